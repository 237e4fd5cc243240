// The meshes a tile's shadow rays are tested against (shadow_block_cull.h): a mesh may be left
// out only where the kernel's own per-ray test would find every ray of the tile passing it, on
// every instruction set, for clusters of surfaces from a millimetre to a metre wide, near and far
// from spheres and planes of every size, under lights from every direction.

#include "tracer/shadow_block_cull.h"

#include <gtest/gtest.h>
#include <hwy/highway.h>
#include <hwy/targets.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace parallax {
namespace {

struct TargetGuard {
  ~TargetGuard() { hwy::SetSupportedTargetsForTest(0); }  // back to what the CPU has
};

// The kernel's test of one ray (shadow_ray_kernel.cpp, MayMeetSphere and the plane's side) in
// float: may the ray from `a` toward the directional light `l` meet bound k?
bool mayMeet(const Eigen::Vector3f& a, const Eigen::Vector3f& l, const OccluderBound& bound,
             int planeSide) {
  const Eigen::Vector3f w = bound.sphere.head<3>() - a;
  const float along = w.x() * l.x() + (w.y() * l.y() + w.z() * l.z());
  const float square = w.x() * w.x() + (w.y() * w.y() + w.z() * w.z());
  const float r = bound.sphere.w();
  const bool beside = square - along * along > r * r + 1e-5f * square;
  const bool behind = along + r < 0.0f;
  if (beside || behind) return false;
  if (bound.flat() && planeSide != 0) {
    const float start = bound.plane.x() * a.x() +
                        (bound.plane.y() * a.y() + bound.plane.z() * a.z()) - bound.plane.w();
    if (planeSide > 0 ? start > bound.planeMargin : start < -bound.planeMargin) return false;
  }
  return true;
}

TEST(ShadowBlockCull, NoMeshARayMayMeetIsLeftOut) {
  std::mt19937 random(20261206);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const auto direction = [&] {
    Eigen::Vector3f v;
    do v = Eigen::Vector3f(unit(random), unit(random), unit(random));
    while (v.norm() < 0.1f);
    return v.normalized();
  };
  TargetGuard guard;
  long culled = 0, kept = 0, rayTests = 0;
  for (int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    for (int trial = 0; trial < 400; ++trial) {
      // A cluster of surfaces somewhere in a scene of size `scale`.
      const float scale = std::pow(10.0f, unit(random) * 2.0f);
      const float spread = scale * std::pow(10.0f, -1.5f + 1.5f * unit(random));
      const Eigen::Vector3f centre = scale * Eigen::Vector3f(unit(random), unit(random), 0.3f);
      const int n = 1 + static_cast<int>(random() % 200);
      LitSurfaces surfaces;
      surfaces.reset(static_cast<size_t>(n));
      const bool onOneMesh = trial % 3 == 0;
      std::vector<Eigen::Vector3f> starts;
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3f p =
            centre + spread * Eigen::Vector3f(unit(random), unit(random), unit(random));
        // The ray starts off the surface, by OffsetCoordinate's 256 ulps (1/65536 near 0).
        const Eigen::Vector3f normal = direction();
        Eigen::Vector3f a;
        for (int c = 0; c < 3; ++c) {
          a[c] = std::abs(p[c]) < 1.0f / 32.0f
                     ? p[c] + normal[c] / 65536.0f
                     : p[c] + std::copysign(256.0f * std::abs(normal[c]), p[c]) *
                                  (std::nextafter(std::abs(p[c]), 1e30f) - std::abs(p[c]));
        }
        starts.push_back(a);
        surfaces.push(p, normal, normal, Rgb::Ones(), i, 0,
                      LitSurfaces::meshFlags(onOneMesh ? 2 : static_cast<unsigned>(i % 5),
                                             onOneMesh || i % 2 == 0));
      }
      // Spheres near and far, small and large; some meshes flat, with a plane near the cluster.
      std::vector<OccluderBound> bounds(6);
      int planeSide[6] = {};
      const Eigen::Vector3f l = direction();
      for (size_t k = 0; k < bounds.size(); ++k) {
        OccluderBound& b = bounds[k];
        const Eigen::Vector3f c =
            centre + scale * std::pow(10.0f, unit(random)) *
                         Eigen::Vector3f(unit(random), unit(random), unit(random));
        b.sphere << c, scale * std::pow(10.0f, -2.0f + unit(random));
        if (k % 2 == 1) {
          const Eigen::Vector3f normal = direction();
          b.plane << normal, normal.dot(centre + spread * Eigen::Vector3f(unit(random), 0, 0));
          b.planeMargin = 1e-6f * scale;
          const float along = normal.dot(l);
          planeSide[k] = along > 0.0f ? 1 : along < 0.0f ? -1 : 0;
        }
      }
      const SurfaceSpread where = spreadOf(surfaces);
      ASSERT_TRUE(where.known);
      std::uint8_t active[6];
      const size_t count =
          occludersWithin(where, l, bounds.data(), bounds.size(), planeSide, active);
      std::vector<bool> isActive(bounds.size(), false);
      for (size_t i = 0; i < count; ++i) isActive[active[i]] = true;
      for (size_t k = 0; k < bounds.size(); ++k) {
        (isActive[k] ? kept : culled) += 1;
        if (isActive[k]) continue;
        for (int i = 0; i < n; ++i) {
          const bool leaves = onOneMesh && k == 2;
          ++rayTests;
          EXPECT_TRUE(leaves ||
                      !mayMeet(starts[static_cast<size_t>(i)], l, bounds[k], planeSide[k]))
              << hwy::TargetName(target) << " trial " << trial << " mesh " << k << " surface " << i;
        }
      }
    }
  }
  // Both answers came up often: the check above was not empty.
  EXPECT_GT(culled, 1000);
  EXPECT_GT(kept, 1000);
  EXPECT_GT(rayTests, 50000);
}

TEST(ShadowBlockCull, NonFiniteOrNoSurfacesKeepEveryMesh) {
  LitSurfaces surfaces;
  surfaces.reset(4);
  EXPECT_FALSE(spreadOf(surfaces).known);
  const Eigen::Vector3f up = Eigen::Vector3f::UnitY();
  surfaces.push({0, 0, 0}, up, up, Rgb::Ones(), 0, 0, 0);
  surfaces.push({std::numeric_limits<float>::quiet_NaN(), 0, 0}, up, up, Rgb::Ones(), 1, 0, 0);
  const SurfaceSpread where = spreadOf(surfaces);
  EXPECT_FALSE(where.known);
  OccluderBound far;
  far.sphere << 100, -100, 100, 1;  // no ray from the origin upward comes near
  const int side[1] = {0};
  std::uint8_t active[1];
  EXPECT_EQ(occludersWithin(where, up, &far, 1, side, active), 1u);
  surfaces.reset(4);
  surfaces.push({0, 0, 0}, up, up, Rgb::Ones(), 0, 0, 0);
  EXPECT_EQ(occludersWithin(spreadOf(surfaces), up, &far, 1, side, active), 0u);
}

}  // namespace
}  // namespace parallax
