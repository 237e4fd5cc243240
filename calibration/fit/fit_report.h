#pragma once
// The per-module table of a calibration (`parallax calibrate --report`): residuals, standard
// deviations, conditioning, and — only when a ground truth is given (tests, simulations) —
// the ray errors against it. Plain text, one row per module, findings listed below.

#include <string>

#include "calibration/fit/display_fit.h"

namespace parallax {

std::string formatFitReport(const FitResult& result, const DisplayModel* truth = nullptr);

// One-paragraph summary (always printed).
std::string formatFitSummary(const FitResult& result);

}  // namespace parallax
