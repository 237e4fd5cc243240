#pragma once
// The setups a user may calibrate in (issue 17's seed sweep): stations, their span, camera
// noise, the screen's transfer against the nominal's, the observer line's distance, modules no
// camera sees, 16 or 72 modules. The synthetic sweep (tests/calibration/calibration_sweep_test)
// and the picture sweep (bench/picture_sessions) run this one list, so their figures describe
// the same setups.

#include <string>
#include <vector>

#include "calibration/display/display_model.h"

namespace parallax {

struct SweepSetup {
  std::string name;
  int modules = 16;  // 16: demo (512×384); otherwise the default layout, smaller images
  int stations = 5;
  double spanM = 3.2;
  double noisePx = 0.3;  // camera noise of the synthetic path (px of its 1920×1080 camera)
  ScreenTransfer truth = ScreenTransfer::kConical;
  ScreenTransfer nominal = ScreenTransfer::kConical;
  double observerM = 2.0;
  std::vector<int> unseen;  // modules no camera sees
};

std::vector<SweepSetup> sweepSetups();

// A setup's nominal display: demo for 16 modules; otherwise the default layout with that many
// modules of 256 × 192 (the default's geometry; small images keep the sweep affordable), the
// setup's transfer and observer line.
DisplayModel sweepNominal(const SweepSetup& setup);

}  // namespace parallax
