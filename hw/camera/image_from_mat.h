#pragma once
// A picture as OpenCV holds it → the link's 8-bit Image: what a camera hands on, whether it read
// a file (folder_camera), a device (camera.cpp) or rendered the picture (the simulator's
// calibration_physics). One channel → kGray8, three (RGB order) → kRgb8; 8-bit values are
// copied, float ones (linear 0..1) clamped and rounded to the nearest code.

#include <opencv2/core.hpp>

#include "hw/link/image.h"

namespace parallax::hw {

// CHECKs that `picture` is CV_8UC1, CV_8UC3, CV_32FC1 or CV_32FC3.
Image imageFromMat(const cv::Mat& picture);

}  // namespace parallax::hw
