#pragma once
// A small simulated display for the capture tests: six 128x96 demo modules, their seeded
// ground truth and a camera rig looking at it.

#include <cstdint>

#include "calibration/display/display_presets.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "hw/simulator/simulated_hardware.h"

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

// Six 128x96 modules, a 240x136 camera at two stations.
inline SmallSession twoStationSession() {
  CameraRigOptions rig;
  rig.stations = 2;
  rig.spanM = 1.0;
  rig.intrinsics = CameraIntrinsics::centred(240, 136, 262.0);
  return makeSmallSession(5, rig, 6);
}

// A simulator with the display's module count and size.
inline SimulatedHardwareOptions modulesOf(const DisplayModel& display) {
  SimulatedHardwareOptions o;
  o.modules = static_cast<int>(display.modules.size());
  o.width = display.modules.front().width;
  o.height = display.modules.front().height;
  return o;
}

}  // namespace parallax::hw
