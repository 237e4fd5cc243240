#include "calibration/fit/fit_uncertainty.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "calibration/fit/fit_diagnostics.h"

namespace parallax::fit {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// Largest σ (module px, RMS of u and v) of the pixel that the fitted module uses to light a
// screen point, over a 5 × 5 grid across its image: J Σ Jᵀ with J the derivative of the
// projection with respect to the module's tangent parameters (central differences through
// the manifold), the screen point held fixed.
double worstPixelStdDev(const FitInputs& in, const FitState& state, size_t m,
                        const Eigen::MatrixXd& cov) {
  if (!cov.allFinite()) return std::numeric_limits<double>::infinity();
  OpticalModule fitted = in.nominal.modules[m];
  unpackModule(state.modules[m].data(), &fitted);
  const ModuleOptics optics(fitted);
  const ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<9>>
      manifold;
  const double mirrorSign = fitted.mirror ? -1.0 : 1.0;
  double worst = 0.0;
  for (int gy = 0; gy < 5; ++gy) {
    for (int gx = 0; gx < 5; ++gx) {
      const double u = (0.02 + 0.96 * gx / 4.0) * fitted.width;
      const double v = (0.02 + 0.96 * gy / 4.0) * fitted.height;
      Eigen::Vector3d d, s;
      double t;
      if (!optics.rayDirection(u, v, &d)) continue;
      // Pixels off the screen are masked: their uncertainty does not matter.
      if (!in.nominal.screen.intersect(fitted.position, d, &t, &s)) continue;
      Eigen::Matrix<double, 2, kModuleTangentSize> jacobian;
      bool ok = true;
      for (int p = 0; p < kModuleTangentSize && ok; ++p) {
        // Steps: rotation (rad) and position (m) 1e-6; intrinsics over the width and the
        // distortion 1e-7.
        const double h = p < 6 ? 1e-6 : 1e-7;
        double delta[kModuleTangentSize] = {};
        std::array<double, kModuleBlockSize> plus, minus;
        delta[p] = h;
        manifold.Plus(state.modules[m].data(), delta, plus.data());
        delta[p] = -h;
        manifold.Plus(state.modules[m].data(), delta, minus.data());
        double a[2], b[2];
        ok = projectIntoModule(plus.data(), fitted.width, mirrorSign, Vec3<double>(s), a) &&
             projectIntoModule(minus.data(), fitted.width, mirrorSign, Vec3<double>(s), b);
        jacobian(0, p) = (a[0] - b[0]) / (2.0 * h);
        jacobian(1, p) = (a[1] - b[1]) / (2.0 * h);
      }
      if (!ok) continue;
      const Eigen::Matrix2d pixelCov = jacobian * cov * jacobian.transpose();
      worst = std::max(worst, std::sqrt(std::max(0.0, 0.5 * pixelCov.trace())));
    }
  }
  return worst;
}

}  // namespace

