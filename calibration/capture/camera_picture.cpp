#include "calibration/capture/camera_picture.h"

#include <fmt/format.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/image_completeness.h"
#include "common/input_error.h"
#include "common/regular_file.h"

namespace parallax {

cv::Mat readCameraPicture(const std::string& path, int width, int height) {
  // Read once, checked whole before decoding (a truncated file is one clear line, not libpng's
  // noise), and capped: a camera picture is never larger than a raw 16-bit RGB frame.
  const size_t maxBytes = static_cast<size_t>(width) * static_cast<size_t>(height) * 6 + (1 << 20);
  const std::string bytes = readRegularFile(path, maxBytes);
  requireCompleteImage(path, bytes);
  uint32_t headerWidth = 0, headerHeight = 0;
  if (!imageHeaderSize(bytes, &headerWidth, &headerHeight))
    throw InputError({path, "", 0}, "cannot read the picture: not a PNG or JPEG file");
  if (headerWidth != static_cast<uint32_t>(width) ||
      headerHeight != static_cast<uint32_t>(height)) {
    throw InputError({path, "", 0},
                     fmt::format("is {}x{}, the camera's pictures are {}x{} (camera.json)",
                                 headerWidth, headerHeight, width, height));
  }
  cv::Mat image = cv::imdecode(
      cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data())),
      cv::IMREAD_UNCHANGED);
  if (image.empty()) throw InputError({path, "", 0}, "cannot read the picture (not an image)");
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw InputError({path, "", 0},
                     "must be an 8-bit grey or colour picture, as the camera recorded it");
  }
  if (image.cols != width || image.rows != height) {
    throw InputError({path, "", 0},
                     fmt::format("is {}x{}, the camera's pictures are {}x{} (camera.json)",
                                 image.cols, image.rows, width, height));
  }
  if (image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  return image;
}

}  // namespace parallax
