#include "calibration/display/world_to_physical.h"

#include <gtest/gtest.h>

#include "common/input_error.h"

namespace parallax {
namespace {

TEST(WorldToPhysical, UniformScaleCentredInsideTheDisplayableBox) {
  const Box3 displayable{{-0.8, -0.45, -0.25}, {0.8, 0.45, 0.25}};
  for (double scale : {1e-3, 1.0, 1e4}) {
    const Box3 world{Eigen::Vector3d(-1, 0, 2) * scale + Eigen::Vector3d::Constant(1e4),
                     Eigen::Vector3d(3, 1, 3) * scale + Eigen::Vector3d::Constant(1e4)};
    const WorldToPhysical map = physicalFromWorld(world, displayable);
    // The box lands centred, inside B_P, touching it on its tightest axis (here x: 4 → 1.6).
    EXPECT_NEAR((map.point(world.center()) - displayable.center()).norm(), 0.0, 1e-9);
    EXPECT_NEAR(map.scale * world.size().x(), 1.6, 1e-12);
    EXPECT_TRUE(displayable.contains(map.point(world.min) + Eigen::Vector3d::Constant(1e-9)));
    EXPECT_TRUE(displayable.contains(map.point(world.max) - Eigen::Vector3d::Constant(1e-9)));
    // No per-axis stretch: angles are kept.
    EXPECT_EQ(map.vector({1, 2, 3}).normalized(), Eigen::Vector3d(1, 2, 3).normalized());
    EXPECT_NEAR((map.worldPoint(map.point({1, 2, 3})) - Eigen::Vector3d(1, 2, 3)).norm(), 0.0,
                1e-9 * (1 + scale));
  }
}

TEST(WorldToPhysical, AFlatSceneIsFineButAPointIsNot) {
  const Box3 displayable{{-0.8, -0.45, -0.25}, {0.8, 0.45, 0.25}};
  EXPECT_NO_THROW(physicalFromWorld({{0, 0, 0}, {1, 1, 0}}, displayable));
  EXPECT_THROW(physicalFromWorld({{1, 1, 1}, {1, 1, 1}}, displayable), InputError);
  EXPECT_THROW(physicalFromWorld({{0, 0, 0}, {-1, 1, 1}}, displayable), InputError);
  EXPECT_THROW(physicalFromWorld({{0, 0, 0}, {std::nan(""), 1, 1}}, displayable), InputError);
}

}  // namespace
}  // namespace parallax
