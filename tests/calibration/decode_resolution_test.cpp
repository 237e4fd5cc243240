// A station's module pixels a camera pixel, from its decodes alone.

#include "calibration/fit/decode_resolution.h"

#include <gtest/gtest.h>

#include <cmath>

namespace parallax {
namespace {

// A station seeing one module on a grid every `step` camera px, `scale` module px a camera px
// across and `scale` / 2 down (mirrored across, as a rear-projected module is), each camera
// pixel moved by up to 0.4 px as the lens blur's correction moves it.
std::vector<Correspondence> grid(int station, double scale, int step) {
  std::vector<Correspondence> out;
  for (int y = 0; y < 60; y += step) {
    for (int x = 0; x < 80; x += step) {
      const Eigen::Vector2d at(x + 0.5 + 0.4 * std::sin(x * 0.7 + y), y + 0.5);
      out.push_back({station, 3, at, {500.0 - scale * at.x(), 0.5 * scale * at.y()}});
    }
  }
  return out;
}

TEST(DecodeResolution, MeasuresTheModulePixelsACameraPixelSpansAtEachStation) {
  std::vector<Correspondence> decoded = grid(0, 1.4, 4);
  const std::vector<Correspondence> far = grid(2, 4.3, 4);
  decoded.insert(decoded.end(), far.begin(), far.end());
  const std::vector<StationResolution> r = decodeResolution(decoded);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].station, 0);
  EXPECT_NEAR(r[0].modulePxACameraPx, 1.4, 1e-9);
  EXPECT_EQ(r[1].station, 2);
  EXPECT_NEAR(r[1].modulePxACameraPx, 4.3, 1e-9);
  EXPECT_GT(r[1].modulePxACameraPx, kCoarseModulePxACameraPx);
  EXPECT_LT(r[0].modulePxACameraPx, kCoarseModulePxACameraPx);
  EXPECT_GT(r[1].pairs, 200);
}

TEST(DecodeResolution, DecodesWithoutNeighboursMeasureNothing) {
  // One decode a row and column, and two far apart: nothing to measure, no station listed.
  const std::vector<Correspondence> lone = {{1, 0, {10.5, 10.5}, {20.0, 20.0}},
                                            {1, 0, {50.5, 40.5}, {90.0, 70.0}}};
  EXPECT_TRUE(decodeResolution(lone).empty());
  EXPECT_TRUE(decodeResolution({}).empty());
}

}  // namespace
}  // namespace parallax
