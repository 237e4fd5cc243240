#pragma once
// What the Jacobian of a finished fit says about it: the standard deviation of every parameter
// (from the information matrix JᵀJ of the σ-normalised, robustly weighted residuals) and which
// parameters the data cannot determine. Nothing here knows the geometry: a degenerate setup
// (flat screen seen from one place, no stripe directions: focal length and distance trade off)
// shows up as a near-null direction of a module's information block, and is reported with the
// parameters that make up that direction.
//
// The information matrix has the bundle-adjustment structure: module blocks never touch each
// other, only the shared block (camera poses and k). So each module is examined on its own
// block (its conditioning with everything else held), and the marginal covariances come from
// the Schur complement on the shared block:
//   S = H_ss − Σ_i H_si H_ii⁻¹ H_is,  Σ_ss = S⁻¹,
//   Σ_ii = H_ii⁻¹ + H_ii⁻¹ H_is Σ_ss H_si H_ii⁻¹.
// Conditioning is judged on the block scaled to unit diagonal (a correlation matrix), so the
// units of the parameters do not matter: its smallest eigenvalue over its largest is the
// reciprocal condition number, and the eigenvector of the smallest names the parameters.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace parallax {

struct ConditioningOptions {
  // Thresholds on the reciprocal condition number of a block scaled to unit diagonal. Measured
  // on the demo display (tests/calibration/display_fit_test.cpp): five camera stations with
  // stripes give 3e-5..2e-4 per module; one station with stripes (a single stripe per module:
  // distance known to 1–20 cm only) 5e-8..2e-6; the degenerate flat/one-station/no-stripe
  // case 4e-11..8e-8, where only the distortion polynomial's curvature still tells focal
  // length from distance. Below rankDeficientBelow the fit is refused; between the two it is
  // reported as poorly conditioned.
  double rankDeficientBelow = 2e-7;
  double poorlyConditionedBelow = 5e-6;
  double nameComponentsAbove = 0.25;  // eigenvector entries that name a parameter

  void validate() const;
};

// kUndetermined: well conditioned, but the covariance says a parameter is unknown (too little
// data); set by the fit's quality gate, not by conditioningOf.
enum class Conditioning { kGood, kPoor, kRankDeficient, kUndetermined };
const char* conditioningName(Conditioning c);

struct BlockConditioning {
  Conditioning state = Conditioning::kGood;
  double reciprocalCondition = 1.0;
  std::vector<int> nullDirection;  // parameter indices (within the block), largest first
};

// Information matrix blocks of one fit.
struct InformationBlocks {
  std::vector<Eigen::MatrixXd> moduleModule;  // H_ii, each n_m × n_m
  std::vector<Eigen::MatrixXd> moduleShared;  // H_is, each n_m × n_s
  Eigen::MatrixXd sharedShared;               // H_ss
};

struct Diagnostics {
  std::vector<BlockConditioning> modules;
  std::vector<Eigen::VectorXd> moduleStdDev;      // +inf where undetermined
  std::vector<Eigen::MatrixXd> moduleCovariance;  // marginal, tangent units
  // Cross-covariance of each module with the shared block, Σ_is = −H_ii⁻¹ H_is Σ_ss: a
  // module's rays also depend on k, and its error and k's are correlated.
  std::vector<Eigen::MatrixXd> moduleSharedCovariance;
  BlockConditioning shared;
  Eigen::VectorXd sharedStdDev;
  Eigen::MatrixXd sharedCovariance;
};

// Builds the blocks from a row-major sparse Jacobian (Ceres' CRSMatrix fields) whose columns
// are [module 0 (moduleSize) | module 1 | ... | shared (sharedSize)].
// rowWeights, when given, scales each row's outer product (one per row).
InformationBlocks informationFromJacobian(int numRows, int numCols, const std::vector<int>& rows,
                                          const std::vector<int>& cols,
                                          const std::vector<double>& values, int moduleCount,
                                          int moduleSize, int sharedSize,
                                          const std::vector<double>* rowWeights = nullptr);

