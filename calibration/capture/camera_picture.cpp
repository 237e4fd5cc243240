#include "calibration/capture/camera_picture.h"

#include <fmt/format.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/input_error.h"

namespace parallax {

cv::Mat readCameraPicture(const std::string& path, int width, int height) {
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty())
    throw InputError({path, "", 0}, "cannot read the picture (missing or not an image)");
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
