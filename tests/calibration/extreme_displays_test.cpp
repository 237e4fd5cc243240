// Stiff and extreme displays: no NaN anywhere, the forward map round trip holds, and the masked
// pixels are exactly those whose module ray misses the screen or whose transfer has no
// solution, both decided here by independent brute-force searches.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "calibration/display/forward_map.h"
#include "calibration/display/ray_function.h"
#include "calibration/display/ray_textures.h"
#include "test_displays.h"

namespace parallax {
namespace {

enum class Verdict { kHit, kMiss, kAmbiguous };

// Does p + t d cross the screen from behind inside its extent? Marches along the ray over the
// part whose x lies on the screen, watching the sign of z − sag(x), then bisects.
Verdict independentScreenHit(const Screen& screen, const Eigen::Vector3d& p,
                             const Eigen::Vector3d& d, Eigen::Vector3d* hit) {
  const double half = 0.5 * screen.width;
  double t0 = 0.0, t1 = 100.0;  // the ray's span over |x| ≤ W/2 (all of it when d.x = 0)
  if (d.x() != 0.0) {
    const double ta = (-half - p.x()) / d.x(), tb = (half - p.x()) / d.x();
    t0 = std::max(0.0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  } else if (std::abs(p.x()) > half) {
    return Verdict::kMiss;
  }
  if (!(t1 > t0)) return Verdict::kMiss;
  auto g = [&](double t) {
    const double x = std::clamp(p.x() + t * d.x(), -half, half);
    return (p.z() + t * d.z()) - screen.sag(x);
  };
  constexpr int kSteps = 2000;
  double prevT = t0, prevG = g(t0);
  for (int i = 1; i <= kSteps; ++i) {
    const double t = t0 + (t1 - t0) * i / kSteps;
    const double gt = g(t);
    if (prevG < 0.0 && gt >= 0.0) {
      double lo = prevT, hi = t;
      for (int k = 0; k < 200; ++k) {
        const double mid = 0.5 * (lo + hi);
        (g(mid) < 0.0 ? lo : hi) = mid;
      }
      const Eigen::Vector3d x = p + hi * d;
      *hit = x;
      // Too close to an edge to call either way in floating point.
      if (std::abs(std::abs(x.x()) - half) < 1e-9 ||
          std::abs(std::abs(x.y()) - 0.5 * screen.height) < 1e-9) {
        return Verdict::kAmbiguous;
      }
      return std::abs(x.y()) <= 0.5 * screen.height ? Verdict::kHit : Verdict::kMiss;
    }
    prevT = t;
    prevG = gt;
  }
  return Verdict::kMiss;
}

// Can an outgoing direction e from s toward the observer line have e·t = a? Searches the range of
// e·t over the whole line by sampling the angle φ (X − s.x = L tan φ) and refining the extremes.
Verdict independentConeReachesLine(const Screen& screen, const ObserverLine& observer,
                                   const Eigen::Vector3d& s, const Eigen::Vector3d& d) {
  const Eigen::Vector3d t = screen.tangent(s.x());
  const double a = d.dot(t);
  const double yy = observer.y - s.y(), zz = observer.z - s.z();
  const double length = std::hypot(yy, zz);
  auto cosine = [&](double phi) {
    return Eigen::Vector3d(length * std::tan(phi), yy, zz).normalized().dot(t);
  };
  double lo = 2.0, hi = -2.0, argLo = 0.0, argHi = 0.0;
  constexpr int kSamples = 1001;
  const double step = std::numbers::pi / (kSamples + 1);
  for (int i = 1; i <= kSamples; ++i) {
    const double phi = -0.5 * std::numbers::pi + i * step;
    const double c = cosine(phi);
    if (c < lo) lo = c, argLo = phi;
    if (c > hi) hi = c, argHi = phi;
  }
  // Golden-section refinement of both extremes (the cosine is unimodal in φ).
  auto refine = [&](double centre, double sign) {
    double a0 = centre - step, b0 = centre + step;
    for (int k = 0; k < 100; ++k) {
      const double m1 = a0 + 0.382 * (b0 - a0), m2 = a0 + 0.618 * (b0 - a0);
      if (sign * cosine(m1) > sign * cosine(m2))
        b0 = m2;
      else
        a0 = m1;
    }
    return cosine(0.5 * (a0 + b0));
  };
  hi = std::max(hi, refine(argHi, 1.0));
  lo = std::min(lo, refine(argLo, -1.0));
  if (std::abs(a - hi) < 1e-9 || std::abs(a - lo) < 1e-9) return Verdict::kAmbiguous;
  return (a > lo && a < hi) ? Verdict::kHit : Verdict::kMiss;
}

struct Extreme {
  std::string name;
  double curvature = 0.0;
  double yawDeg = 0.0;  // added to every module
  double observerZ = 2.0;
  double focalPx = 0.0;  // 0: the preset's
};

void PrintTo(const Extreme& e, std::ostream* os) { *os << e.name; }

class ExtremeDisplays : public ::testing::TestWithParam<std::tuple<Extreme, ScreenTransfer>> {};

DisplayModel makeExtreme(const Extreme& e, ScreenTransfer transfer) {
  DisplayModel model = testing::smallDisplay(e.curvature, transfer, 5, 192, 144);
  model.observer.z = e.observerZ;
  for (OpticalModule& m : model.modules) {
    m.orientation =
        (Eigen::AngleAxisd(e.yawDeg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()) *
         m.orientation)
            .normalized();
    if (e.focalPx > 0.0) m.fx = m.fy = e.focalPx;
    m.k1 = -0.05;  // a little barrel distortion exercises the undistortion everywhere
  }
  model.validate();
  return model;
}

TEST_P(ExtremeDisplays, NoNanRoundTripAndExactMask) {
  const auto& [extreme, transfer] = GetParam();
  const DisplayModel model = makeExtreme(extreme, transfer);
  long valid = 0, masked = 0, ambiguous = 0, roundTrips = 0;
  double worstRoundTrip = 0.0;
  for (int index = 0; index < static_cast<int>(model.modules.size()); ++index) {
    const RayTextures textures = generateRayTextures(model, index);
    const RayFunction rays(model, index);
    const ForwardMap forward(model, index);
    const OpticalModule& m = model.modules[static_cast<size_t>(index)];
    const ModuleOptics optics(m);
    for (int row = 0; row < m.height; row += 3) {
      for (int column = 0; column < m.width; column += 3) {
        const CompactRay& compact = textures.at(column, row);
        const PixelRay ray = rays.atPixel(column, row);
        ASSERT_EQ(compact.masked(), !ray.valid());
        if (!compact.masked()) {
          ASSERT_TRUE(std::isfinite(compact.screenX) && std::isfinite(compact.screenY) &&
                      std::isfinite(compact.originX));
          ASSERT_TRUE(ray.origin.allFinite() && ray.screenPoint.allFinite());
          ASSERT_TRUE(textures.frame().direction(compact).allFinite());
        }
        // The independent verdict on this pixel.
        Eigen::Vector3d direction;
        if (!optics.rayDirection(column + 0.5, row + 0.5, &direction)) {
          ASSERT_EQ(ray.status, RayStatus::kOutsideLens);
          ++masked;
          continue;
        }
        Eigen::Vector3d hit;
        const Verdict onScreen = independentScreenHit(model.screen, m.position, direction, &hit);
        Verdict reaches = Verdict::kMiss;
        if (onScreen == Verdict::kHit) {
          reaches = transfer == ScreenTransfer::kLinear
                        ? Verdict::kHit
                        : independentConeReachesLine(model.screen, model.observer, hit, direction);
        }
        if (onScreen == Verdict::kAmbiguous || reaches == Verdict::kAmbiguous) {
          ++ambiguous;
          continue;
        }
        const bool expectValid = onScreen == Verdict::kHit && reaches == Verdict::kHit;
        ASSERT_EQ(ray.valid(), expectValid)
            << extreme.name << " module " << index << " pixel (" << column << ", " << row
            << "): " << rayStatusName(ray.status);
        if (!expectValid) {
          ++masked;
          ASSERT_EQ(ray.status,
                    onScreen == Verdict::kHit ? RayStatus::kNoTransfer : RayStatus::kMissesScreen);
          continue;
        }
        ++valid;
        EXPECT_LT((hit - ray.screenPoint).norm(), 1e-9);
        if ((row * 7 + column) % 11 == 0) {
          const Eigen::Vector3d point = ray.origin + 1.1 * (ray.screenPoint - ray.origin);
          const ForwardMapResult back = forward.pixelOf(point);
          ASSERT_TRUE(back.ok) << extreme.name << " module " << index << " (" << column << ", "
                               << row << ")";
          const double error = (back.pixel - Eigen::Vector2d(column + 0.5, row + 0.5)).norm();
          worstRoundTrip = std::max(worstRoundTrip, error);
          ++roundTrips;
        }
      }
    }
  }
  EXPECT_LT(worstRoundTrip, 1e-6) << extreme.name;
  EXPECT_GT(valid, 0) << extreme.name;
  EXPECT_LT(ambiguous, std::max(10L, valid / 1000)) << extreme.name;
  ::testing::Test::RecordProperty("valid", std::to_string(valid));
  ::testing::Test::RecordProperty("masked", std::to_string(masked));
  ::testing::Test::RecordProperty("round_trips", std::to_string(roundTrips));
  ::testing::Test::RecordProperty("worst_round_trip_px", fmt::format("{:.3g}", worstRoundTrip));
}

const Extreme kExtremes[] = {
    {"flat_k0", 0.0},
    {"k_1e_minus12", 1e-12},
    {"strongly_curved_R_0_6W", 1.0 / (0.6 * 1.6)},
    {"strongly_convex_R_0_6W", -1.0 / (0.6 * 1.6)},
    {"yawed_plus60", 0.0, 60.0},
    {"yawed_minus60_curved", 0.5, -60.0},
    {"observer_0_3m", 0.0, 0.0, 0.3},
    {"observer_100m", 0.4, 0.0, 100.0},
    {"focal_200px", 0.0, 0.0, 2.0, 200.0},
    {"focal_20000px", 0.3, 0.0, 2.0, 20000.0},
};

INSTANTIATE_TEST_SUITE_P(Stiff, ExtremeDisplays,
                         ::testing::Combine(::testing::ValuesIn(kExtremes),
                                            ::testing::Values(ScreenTransfer::kConical,
                                                              ScreenTransfer::kLinear)),
                         [](const auto& p) {
                           return std::get<0>(p.param).name + "_" +
                                  transferName(std::get<1>(p.param));
                         });

}  // namespace
}  // namespace parallax
