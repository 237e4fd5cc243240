#pragma once
// A small simulated display for the capture tests: six 128x96 demo modules, their seeded
// ground truth and a camera rig looking at it.

#include <cstdint>

#include "calibration/display/display_presets.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"

namespace parallax::hw {

struct SmallSession {
  DisplayModel nominal, truth;
  SimulatedRig rig;
};

inline SmallSession makeSmallSession(std::uint64_t truthSeed, const CameraRigOptions& rig,
                                     std::uint64_t rigSeed) {
  NominalDisplayOptions options;
  options.preset = "demo";
  options.modules = 6;
  options.width = 128;
  options.height = 96;
  SmallSession s;
  s.nominal = makeNominalDisplay(options);
  GroundTruthOptions gt;
  gt.seed = truthSeed;
  s.truth = makeGroundTruth(s.nominal, gt);
  s.rig = makeSimulatedRig(s.truth, rig, rigSeed);
  return s;
}

}  // namespace parallax::hw
