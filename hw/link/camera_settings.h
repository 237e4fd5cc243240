#pragma once
// The camera settings a calibration session locks for its whole run: what the link's camera
// lock carries to the simulator, and what a real camera backend sets and reads back.

#include <cstdint>

namespace parallax::hw {

struct CameraSettings {
  uint32_t exposureUs = 10000;
  double gain = 1.0;
  double whiteBalanceRed = 1.0, whiteBalanceBlue = 1.0;
  bool colour = false;  // RGB pictures (photometric calibration); grey suffices for geometry
};

}  // namespace parallax::hw
