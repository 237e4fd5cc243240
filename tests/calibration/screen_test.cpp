#include "calibration/display/screen.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace parallax {
namespace {

// Long-double reference by the series R − √(R² − x²) = k x²/2 + k³x⁴/8 + k⁵x⁶/16 + 5k⁷x⁸/128 + …,
// which has no cancellation at all for small k x.
long double sagSeries(long double k, long double x) {
  const long double u = k * x;
  return x * x * k * (0.5L + u * u * (0.125L + u * u * (0.0625L + u * u * 0.0390625L)));
}

TEST(ScreenSag, CancellationFreeWhereTheNaiveFormLosesAllDigits) {
  const double k = 1e-9;
  const double radius = 1.0 / k;
  double worstRelative = 0.0, naiveWorst = 0.0;
  for (int i = 1; i <= 1000; ++i) {
    const double x = 0.8 * i / 1000.0;
    const long double reference = sagSeries(k, x);
    const double sag = screenSag(k, x);
    const double relative = std::abs(static_cast<double>((sag - reference) / reference));
    worstRelative = std::max(worstRelative, relative);
    const double naive = radius - std::sqrt(radius * radius - x * x);
    naiveWorst =
        std::max(naiveWorst, std::abs(static_cast<double>((naive - reference) / reference)));
  }
  // ≤ a few ulp of relative error (ulp = 2.2e-16).
  EXPECT_LE(worstRelative, 4 * std::numeric_limits<double>::epsilon());
  // The naive R − sqrt(R² − x²) has no correct digits left here: that is why k is the parameter.
  EXPECT_GT(naiveWorst, 0.1);
}

TEST(ScreenSag, FlatScreenIsExactlyFlat) {
  Screen screen;
  screen.curvature = 0.0;
  for (double x : {-0.8, -0.1, 0.0, 0.3, 0.8}) {
    EXPECT_EQ(screen.sag(x), 0.0);
    EXPECT_EQ(screen.slope(x), 0.0);
    EXPECT_EQ(screen.tangent(x), Eigen::Vector3d(1, 0, 0));
  }
}

TEST(ScreenSag, MatchesTheCircleForStrongCurvature) {
  const double radius = 0.96;  // R = 0.6 W for a 1.6 m screen
  for (double x : {-0.8, -0.5, 0.2, 0.79}) {
    EXPECT_NEAR(screenSag(1.0 / radius, x), radius - std::sqrt(radius * radius - x * x), 1e-15);
    EXPECT_NEAR(screenSag(-1.0 / radius, x), -(radius - std::sqrt(radius * radius - x * x)), 1e-15);
  }
}

TEST(ScreenIntersect, ExactOnAFlatScreenAndOnTheSurfaceWhenCurved) {
  Screen screen;
  double t;
  Eigen::Vector3d hit;
  ASSERT_TRUE(screen.intersect({0.1, 0.05, -0.7}, {0.2, -0.1, 1.0}, &t, &hit));
  EXPECT_EQ(hit.z(), 0.0);
  EXPECT_DOUBLE_EQ(t, 0.7);
  EXPECT_DOUBLE_EQ(hit.x(), 0.1 + 0.7 * 0.2);
  screen.curvature = 1.0;
  ASSERT_TRUE(screen.intersect({0.1, 0.05, -0.7}, {0.5, -0.1, 1.0}, &t, &hit));
  EXPECT_EQ(hit.z(), screen.sag(hit.x()));
  EXPECT_NEAR((Eigen::Vector3d(0.1, 0.05, -0.7) + t * Eigen::Vector3d(0.5, -0.1, 1.0) - hit).norm(),
              0, 1e-15);
}

TEST(ScreenIntersect, GrazingRaysStayFiniteAndMissCleanly) {
  for (double k : {0.0, 1e-12, 0.9, -0.9}) {
    Screen screen;
    screen.curvature = k;
    double t;
    Eigen::Vector3d hit;
    // Nearly parallel to the screen: lands far outside its extent, or on it with finite values.
    for (double dz : {1e-3, 1e-9, 1e-15, 0.0, -1e-15}) {
      const bool ok = screen.intersect({0.0, 0.0, -1e-3}, {1.0, 0.0, dz}, &t, &hit);
      if (ok) {
        EXPECT_TRUE(hit.allFinite());
        EXPECT_TRUE(screen.contains(hit.x(), hit.y()));
      }
    }
    // Travelling away from the screen never hits it.
    EXPECT_FALSE(screen.intersect({0.0, 0.0, -1.0}, {0.1, 0.0, -1.0}, &t, &hit));
  }
}

}  // namespace
}  // namespace parallax