void diagnoseUncertainty(const FitInputs& in, FitState& state, const NoiseLevels& sigmas,
                         FitProblem& built, FitResult* result) {
  const FitOptions& options = in.options;
  // ---- the Jacobian over the estimated blocks: modules first, then cameras and k ----
  std::vector<double*> blocks;
  std::vector<size_t> moduleOf;
  for (size_t m = 0; m < state.modules.size(); ++m) {
    if (in.observed[m] && !in.held[m]) {  // held modules are not estimated: no covariance
      blocks.push_back(state.modules[m].data());
      moduleOf.push_back(m);
    }
  }
  for (auto& cam : state.cameras) blocks.push_back(cam.data());
  if (options.fitCurvature) blocks.push_back(&state.k);
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.apply_loss_function = true;
  eo.num_threads = options.threads;
  ceres::CRSMatrix jacobian;
  double cost = 0.0;
  const int sharedSize =
      kCameraTangentSize * static_cast<int>(state.cameras.size()) + (options.fitCurvature ? 1 : 0);
  if (!built.problem->Evaluate(eo, &cost, nullptr, nullptr, &jacobian)) {
    result->notes.push_back("the Jacobian could not be evaluated at the solution");
    result->converged = false;
    return;
  }
  const InformationBlocks info = informationFromJacobian(
      jacobian.num_rows, jacobian.num_cols, jacobian.rows, jacobian.cols, jacobian.values,
      static_cast<int>(moduleOf.size()), kModuleTangentSize, sharedSize);
  const Diagnostics d = diagnose(info, options.conditioning);

  // ---- modules ----
  for (size_t j = 0; j < moduleOf.size(); ++j) {
    ModuleFit& mf = result->modules[moduleOf[j]];
    mf.conditioning = d.modules[j];
    const double width = in.nominal.modules[moduleOf[j]].width;
    for (int p = 0; p < kModuleTangentSize; ++p) {
      double sd = d.moduleStdDev[j][p];
      if (p < 3)
        sd *= kRadToDeg;
      else if (p < 6)
        sd *= 1e3;
      else if (p < 10)
        sd *= width;
      mf.stdDev[static_cast<size_t>(p)] = sd;
    }
    mf.worstPixelStdDevPx = worstPixelStdDev(in, state, moduleOf[j], d.moduleCovariance[j]);
    const double limit =
        std::max(options.maxPixelStdDevPx, options.maxPixelDilution * sigmas.correspondencePx);
    if (d.modules[j].state != Conditioning::kRankDeficient && !(mf.worstPixelStdDevPx <= limit)) {
      // Well conditioned but too little data: the covariance says the rays are unknown.
      Deficiency def;
      def.module = static_cast<int>(moduleOf[j]);
      def.state = Conditioning::kUndetermined;
      def.reciprocalCondition = d.modules[j].reciprocalCondition;
      def.parameters = {fmt::format("its rays (pixel σ up to {:.2f} px > {:.2f} px allowed)",
                                    mf.worstPixelStdDevPx, limit)};
      result->deficiencies.push_back(def);
    } else if (mf.worstPixelStdDevPx > options.maxPixelStdDevPx) {
      result->notes.push_back(fmt::format(
          "module {}: pixel σ up to {:.2f} px, {:.1f}× the correspondences' noise ({:.3f} module "
          "px): the camera's noise, not the setup, limits its rays",
          moduleOf[j], mf.worstPixelStdDevPx, mf.worstPixelStdDevPx / sigmas.correspondencePx,
          sigmas.correspondencePx));
    }
    if (d.modules[j].state != Conditioning::kGood) {
      Deficiency def;
      def.module = static_cast<int>(moduleOf[j]);
      def.state = d.modules[j].state;
      def.reciprocalCondition = d.modules[j].reciprocalCondition;
      for (int p : d.modules[j].nullDirection) def.parameters.push_back(moduleParameterName(p));
      result->deficiencies.push_back(def);
    }
  }

  // ---- cameras and k ----
  for (size_t c = 0; c < state.cameras.size(); ++c) {
    for (int p = 0; p < kCameraTangentSize; ++p) {
      double sd = d.sharedStdDev[static_cast<long>(c) * kCameraTangentSize + p];
      sd *= p < 3 ? kRadToDeg : 1e3;
      result->cameras[c].stdDev[static_cast<size_t>(p)] = sd;
    }
  }
  result->curvatureStdDev = options.fitCurvature ? d.sharedStdDev[sharedSize - 1] : 0.0;
  if (d.shared.state != Conditioning::kGood) {
    Deficiency def;
    def.module = -1;
    def.state = d.shared.state;
    def.reciprocalCondition = d.shared.reciprocalCondition;
    for (int p : d.shared.nullDirection) {
      if (options.fitCurvature && p == sharedSize - 1) {
        def.parameters.push_back("screen curvature k");
      } else {
        def.parameters.push_back(fmt::format("camera {} {}", p / kCameraTangentSize,
                                             cameraParameterName(p % kCameraTangentSize)));
      }
    }
    result->deficiencies.push_back(def);
  }
}

}  // namespace parallax::fit
