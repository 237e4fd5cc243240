#include "calibration/fit/ray_uncertainty.h"

#include <ceres/manifold.h>
#include <ceres/product_manifold.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

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
  if (columns < 2 || columns > 256) throw InputError({"", "columns", 0}, "must be 2..256");
  if (rows < 2 || rows > 256) throw InputError({"", "rows", 0}, "must be 2..256");
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
  // Two scratch models, one per side of each difference.
  DisplayModel plus = fitted, minus = fitted;
  double sumPx = 0.0, sumMm = 0.0;
  for (int gy = 0; gy < options.rows; ++gy) {
    for (int gx = 0; gx < options.columns; ++gx) {
      // Pixel centres from the first to the last: the image's corners are on the grid.
      const double u = 0.5 + (fittedModule.width - 1.0) * gx / (options.columns - 1);
      const double v = 0.5 + (fittedModule.height - 1.0) * gy / (options.rows - 1);
      const PixelRay ray = rays.at(u, v);
      if (!ray.valid()) continue;  // masked: the pixel lights nothing
      Eigen::Matrix<double, 2, kParameters> pixelJacobian =
          Eigen::Matrix<double, 2, kParameters>::Zero();
      Eigen::Matrix<double, 3, kParameters> originJacobian;
      bool ok = true;
      for (int p = 0; p < kParameters && ok; ++p) {
        const double h = kStep[static_cast<size_t>(p)];
        perturb(fitted, module, p, h, &plus);
        perturb(fitted, module, p, -h, &minus);
        // The ray continued past the screen's edges, so an edge pixel still differentiates.
        const PixelRay a = RayFunction(plus, module).atUnclipped(u, v);
        const PixelRay b = RayFunction(minus, module).atUnclipped(u, v);
        ok = a.valid() && b.valid();
        if (!ok) break;
        originJacobian.col(p) = (a.origin - b.origin) / (2.0 * h);
        if (p == kModuleTangentSize) continue;  // the true screen point's pixel ignores k
        const ModuleOptics pa(plus.modules[static_cast<size_t>(module)]);
        const ModuleOptics pb(minus.modules[static_cast<size_t>(module)]);
        Eigen::Vector2d ua, ub;
        ok = pa.project(ray.screenPoint - pa.position(), &ua) &&
             pb.project(ray.screenPoint - pb.position(), &ub);
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
