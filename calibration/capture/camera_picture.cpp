#include "calibration/capture/camera_picture.h"

#include <fmt/format.h>

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string_view>

#include "common/image_completeness.h"
#include "common/input_error.h"
#include "common/regular_file.h"

namespace parallax {
namespace {

uint32_t bigEndian(std::string_view bytes, size_t at, int count) {
  uint32_t value = 0;
  for (int i = 0; i < count; ++i)
    value = value << 8 | static_cast<uint8_t>(bytes[at + static_cast<size_t>(i)]);
  return value;
}

// The size a PNG or JPEG says it has, read from its header before anything is decoded: a few
// kilobytes of zlib can claim 30000x30000 pixels, which the decoder would allocate (a GiB)
// before the size is checked. False for any other format, or a JPEG with no frame header.
bool headerSize(std::string_view bytes, uint32_t* width, uint32_t* height) {
  // PNG: IHDR is the first chunk (requireCompleteImage checked the chunks and their CRCs).
  if (bytes.size() >= 24 && bytes.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8) &&
      bytes.substr(12, 4) == "IHDR") {
    *width = bigEndian(bytes, 16, 4);
    *height = bigEndian(bytes, 20, 4);
    return true;
  }
  if (bytes.size() < 4 || bytes.substr(0, 2) != "\xff\xd8") return false;
  // JPEG: walk the marker segments up to the frame header (SOF0..SOF15 but DHT, JPG, DAC).
  size_t at = 2;
  while (at + 4 <= bytes.size()) {
    if (static_cast<uint8_t>(bytes[at]) != 0xff) return false;
    const uint8_t marker = static_cast<uint8_t>(bytes[at + 1]);
    if (marker == 0xff) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd7)) {  // no length field
      at += 2;
      continue;
    }
    if (marker == 0xd9 || marker == 0xda) return false;  // end or scan before any frame
    const uint32_t length = bigEndian(bytes, at + 2, 2);
    const bool frame =
        marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
    if (frame) {
      if (length < 7 || at + 9 > bytes.size()) return false;
      *height = bigEndian(bytes, at + 5, 2);
      *width = bigEndian(bytes, at + 7, 2);
      return true;
    }
    if (length < 2) return false;
    at += 2 + length;
  }
  return false;
}

}  // namespace

cv::Mat readCameraPicture(const std::string& path, int width, int height) {
  // Read once, checked whole before decoding (a truncated file is one clear line, not libpng's
  // noise), and capped: a camera picture is never larger than a raw 16-bit RGB frame.
  const size_t maxBytes = static_cast<size_t>(width) * static_cast<size_t>(height) * 6 + (1 << 20);
  const std::string bytes = readRegularFile(path, maxBytes);
  requireCompleteImage(path, bytes);
  uint32_t headerWidth = 0, headerHeight = 0;
  if (!headerSize(bytes, &headerWidth, &headerHeight))
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
