#include "calibration/fit/ray_uncertainty.h"

#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/ray_function.h"
#include "common/check.h"
#include "common/input_error.h"

namespace parallax {
namespace {

constexpr int kParameters = kModuleTangentSize + 1;  // the module's tangent, then k

using ModuleManifold =
    ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<9>>;

// Central-difference steps: radians, metres, focal/centre as fractions of the width, distortion
// coefficients, then k (1/m). Each moves a ray by ~1e-6 of its length: far above rounding,
// far below the fit's σ, where the map is linear.
constexpr std::array<double, kParameters> kStep = {1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-7,
                                                   1e-7, 1e-7, 1e-7, 1e-7, 1e-7, 1e-6};

// The fitted model with one tangent parameter moved by `delta`.
void perturb(const DisplayModel& fitted, int module, int parameter, double delta,
             DisplayModel* out) {
  const size_t m = static_cast<size_t>(module);
  out->modules[m] = fitted.modules[m];
  out->screen.curvature = fitted.screen.curvature;
  if (parameter == kModuleTangentSize) {
    out->screen.curvature += delta;
    return;
  }
  const std::array<double, kModuleBlockSize> block = packModule(fitted.modules[m]);
  std::array<double, kModuleTangentSize> tangent{};
  tangent[static_cast<size_t>(parameter)] = delta;
  std::array<double, kModuleBlockSize> moved;
  ModuleManifold().Plus(block.data(), tangent.data(), moved.data());
  unpackModule(moved.data(), &out->modules[m]);
}

}  // namespace

void RayUncertaintyOptions::validate() const {
  if (stepPx < 0 || stepPx > kMaxModuleSide)
    throw InputError({"", "step_px", 0}, fmt::format("must be 0..{}", kMaxModuleSide));
}

RayUncertainty predictRayUncertainty(const DisplayModel& fitted, int module,
                                     const Eigen::MatrixXd& covariance,
                                     const RayUncertaintyOptions& options) {
  options.validate();
  PARALLAX_CHECK(module >= 0 && module < static_cast<int>(fitted.modules.size()));
  PARALLAX_CHECK_OP(covariance.rows(), ==, kParameters);
  PARALLAX_CHECK_OP(covariance.cols(), ==, kParameters);
  RayUncertainty out;
  if (!covariance.allFinite()) {
    out.bounded = false;
    out.worstPx = out.worstObserverMm = out.rmsPx = out.rmsObserverMm =
        std::numeric_limits<double>::infinity();
    return out;
  }
  const OpticalModule& fittedModule = fitted.modules[static_cast<size_t>(module)];
  const RayFunction rays(fitted, module);
  // The fitted model with each parameter moved either way, made once for all pixels.
  std::vector<DisplayModel> plus(kParameters, fitted), minus(kParameters, fitted);
  std::vector<RayFunction> plusRays, minusRays;
  std::vector<ModuleOptics> plusOptics, minusOptics;
  for (int p = 0; p < kParameters; ++p) {
    const double h = kStep[static_cast<size_t>(p)];
    perturb(fitted, module, p, h, &plus[static_cast<size_t>(p)]);
    perturb(fitted, module, p, -h, &minus[static_cast<size_t>(p)]);
  }
  for (int p = 0; p < kParameters; ++p) {
    plusRays.emplace_back(plus[static_cast<size_t>(p)], module);
    minusRays.emplace_back(minus[static_cast<size_t>(p)], module);
    plusOptics.emplace_back(plus[static_cast<size_t>(p)].modules[static_cast<size_t>(module)]);
    minusOptics.emplace_back(minus[static_cast<size_t>(p)].modules[static_cast<size_t>(module)]);
  }
  const int step = options.stepPx > 0 ? options.stepPx : std::max(4, fittedModule.width / 32);
  double sumPx = 0.0, sumMm = 0.0;
  for (int j = step / 2; j < fittedModule.height; j += step) {
    for (int i = step / 2; i < fittedModule.width; i += step) {
      const double u = i + 0.5, v = j + 0.5;
      const PixelRay ray = rays.at(u, v);
      if (!ray.valid()) continue;  // masked: the pixel lights nothing
      Eigen::Matrix<double, 2, kParameters> pixelJacobian =
          Eigen::Matrix<double, 2, kParameters>::Zero();
      Eigen::Matrix<double, 3, kParameters> originJacobian;
      bool ok = true;
      for (int p = 0; p < kParameters && ok; ++p) {
        const size_t q = static_cast<size_t>(p);
        const double h = kStep[q];
        // The ray continued past the screen's edges, so an edge pixel still differentiates.
        const PixelRay a = plusRays[q].atUnclipped(u, v);
        const PixelRay b = minusRays[q].atUnclipped(u, v);
        ok = a.valid() && b.valid();
        if (!ok) break;
        originJacobian.col(p) = (a.origin - b.origin) / (2.0 * h);
        if (p == kModuleTangentSize) continue;  // the true screen point's pixel ignores k
        Eigen::Vector2d ua, ub;
        ok = plusOptics[q].project(ray.screenPoint - plusOptics[q].position(), &ua) &&
             minusOptics[q].project(ray.screenPoint - minusOptics[q].position(), &ub);
        pixelJacobian.col(p) = (ua - ub) / (2.0 * h);
      }
      if (!ok) continue;
      const double pixelVariance = (pixelJacobian * covariance * pixelJacobian.transpose()).trace();
      const double originVariance =
          (originJacobian * covariance * originJacobian.transpose()).trace();
      const double sdPx = std::sqrt(std::max(0.0, pixelVariance));
      const double sdMm = 1e3 * std::sqrt(std::max(0.0, originVariance));
      ++out.samples;
      sumPx += sdPx * sdPx;
      sumMm += sdMm * sdMm;
      out.worstPx = std::max(out.worstPx, sdPx);
      out.worstObserverMm = std::max(out.worstObserverMm, sdMm);
    }
  }
  if (out.samples > 0) {
    out.rmsPx = std::sqrt(sumPx / out.samples);
    out.rmsObserverMm = std::sqrt(sumMm / out.samples);
  }
  return out;
}

}  // namespace parallax
