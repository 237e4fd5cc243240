#pragma once
// The per-module table of a calibration (`parallax calibrate --report`): residuals, standard
// deviations, conditioning, and — only when a ground truth is given (tests, simulations) —
// the ray errors against it. Plain text, one row per module, findings listed below.

#include <string>

#include "calibration/fit/display_fit.h"

namespace parallax {

std::string formatFitReport(const FitResult& result, const DisplayModel* truth = nullptr);

// One-paragraph summary (always printed), headed by the rays' predicted error in module px
// and on the observer line (RMS and worst, σ) and the gate's verdict.
std::string formatFitSummary(const FitResult& result);

// What the rays predicted by the fit's covariance add up to over the modules the gate judged
// (RMS of σ over their grids, worst σ, and the gate's bounds).
struct PredictedRays {
  int modules = 0;
  double rmsPx = 0.0, worstPx = 0.0, boundPx = 0.0;
  double rmsObserverMm = 0.0, worstObserverMm = 0.0, boundObserverMm = 0.0;
};
PredictedRays predictedRays(const FitResult& result);

// The headline against a ground truth (tests, simulations): the installed model's true ray
// error beside the predicted one, in module px and on the observer line.
std::string formatTruthHeadline(const FitResult& result, const DisplayModel& truth,
                                const DisplayModel& nominal);

}  // namespace parallax
