#pragma once
// What is left after the correction, measured on the flat-field pictures themselves: for every
// sample a module's full-drive light of each channel and its black were photographed, so the
// light the corrected module sends for a flat grey there is known without the fit's model —
//   light = Σ_c drive_c · measured_c + measured black,  drive = the correction's (quantisation
//   left out) —
// and is compared with the target's grey. Samples are averaged over a coarse grid of each module
// image first (the camera's noise is not the display's), then:
//   - per module: CIEDE2000 against the target grey, mean and worst over its cells;
//   - the display: the same over every included module's cells, and the brightness
//     non-uniformity, (brightest − darkest cell) / mean luminance.
// A falloff the smooth surface did not follow, a gain map too coarse, a response curve off
// between its levels: all show here. Viewing-angle effects the camera's stations did not see
// do not (the report's viewer uniformity covers those on the simulator).

#include "calibration/display/colour_correction.h"
#include "calibration/photometry/flat_field_capture.h"
#include "calibration/photometry/photometric_fit.h"

namespace parallax {

struct PhotometricResidualOptions {
  double grey = 0.5;           // the content level compared (target space)
  int cellsX = 4, cellsY = 3;  // per module image
  int minSamplesPerCell = 8;   // fewer: the cell is left out
};

// The summary stored with the correction (colour_correction.h): each module's scale, largest
// gain node and ΔE, the display's ΔE and non-uniformity over the included modules.
PhotometricSummary measurePhotometricResidual(const FlatFieldCaptures& captures,
                                              const PhotometricCalibration& calibration,
                                              const PhotometricResidualOptions& options = {});

}  // namespace parallax
