#pragma once
// How finely each station's camera sees the modules: the module pixels one camera pixel spans,
// from the decoded correspondences themselves (neighbouring decodes of one module on one camera
// row or column: their module-pixel distance over their camera-pixel distance, the median over
// the station, the larger of the two axes). From far away a camera pixel spans several module
// pixels: the finest pattern, a 16-px phase period by default, then has few camera pixels a
// period, the lens blur washes it out, and the decodes grow noisy and biased (demo seen by a
// 640×360 camera: 1.4 module px a camera px from 2 m, 2.6 from 6 m, 4.3 from 10 m, where the
// decoded correspondences err by 0.154 px RMS against 0.084 without the blur).

#include <vector>

#include "calibration/camera/calibration_observations.h"

namespace parallax {

struct StationResolution {
  int station = 0;
  double modulePxACameraPx = 0.0;  // median over the station's neighbouring decodes
  int pairs = 0;                   // neighbouring decodes measured
};

// One entry per station with at least one pair of neighbouring decodes, by station.
std::vector<StationResolution> decodeResolution(const std::vector<Correspondence>& decoded);

// Beyond this a 16-px phase period spans fewer than 4 camera pixels.
constexpr double kCoarseModulePxACameraPx = 4.0;

}  // namespace parallax
