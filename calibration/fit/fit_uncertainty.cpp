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
// Ceres' quaternion tangent δ turns by 2|δ| (Plus multiplies by [cos|δ|, sin|δ| δ/|δ|]): a
// rotation's σ in degrees is twice its tangent's.
constexpr double kTangentToRotationDeg = 2.0 * kRadToDeg;

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
        sd *= kTangentToRotationDeg;
      else if (p < 6)
        sd *= 1e3;
      else if (p < 10)
        sd *= width;
      mf.stdDev[static_cast<size_t>(p)] = sd;
    }
    // The module's covariance joined with k's, for the gate (ray_uncertainty.h): its rays
    // depend on both, and the two estimates are correlated.
    Eigen::MatrixXd& cov = mf.rayCovariance;
    cov = Eigen::MatrixXd::Zero(kModuleTangentSize + 1, kModuleTangentSize + 1);
    cov.topLeftCorner(kModuleTangentSize, kModuleTangentSize) = d.moduleCovariance[j];
    if (options.fitCurvature) {
      const Eigen::VectorXd cross = d.moduleSharedCovariance[j].col(sharedSize - 1);
      cov.block(0, kModuleTangentSize, kModuleTangentSize, 1) = cross;
      cov.block(kModuleTangentSize, 0, 1, kModuleTangentSize) = cross.transpose();
      cov(kModuleTangentSize, kModuleTangentSize) =
          d.sharedCovariance(sharedSize - 1, sharedSize - 1);
    }
    for (int p = 0; p < kModuleTangentSize; ++p) {
      if (!std::isfinite(d.moduleStdDev[j][p])) cov(p, p) = std::numeric_limits<double>::infinity();
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
      sd *= p < 3 ? kTangentToRotationDeg : 1e3;
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
