#pragma once
// The simulated calibration camera's colour pictures, for photometric calibration: the same
// screen physics as renderFrame (camera_renderer.h: each camera pixel sees a screen point lit by
// the modules through the HPO lobe, ambient light, the fiducial markers, lens blur), but in
// RGB light, through a known exposure (recorded linear = exposure × light), the sensor's
// response curve and noise, clipped at full scale (saturation) and quantised to 8 bits.
// The camera's channels are the reference space's (linear RGB with sRGB primaries).

#include <opencv2/core.hpp>
#include <vector>

#include "calibration/simulation/camera_renderer.h"
#include "calibration/simulation/seeded_random.h"

namespace parallax {

// `moduleLight[i]` is module i's emitted light (CV_32FC3, R G B, its resolution) or empty for
// a dark module. Returns CV_32FC3 recorded values in [0, 1], multiples of 1/255.
cv::Mat renderColourPicture(const StationView& view, const std::vector<cv::Mat>& moduleLight,
                            const CameraRenderOptions& sensor, double exposure,
                            SeededRandom& random);

}  // namespace parallax
