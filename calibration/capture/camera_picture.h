#pragma once
// A picture as the calibration camera recorded it, read back from a captures folder (the
// pattern pictures and the checkerboard pictures alike).

#include <opencv2/core.hpp>
#include <string>

namespace parallax {

// 8-bit grey (a colour file is converted), exactly width × height. Throws InputError naming
// the file when it is missing, not an 8-bit image, or of another size.
cv::Mat readCameraPicture(const std::string& path, int width, int height);

}  // namespace parallax
