#pragma once
// How the final problem's rows move with the camera intrinsics the fit holds fixed: the
// checkerboard's estimate of them errs (demo, seed 3002: f 701.02 for a true 700.00), and the
// fit's answer errs with it (the cameras 2.2-2.9 mm too far, every module's fx 6-12σ off), so
// fit_uncertainty.cpp carries their covariance through these columns into the fit's σ.
// Internal to parallax_fit.

#include <Eigen/Core>

#include "calibration/fit/fit_problem.h"

namespace parallax::fit {

// ∂r/∂φ at `state`: one column per intrinsic (fx, fy, cx, cy, k1, k2; zero where its variance
// in in.obs is zero), one row per residual of `built` (built from `stage`) in its order,
// σ-normalised and robustly weighted as Ceres evaluates them. The intrinsics enter through the
// normalized pixels FitInputs makes once and through the cost functions, so each column is a
// central difference of the problem rebuilt at φ ± h (h a tenth of φ's σ). Empty when the
// intrinsics are taken as exact, or when a rebuilt problem does not hold the same rows.
Eigen::MatrixXd intrinsicsSensitivity(const FitInputs& in, const NoiseLevels& sigmas,
                                      const ModuleStage& stage, const FitState& state,
                                      const FitProblem& built);

}  // namespace parallax::fit
