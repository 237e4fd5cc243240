#include "calibration/display/ray_error.h"

#include <algorithm>
#include <cmath>

#include "calibration/display/ray_function.h"
#include "common/check.h"
#include "common/input_error.h"

namespace parallax {

void RayErrorOptions::validate() const {
  if (stepPx < 1) throw InputError({"", "step_px", 0}, "must be >= 1");
}

void RayErrorStats::merge(const RayErrorStats& o) {
  // RMS fields hold RMS; combine through the sums of squares.
  auto combine = [&](double a, double b) {
    const long n = samples + o.samples;
    return n ? std::sqrt((a * a * samples + b * b * o.samples) / static_cast<double>(n)) : 0.0;
  };
  rmsPx = combine(rmsPx, o.rmsPx);
  rmsScreenMm = combine(rmsScreenMm, o.rmsScreenMm);
  rmsObserverMm = combine(rmsObserverMm, o.rmsObserverMm);
  maxPx = std::max(maxPx, o.maxPx);
  maxScreenMm = std::max(maxScreenMm, o.maxScreenMm);
  maxObserverMm = std::max(maxObserverMm, o.maxObserverMm);
  samples += o.samples;
  maskMismatches += o.maskMismatches;
}

std::vector<RayErrorStats> compareRays(const DisplayModel& truth, const DisplayModel& fitted,
                                       const RayErrorOptions& options) {
  options.validate();
  PARALLAX_CHECK_OP(truth.modules.size(), ==, fitted.modules.size());
  std::vector<RayErrorStats> out(truth.modules.size());
  for (size_t m = 0; m < truth.modules.size(); ++m) {
    const OpticalModule& mt = truth.modules[m];
    PARALLAX_CHECK_OP(mt.width, ==, fitted.modules[m].width);
    PARALLAX_CHECK_OP(mt.height, ==, fitted.modules[m].height);
    const RayFunction rt(truth, static_cast<int>(m));
    const RayFunction rf(fitted, static_cast<int>(m));
    RayErrorStats& st = out[m];
    double sumPx = 0.0, sumScreen = 0.0, sumObserver = 0.0;
    for (int j = options.stepPx / 2; j < mt.height; j += options.stepPx) {
      for (int i = options.stepPx / 2; i < mt.width; i += options.stepPx) {
        const double u = i + 0.5, v = j + 0.5;
        const PixelRay a = rt.at(u, v);
        const PixelRay b = rf.at(u, v);
        if (a.valid() != b.valid()) {
          ++st.maskMismatches;
          continue;
        }
        if (!a.valid()) continue;
        Eigen::Vector2d px;
        if (!rf.optics().project(a.screenPoint - rf.optics().position(), &px)) {
          ++st.maskMismatches;
          continue;
        }
        const double ePx = (px - Eigen::Vector2d(u, v)).norm();
        const double eScreen = 1e3 * (a.screenPoint - b.screenPoint).norm();
        const double eObserver = 1e3 * (a.origin - b.origin).norm();
        if (!std::isfinite(ePx) || !std::isfinite(eScreen) || !std::isfinite(eObserver)) {
          ++st.maskMismatches;
          continue;
        }
        ++st.samples;
        sumPx += ePx * ePx;
        sumScreen += eScreen * eScreen;
        sumObserver += eObserver * eObserver;
        st.maxPx = std::max(st.maxPx, ePx);
        st.maxScreenMm = std::max(st.maxScreenMm, eScreen);
        st.maxObserverMm = std::max(st.maxObserverMm, eObserver);
      }
    }
    if (st.samples) {
      const double n = static_cast<double>(st.samples);
      st.rmsPx = std::sqrt(sumPx / n);
      st.rmsScreenMm = std::sqrt(sumScreen / n);
      st.rmsObserverMm = std::sqrt(sumObserver / n);
    }
  }
  return out;
}

RayErrorStats totalRayError(const std::vector<RayErrorStats>& perModule) {
  RayErrorStats total;
  for (const RayErrorStats& s : perModule) total.merge(s);
  return total;
}

}  // namespace parallax
