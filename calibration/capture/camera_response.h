#pragma once
// The calibration camera's response, measured from the phase-shift pictures instead of taken on
// trust from camera.json.
//
// Every decoded quantity assumes the pictures are in linear light: the white − black contrast
// whose lobes are fitted and whose neighbours' tails are subtracted (stripe_peak.h), the phase
// of the shifted sinusoids. A camera.json that leaves its response out makes a gamma-encoded
// camera look linear, and then every stripe centre at an oblique station
// moves by pixels (on demo through the link, camera.json saying 1 for a γ 2.2 sensor: stripe
// centres 13 mm RMS off, rays 9.5 mm RMS / 56 mm worst on the observer line, while the fit
// predicted 0.6 mm).
//
// The phase frames show it without any extra picture: N frames of a sinusoid shifted by 2π/N
// have, in linear light, only the DFT bins 0 and ±1 across the N samples of a pixel; a response
// curve adds harmonics (bins 2..N−2, N ≥ 4). Writing the pictures as linear under the assumed
// response L, the true linear light is L^e for one exponent e (a power-law response: the true γ
// is e · the assumed γ); e is the one that makes the harmonics vanish:
//   e = argmin Σ_pixels Σ_{k=2..N−2} |X_k(L^e)|² / Σ_pixels |X_1(L^e)|²
// with each pixel's samples scaled to a maximum of 1 first (L^e is homogeneous: any per-pixel
// light level, module brightness or lobe weight drops out). Its σ is the spread of the estimate
// over disjoint pixel subsets. What it measures is the response of the whole chain from a
// pattern value to a recorded value: the camera's when the modules are driven linearly, as the
// calibration patterns are.

#include "calibration/camera/calibration_observations.h"
#include "calibration/capture/calibration_captures.h"

namespace parallax {

struct CameraResponseOptions {
  int maxPixels = 20000;  // phase pixels sampled over all picture sets
  int minPixels = 500;
  double relativeTolerance = 0.02;  // differences below this are left alone
};

// Measures the response from every set's column and row phase frames (linear under
// captures.camera.responseGamma) and decides whether it must be corrected (only when camera.json
// states none: CameraResponseCheck::corrected says why a stated one is kept).
CameraResponseCheck checkCameraResponse(const CalibrationCaptures& captures,
                                        const CameraResponseOptions& options = {});

}  // namespace parallax
