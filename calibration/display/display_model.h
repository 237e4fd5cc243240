#pragma once
// The DisplayModel: screen (with its transfer and diffusion width) + observer line + optical
// modules + the displayable box B_P. The single source of truth: calibration fits it, the
// simulator perturbs it into a ground truth, ray textures are a pure function of it.

#include <string>
#include <vector>

#include "calibration/display/box3.h"
#include "calibration/display/observer_line.h"
#include "calibration/display/optical_module.h"
#include "calibration/display/screen.h"

namespace parallax {

struct DisplayModel {
  std::string name = "custom";
  Screen screen;
  ObserverLine observer;
  std::vector<OpticalModule> modules;
  Box3 displayableBox;  // B_P, physical

  // Throws InputError naming the first offending field (e.g. "modules[3].orientation") when
  // the model is not physically meaningful: non-finite numbers, non-positive sizes, a folding
  // screen (|k|·W/2 ≥ 1), a module in front of the screen, a non-unit quaternion, a zero
  // focal length, an observer line behind the screen, an empty or inverted B_P.
  void validate() const;

  long pixelCount() const;
};

// Upper bounds that keep hostile files from asking for absurd allocations.
constexpr int kMaxModules = 4096;
constexpr int kMaxModuleSide = 16384;

}  // namespace parallax
