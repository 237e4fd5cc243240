#include "hw/camera/image_from_mat.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"

namespace parallax::hw {

Image imageFromMat(const cv::Mat& picture) {
  const int channels = picture.channels();
  PARALLAX_CHECK(channels == 1 || channels == 3);
  PARALLAX_CHECK(picture.depth() == CV_8U || picture.depth() == CV_32F);
  Image image;
  image.width = picture.cols;
  image.height = picture.rows;
  image.format = channels == 1 ? PixelFormat::kGray8 : PixelFormat::kRgb8;
  image.pixels.resize(image.byteSize());
  const size_t row = static_cast<size_t>(picture.cols) * static_cast<size_t>(channels);
  for (int y = 0; y < picture.rows; ++y) {
    uint8_t* out = image.pixels.data() + static_cast<size_t>(y) * row;
    if (picture.depth() == CV_8U) {
      std::copy_n(picture.ptr<uint8_t>(y), row, out);
      continue;
    }
    const float* in = picture.ptr<float>(y);
    for (size_t i = 0; i < row; ++i)
      out[i] = static_cast<uint8_t>(std::lround(255.0f * std::clamp(in[i], 0.0f, 1.0f)));
  }
  return image;
}

}  // namespace parallax::hw
