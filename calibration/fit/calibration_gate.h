#pragma once
// The gate a calibration passes before it is installed, in the units a viewer sees. Every
// module is judged by its predicted worst error over its whole image (ray_uncertainty.h:
// `sigmas` × the σ of its worst grid pixel), in module pixels and in millimetres where its rays
// meet the observer line, against FIXED limits: a noisy camera or a far observer line does not
// buy a looser gate, it buys a refusal that says why.
//
// The default limits are what a viewer would not notice:
//   3 module px: the worst pixel of a module (near an image corner, where the fit extrapolates
//     beyond what the cameras saw), even at the 3σ bound, lands at most three of its own pixels
//     from its place: within the blur of a projector pixel on a diffuser (lens blur plus the
//     diffuser's spread, 1.5–2 pitches) plus one pixel, seen only as a viewer crosses from that
//     module's view to the next. Measured, not tuned per seed: on `demo` at 0.3 px camera noise
//     (five stations over 3.2 m) the two modules whose images reach furthest beyond the
//     stations' stripes have a 3σ bound of 2.1–2.7 px (true worst 0.8–1.6 px); 2 px would refuse
//     that sound setup on every seed, 1 px (the display's own pixel) every demo calibration.
//   15 mm on the observer line: a quarter of the eye separation (~63 mm), under a third of the
//     distance between neighbouring modules' views at the observer line on `default` (68 mm):
//     no eye ever receives the view meant for the other eye or the next module's, and at 2 m
//     it is 0.43°, a quarter of `default`'s 1.9° angular pitch.
// A module no camera saw, or one whose error cannot be bounded (rank deficient: no finite
// covariance; or seen from one station only, ModuleFit::stationsSeeing, where what its one
// decode shares is absorbed by its parameters, out of any residual's sight), fails. A failure of
// the whole fit (not converged, stopped, a transfer the data cannot decide, cameras or k
// undetermined) fails every module; one that did not converge leaves every module unbounded
// (its σ describe no minimum).

#include <string>
#include <vector>

#include "calibration/fit/ray_uncertainty.h"

namespace parallax {

struct GateLimits {
  double worstPx = 3.0;           // module px
  double worstObserverMm = 15.0;  // mm on the observer line
  double sigmas = 3.0;            // the predicted worst error: this many σ at the worst pixel
  // Install the modules that pass, the others held at their nominal calibration and named;
  // without it, one failing module refuses the whole calibration.
  bool allowPartial = false;

  void validate() const;
};

struct ModuleGate {
  int module = 0;
  bool passes = false;
  bool held = false;   // held at its starting calibration by request (FitOptions::heldModules)
  std::string reason;  // why it fails; empty when it passes
  RayUncertainty predicted;
  // `sigmas` × predicted worst σ (+inf when unbounded).
  double boundPx = 0.0, boundObserverMm = 0.0;
};

struct GateResult {
  GateLimits limits;  // the limits it was judged by
  bool passes = false;
  std::vector<std::string> reasons;  // failures of the whole fit
  std::vector<ModuleGate> modules;
  // Modules failing the gate that --allow-partial held at their nominal calibration.
  std::vector<int> heldNominal;
  // The fit's own estimate of each, in heldNominal's order: what a truth judges the σ by.
  std::vector<OpticalModule> heldEstimates;

  int failingModules() const;
  // One line per failure, for the summary.
  std::vector<std::string> describe() const;
};

}  // namespace parallax

namespace parallax {

struct FitResult;
struct DisplayModel;

// Judges every module of a finished fit (FitResult::modules[m].rayCovariance) and the fit as a
// whole; stores the verdict in result->gate. With allowPartial, the failing modules of a fit
// that passes as a whole are put back to `nominal` in result->model and named in the notes.
void applyGate(const DisplayModel& nominal, const GateLimits& limits,
               const RayUncertaintyOptions& grid, FitResult* result);

}  // namespace parallax