// Takes out of `info` what a group of rows does not know because their errors share a common
// part: rows of covariance w I + b 11ᵀ (σ units) inform J̃ᵀ(wI + b11ᵀ)⁻¹J̃
//   = (1/w) [J̃ᵀJ̃ − b / (w + n b) (J̃ᵀ1)(J̃ᵀ1)ᵀ];
// the first term is the rows' own (weighted 1/w by informationFromJacobian), this subtracts
// the second: `coefficient` × s sᵀ with s the sum of the group's rows. Each group touches at
// most one module (`module`, −1 for none).
void subtractCommonPart(const Eigen::VectorXd& moduleSum, const Eigen::VectorXd& sharedSum,
                        int module, double coefficient, InformationBlocks* info);

Diagnostics diagnose(const InformationBlocks& info, const ConditioningOptions& options);

// The score of one cluster of residuals, Σ Jᵀr over its σ-normalised rows, split as the fit's
// structure: at most one module's block (module, −1 for none) and the shared block.
struct ClusterScore {
  int module = -1;
  Eigen::VectorXd modulePart;
  Eigen::VectorXd sharedPart;
  // The cluster's own information J_cᵀ Ω_c⁻¹ J_c over [modulePart | sharedPart] (square), for
  // the correction of its leverage; empty: the score is taken as it is.
  Eigen::MatrixXd information;
};

// Widens the covariances of `d` (from diagnose: the model's, the rows independent with the σ
// that scales them) by what the residuals themselves say, clustered: the sandwich
// Σ_sw = H⁻¹ (Σ_c s_c s_cᵀ) H⁻¹ holds when clusters of rows err together in ways the model does
// not know (one station's decoding of a module off as a whole). With few clusters per module
// Σ_sw is rank deficient, so it only scales: each module's block (and the shared block) by
// f = max(1, tr(Σ⁻¹ Σ_sw) / n), whose expectation is 1 when the model is right (B's is H);
// cross-covariances by √(f_module f_shared), keeping the correlations.
// The scores are of residuals at the solution, which the fit has pulled toward each cluster's
// own errors: a module seen from few stations absorbs most of what each station's decode
// shares, and its raw sandwich says little. A score with its `information` is corrected for
// that leverage as Bell and McCaffrey's CR2 does: the cluster's residuals taken through
// (I − H_cc)^(−1/2), H_cc = Ω_c^(−1/2) J_c Σ J_cᵀ Ω_c^(−1/2) its block of the hat matrix, which
// makes the sandwich's expectation Σ again under the model.
void widenToClusterRobust(const InformationBlocks& info, const std::vector<ClusterScore>& scores,
                          const ConditioningOptions& options, Diagnostics* d);

// Carries the uncertainty of quantities the fit held fixed at an estimate (the camera's
// intrinsics, from its checkerboard) into `d`: the answer moves with them as δθ = −H⁻¹ g δφ,
// g = Jᵀ Ω⁻¹ ∂r/∂φ (`scores`, one full-length column [modules | shared] per held quantity), so
// Σ_θ gains X Σ_φ Xᵀ with X = H⁻¹ g, found by the Schur complement as diagnose's covariance
// is. Call it on diagnose's answer before any widening (it solves with d's Σ_ss); it returns
// X for addCarriedCovariance, which may follow a widening. Undetermined parameters stay so.
Eigen::MatrixXd solveInformation(const InformationBlocks& info, const Diagnostics& d,
                                 const ConditioningOptions& options, const Eigen::MatrixXd& scores);
void addCarriedCovariance(const Eigen::MatrixXd& x, const Eigen::MatrixXd& heldCovariance,
                          Diagnostics* d);

// Conditioning of one symmetric positive semi-definite block (exposed for tests).
BlockConditioning conditioningOf(const Eigen::MatrixXd& block, const ConditioningOptions& options);

}  // namespace parallax
