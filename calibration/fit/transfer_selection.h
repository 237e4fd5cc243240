#pragma once
// Which screen transfer (linear or conical, screen.h) the calibration data support. Only the
// stripe centres depend on it (the transfer sends a module's light exactly to the camera
// there); the two fits have the same parameters, so the Bayesian information criterion's
// difference reduces to the difference of their χ² on the stripes, whitened by one common σ —
// the smaller of the two fits' robust stripe σ, what the better model leaves as noise (each
// fit's own re-estimated σ would absorb its misfit and hide it). Residuals beyond
// kClipSigmas σ count as kClipSigmas σ (decoding outliers must not decide the model).
//
//   Δχ² = χ²(assumed) − χ²(other);  > decisiveChi2: the other transfer; < −decisiveChi2: the
//   assumed one; between: undecided.
// Undecided matters only when the two fits' rays differ: if their worst disagreement on the
// observer line is within the gate's limit, either may be installed (the assumed one); if not,
// the calibration is refused.

#include <string>

#include "calibration/display/screen.h"
#include "calibration/fit/calibration_gate.h"

namespace parallax {

struct TransferEvidence {
  ScreenTransfer assumed = ScreenTransfer::kConical;
  ScreenTransfer chosen = ScreenTransfer::kConical;
  bool decided = false;
  double deltaChi2 = 0.0;      // χ²(assumed) − χ²(other), positive favours the other
  double commonSigmaMm = 0.0;  // the σ both χ² use
  int stripes = 0;
  // The two fits' rays compared (the assumed fit's model against the other's), observed
  // modules: worst distance on the observer line (mm) and in module px.
  double raysDifferMm = 0.0, raysDifferPx = 0.0;

  std::string describe() const;
};

struct FitResult;

// Kass & Raftery: 2 ln(Bayes factor) above 10 is very strong evidence.
constexpr double kDecisiveChi2 = 10.0;

// Chooses between two fits of the same data under the two transfers; returns the one to keep,
// its `transferEvidence` and notes filled in, `transferMismatch` set when undecided and the
// choice would move rays beyond `limits`.
FitResult selectTransfer(FitResult assumed, FitResult other, const GateLimits& limits);

}  // namespace parallax
