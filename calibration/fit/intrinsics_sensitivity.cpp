#include "calibration/fit/intrinsics_sensitivity.h"

#include <cmath>

namespace parallax::fit {
namespace {

int rowCount(const FitProblem& built) {
  int rows = 0;
  for (ceres::ResidualBlockId id : built.residualBlocks)
    rows += built.problem->GetCostFunctionForResidualBlock(id)->num_residuals();
  return rows;
}

// The rows before the robust loss (σ-normalised only).
std::vector<double> rawResiduals(const FitProblem& built, int threads) {
  ceres::Problem::EvaluateOptions eo;
  eo.residual_blocks = built.residualBlocks;
  eo.apply_loss_function = false;
  eo.num_threads = threads;
  double cost = 0.0;
  std::vector<double> residuals;
  if (!built.problem->Evaluate(eo, &cost, &residuals, nullptr, nullptr)) return {};
  return residuals;
}

// Robustifies the raw derivative columns of one residual block as Ceres robustifies its
// Jacobian at the residual r (Triggs' correction, as ceres::Corrector applies it):
// J̃ = √ρ' (I − α r rᵀ / |r|²) J, α = 1 − √(1 + 2 |r|² ρ'' / ρ'), α = 0 where ρ'' ≤ 0 (the
// Cauchy loss). Differencing the robustified residuals instead would add the loss weight's own
// change, which the fit's Jacobian leaves out (that made the carried σ 15% short).
void robustify(const ceres::LossFunction* loss, const double* r, int size, Eigen::MatrixXd* rows,
               Eigen::Index first) {
  if (!loss) return;
  double squared = 0.0;
  for (int i = 0; i < size; ++i) squared += r[i] * r[i];
  double rho[3];
  loss->Evaluate(squared, rho);
  const double root = std::sqrt(rho[1]);
  auto block = rows->middleRows(first, size);
  if (squared > 0.0 && rho[2] > 0.0) {
    const double alpha = 1.0 - std::sqrt(1.0 + 2.0 * squared * rho[2] / rho[1]);
    const Eigen::Map<const Eigen::VectorXd> residual(r, size);
    const Eigen::MatrixXd along = residual * (residual.transpose() * block) / squared;
    block -= alpha * along;
  }
  block *= root;
}

// The rows of the problem `stage` builds with intrinsic `parameter` moved by `delta`; empty when
// they are not `rows` many or cannot be evaluated.
std::vector<double> residualsMoved(const FitInputs& in, const NoiseLevels& sigmas,
                                   const ModuleStage& stage, const FitState& state, int parameter,
                                   double delta, int rows) {
  CalibrationObservations moved = in.obs;
  intrinsicsParameter(moved.intrinsics, parameter) += delta;
  const FitInputs movedInputs(in.nominal, moved, in.options, in.transfer);
  FitState at = state;
  const FitProblem built = buildProblem(movedInputs, sigmas, stage, &at);
  if (rowCount(built) != rows) return {};
  ceres::Problem::EvaluateOptions eo;
  return rawResiduals(built, in.options.threads);
}

}  // namespace

Eigen::MatrixXd intrinsicsSensitivity(const FitInputs& in, const NoiseLevels& sigmas,
                                      const ModuleStage& stage, const FitState& state,
                                      const FitProblem& built) {
  const IntrinsicsCovariance& covariance = in.obs.intrinsicsCovariance;
  if (covariance.isZero()) return {};
  const int rows = rowCount(built);
  Eigen::MatrixXd sensitivity = Eigen::MatrixXd::Zero(rows, kIntrinsicsParameters);
  const std::vector<double> base = rawResiduals(built, in.options.threads);
  if (static_cast<int>(base.size()) != rows) return {};
  for (int p = 0; p < kIntrinsicsParameters; ++p) {
    const double variance = covariance(p, p);
    if (!(variance > 0.0)) continue;
    const double h = 0.1 * std::sqrt(variance);
    const std::vector<double> plus = residualsMoved(in, sigmas, stage, state, p, h, rows);
    const std::vector<double> minus = residualsMoved(in, sigmas, stage, state, p, -h, rows);
    if (plus.empty() || minus.empty()) return {};
    for (int r = 0; r < rows; ++r) {
      sensitivity(r, p) =
          (plus[static_cast<size_t>(r)] - minus[static_cast<size_t>(r)]) / (2.0 * h);
    }
  }
  Eigen::Index row = 0;
  for (ceres::ResidualBlockId id : built.residualBlocks) {
    const int size = built.problem->GetCostFunctionForResidualBlock(id)->num_residuals();
    robustify(built.problem->GetLossFunctionForResidualBlock(id), &base[static_cast<size_t>(row)],
              size, &sensitivity, row);
    row += size;
  }
  return sensitivity.allFinite() ? sensitivity : Eigen::MatrixXd();
}

}  // namespace parallax::fit
