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
  // focal length, an observer line behind the screen, an empty or inverted B_P, or any value
  // outside the physical ranges below.
  void validate() const;

  long pixelCount() const;
};

// Upper bounds that keep hostile files from asking for absurd allocations.
constexpr int kMaxModules = 4096;
constexpr int kMaxModuleSide = 16384;

// Physically meaningful ranges, stated once (validate() and the tools that take a viewer
// position use them). A finite but absurd value (a 1e300 m screen, a module at x = 1e308, a
// distortion of 1e10) would overflow the ray maths or yield a black render, not an error.
constexpr double kMaxDisplayExtentM = 100.0;     // |every length and coordinate| (m)
constexpr double kMaxScreenCurvature = 1000.0;   // |k| (1/m): a radius of 1 mm or more
constexpr double kMaxFocalPx = 1e6;              // focal length (px)
constexpr double kMaxPrincipalOffsetSides = 10;  // |c - side/2| within this many module sides
constexpr double kMaxDistortion = 10.0;          // |k1|, |k2| (OpenCV radial)

}  // namespace parallax
