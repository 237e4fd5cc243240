#pragma once
// The uncertainty of a finished fit: the Jacobian at the solution turned into standard
// deviations, conditioning and the undetermined combinations (fit_diagnostics.h), and each
// module's covariance joined with the curvature's for the gate (calibration_gate.h).
// Internal to parallax_fit.

#include "calibration/fit/fit_problem.h"

namespace parallax::fit {

// Fills the modules' and cameras' standard deviations, conditioning, worst pixel σ, the
// curvature's σ, the deficiencies and their notes. `built` is the final problem, its residuals
// scaled by the final noise levels `sigmas`, its blocks pointing into `state`. The σ include
// the camera intrinsics' uncertainty (in.obs.intrinsicsCovariance) through
// `intrinsicsSensitivity` (intrinsics_sensitivity.h; empty: not carried).
void diagnoseUncertainty(const FitInputs& in, FitState& state, const NoiseLevels& sigmas,
                         FitProblem& built, const Eigen::MatrixXd& intrinsicsSensitivity,
                         FitResult* result);

}  // namespace parallax::fit
