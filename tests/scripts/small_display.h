#pragma once
// A few modules of the demo screen with their ray textures, small enough for the tests that
// render whole animations twice (frame cache, shadow-ray bounds) or whole display frames.

#include <vector>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"

namespace parallax::testing {

struct SmallDisplay {
  DisplayModel model;
  std::vector<RayTextures> textures;
};

// `modules` modules of `demo`, each width × 96.
inline SmallDisplay makeSmallDisplay(int width, int modules = 3) {
  NominalDisplayOptions options;
  options.preset = "demo";
  options.modules = modules;
  options.width = width;
  options.height = 96;
  SmallDisplay d;
  d.model = makeNominalDisplay(options);
  for (int m = 0; m < options.modules; ++m) d.textures.push_back(generateRayTextures(d.model, m));
  return d;
}

}  // namespace parallax::testing
