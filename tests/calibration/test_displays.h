#pragma once
// Displays the foundation tests share: small variants of the nominal layouts, so every suite
// runs in seconds while exercising the same code paths as the full-size `default`.

#include <string>

#include "calibration/display/display_presets.h"

namespace parallax::testing {

inline DisplayModel smallDisplay(double curvature, ScreenTransfer transfer, int modules = 9,
                                 int width = 160, int height = 120) {
  NominalDisplayOptions options;
  options.preset = "default";
  options.modules = modules;
  options.width = width;
  options.height = height;
  options.curvature = curvature;
  options.transfer = transfer;
  return makeNominalDisplay(options);
}

}  // namespace parallax::testing
