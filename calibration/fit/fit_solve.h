#pragma once
// One solve of a built fit problem (fit_problem.h): the solver's settings for the stage, the
// caller's progress and stop callbacks, and a stop once the steps no longer move the rays.
// Internal to parallax_fit.

#include "calibration/fit/fit_problem.h"

namespace parallax::fit {

// Cost-change tolerances: a first solve only has to bring a start close enough for the
// camera-px residual and the outlier test (within a σ or so); the final one to 0.14 σ
// (CostChangeTolerance in fit_solve.cpp says why).
constexpr double kStartCostTolerance = 1.0;
constexpr double kFinalCostTolerance = 0.01;

struct SolveOutcome {
  int iterations = 0;
  bool stopped = false;    // FitOptions::stopRequested ended it
  bool converged = false;  // Ceres converged or the cost-change tolerance was met
};

// Solves `built` (whose blocks point into `state`) until the cost changes by less than
// `costTolerance` in a successful step, or Ceres' own tolerances or the iteration limit.
SolveOutcome solve(const FitInputs& in, FitProblem& built, FitState& state, double costTolerance);

}  // namespace parallax::fit
