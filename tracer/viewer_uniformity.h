#pragma once
// How alike the modules look to viewers: a flat colour shown by every module, seen from viewers
// along the observer line (synthesizeObserverView). Each view pixel's colour is the view over
// its lobe coverage — the modules' light as the viewer mixes it, the screen's diffusion ripple
// divided out — and is compared with the colour every module should show.

#include <Eigen/Core>
#include <vector>

#include "calibration/display/display_model.h"
#include "tracer/frame.h"

namespace parallax {

struct ViewerUniformity {
  double meanDeltaE = 0.0, worstDeltaE = 0.0;  // CIEDE2000 against the expected colour
  double nonUniformity = 0.0;                  // (brightest − darkest) / mean luminance
  int pixels = 0;                              // view pixels counted (coverage ≥ 0.9)
};

// `light[i]`: module i's emitted light (linear RGB, sRGB primaries); `expected`: the colour
// every module should show; `white`: the white CIELAB is relative to. Viewers at `viewerXs` on
// the observer line, views of width × height pixels.
ViewerUniformity measureViewerUniformity(const DisplayModel& model, const std::vector<Frame>& light,
                                         const Eigen::Vector3d& expected,
                                         const Eigen::Vector3d& white,
                                         const std::vector<double>& viewerXs, int width = 160,
                                         int height = 90);

}  // namespace parallax
