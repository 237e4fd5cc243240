#pragma once
// How far a fitted DisplayModel's rays are from the ground truth's, the figure a calibration
// is judged by. For a grid of pixels of each module:
//   module px:    the truth's screen point s projected into the fitted module, minus (u, v):
//                 how far off the pixel is that the fitted model would use to light s;
//   screen mm:    |s_fit(u, v) − s_true(u, v)|;
//   observer mm:  |o_fit(u, v) − o_true(u, v)| on the observer line.
// Pixels valid in one model and masked in the other are counted apart (edges of the image).

#include <vector>

#include "calibration/display/display_model.h"

namespace parallax {

struct RayErrorStats {
  long samples = 0;
  long maskMismatches = 0;
  double rmsPx = 0.0, maxPx = 0.0;
  double rmsScreenMm = 0.0, maxScreenMm = 0.0;
  double rmsObserverMm = 0.0, maxObserverMm = 0.0;

  void merge(const RayErrorStats& other);
};

struct RayErrorOptions {
  int stepPx = 16;  // grid spacing over each module's image
  void validate() const;
};

// Per module (index as in the models; the two must have the same modules and resolutions).
std::vector<RayErrorStats> compareRays(const DisplayModel& truth, const DisplayModel& fitted,
                                       const RayErrorOptions& options = {});
RayErrorStats totalRayError(const std::vector<RayErrorStats>& perModule);

}  // namespace parallax
