// The scene's footprint on a module (tracer/scene_footprint.h): frames through it are exact only
// if a bigger box never leaves out a pixel a smaller one keeps, in float arithmetic, on flat and
// curved screens; and every pixel it leaves out is masked or misses the box.

#include "tracer/scene_footprint.h"

#include <gtest/gtest.h>

#include <random>

#include "calibration/display/display_presets.h"
#include "tracer/primary_ray_kernel.h"

namespace parallax {
namespace {

std::vector<RayTextures> moduleTextures(double curvature) {
  NominalDisplayOptions options;
  options.preset = "demo";
  options.modules = 3;
  options.width = 160;
  options.height = 120;
  DisplayModel model = makeNominalDisplay(options);
  model.screen.curvature = curvature;
  std::vector<RayTextures> textures;
  for (int m = 0; m < options.modules; ++m) textures.push_back(generateRayTextures(model, m));
  return textures;
}

// Whether the kernel traces pixel (x, y) against the box.
bool traced(const RayTextures& textures, int x, int y, const Eigen::Vector3f& lo,
            const Eigen::Vector3f& hi) {
  Rgb out;
  StagedRays staged;
  staged.reserve(1);
  PrimaryRayRow row;
  row.rays = &textures.at(x, y);
  row.out = &out;
  row.count = 1;
  row.frame = textures.frame();
  row.boundsMin = lo;
  row.boundsMax = hi;
  makePrimaryRays(row, &staged);
  return staged.size() == 1;
}

class SceneFootprintTest : public ::testing::TestWithParam<double> {};

TEST_P(SceneFootprintTest, BiggerBoxesHoldSmallerOnesFootprints) {
  const std::vector<RayTextures> textures = moduleTextures(GetParam());
  std::mt19937 random(11);
  std::uniform_real_distribution<float> centre(-0.3f, 0.3f), size(0.005f, 0.4f), grow(0.0f, 0.05f);
  for (int trial = 0; trial < 40; ++trial) {
    const Eigen::Vector3f c(centre(random), centre(random) + 0.1f, centre(random));
    const Eigen::Vector3f half(size(random), size(random), size(random));
    const Eigen::Vector3f lo = c - half, hi = c + half;
    // Some faces moved out by a float step only: the rounding case.
    Eigen::Vector3f bigLo = lo, bigHi = hi;
    for (int a = 0; a < 3; ++a) {
      bigLo[a] = trial % 2 ? std::nextafter(lo[a], -1e9f) : lo[a] - grow(random);
      bigHi[a] = trial % 3 ? std::nextafter(hi[a], 1e9f) : hi[a] + grow(random);
    }
    for (const RayTextures& t : textures) {
      const SceneFootprint small(t, lo, hi), big(t, bigLo, bigHi);
      EXPECT_TRUE(big.holds(lo, hi));
      EXPECT_FALSE(small.holds(bigLo, bigHi));
      EXPECT_GE(big.livePixels(), small.livePixels());
      for (int y = 0; y < t.height(); ++y) {
        const FootprintRow& s = small.row(y);
        const FootprintRow& b = big.row(y);
        if (s.begin < s.end) {
          EXPECT_LE(b.begin, s.begin) << "row " << y;
          EXPECT_GE(b.end, s.end) << "row " << y;
        }
        EXPECT_EQ(s.masked + s.missed + (s.end - s.begin), t.width());
      }
    }
  }
}

TEST_P(SceneFootprintTest, WhatItLeavesOutIsMaskedOrMissesTheBox) {
  const std::vector<RayTextures> textures = moduleTextures(GetParam());
  const Eigen::Vector3f lo(-0.25f, 0.0f, -0.2f), hi(0.2f, 0.35f, 0.15f);
  long inside = 0;
  for (const RayTextures& t : textures) {
    const SceneFootprint footprint(t, lo, hi);
    for (int y = 0; y < t.height(); ++y) {
      const FootprintRow& row = footprint.row(y);
      int masked = 0;
      for (int x = 0; x < t.width(); ++x) {
        if (x >= row.begin && x < row.end) {
          inside += traced(t, x, y, lo, hi);
          continue;
        }
        EXPECT_FALSE(traced(t, x, y, lo, hi)) << "pixel " << x << ", " << y;
        masked += t.at(x, y).masked();
      }
      EXPECT_EQ(row.masked, masked) << "row " << y;
    }
  }
  EXPECT_GT(inside, 0);
}

INSTANTIATE_TEST_SUITE_P(FlatAndCurved, SceneFootprintTest, ::testing::Values(0.0, 0.8));

}  // namespace
}  // namespace parallax
