// An independent check by hand: a flat 1.0 m × 0.6 m screen, modules on a line 0.7 m behind it
// looking straight at it, observer line 2 m in front at the screen centre's height. The rays
// are written here in closed form for both transfers and compared every 64th pixel.

#include <gtest/gtest.h>

#include <cmath>

#include "calibration/display/ray_function.h"

namespace parallax {
namespace {

DisplayModel handDisplay(ScreenTransfer transfer) {
  DisplayModel model;
  model.screen.width = 1.0;
  model.screen.height = 0.6;
  model.screen.curvature = 0.0;
  model.screen.transfer = transfer;
  model.observer = {0.0, 2.0};
  model.displayableBox = {{-0.5, -0.3, -0.2}, {0.5, 0.3, 0.2}};
  for (int i = 0; i < 5; ++i) {
    OpticalModule m;
    m.id = i;
    m.position = {-0.4 + 0.2 * i, 0.0, -0.7};
    m.orientation = Eigen::Quaterniond(0, 0, 0, 1);  // straight at the screen, upright
    m.width = 640;
    m.height = 480;
    m.fx = m.fy = 500.0;
    m.cx = 320.0;
    m.cy = 240.0;
    m.mirror = true;
    model.modules.push_back(m);
  }
  model.validate();
  return model;
}

TEST(HandComputedRays, MatchTheClosedFormForBothTransfers) {
  for (ScreenTransfer transfer : {ScreenTransfer::kLinear, ScreenTransfer::kConical}) {
    const DisplayModel model = handDisplay(transfer);
    int compared = 0, masked = 0;
    for (int index = 0; index < 5; ++index) {
      const OpticalModule& m = model.modules[static_cast<size_t>(index)];
      const RayFunction rays(model, index);
      for (int pixel = 0; pixel < m.width * m.height; pixel += 64) {
        const int column = pixel % m.width, row = pixel / m.width;
        // Module frame: (−xn, yn, 1) after the mirror; a half turn about z makes it (xn, −yn, 1).
        const double xn = (column + 0.5 - 320.0) / 500.0, yn = (row + 0.5 - 240.0) / 500.0;
        const double sx = m.position.x() + 0.7 * xn, sy = -0.7 * yn;
        const PixelRay ray = rays.atPixel(column, row);
        if (std::abs(sx) > 0.5 || std::abs(sy) > 0.3) {
          EXPECT_FALSE(ray.valid());
          ++masked;
          continue;
        }
        ASSERT_TRUE(ray.valid());
        double ox;
        if (transfer == ScreenTransfer::kLinear) {
          ox = sx + xn * 2.0;  // d.x/d.z = xn, Z = 2
        } else {
          // a/√(1 − a²) with a = xn/√(xn² + yn² + 1) is xn/√(yn² + 1).
          ox = sx + std::hypot(sy, 2.0) * xn / std::sqrt(yn * yn + 1.0);
        }
        EXPECT_NEAR(ray.screenPoint.x(), sx, 1e-12);
        EXPECT_NEAR(ray.screenPoint.y(), sy, 1e-12);
        EXPECT_EQ(ray.screenPoint.z(), 0.0);
        EXPECT_NEAR(ray.origin.x(), ox, 1e-12);
        EXPECT_EQ(ray.origin.y(), 0.0);
        EXPECT_EQ(ray.origin.z(), 2.0);
        const Eigen::Vector3d expected =
            (Eigen::Vector3d(sx, sy, 0.0) - Eigen::Vector3d(ox, 0.0, 2.0)).normalized();
        EXPECT_LT((ray.direction() - expected).norm(), 1e-12);
        ++compared;
      }
    }
    EXPECT_GT(compared, 5000);
    EXPECT_GT(masked, 100);
  }
}

}  // namespace
}  // namespace parallax
