#include "hw/link/image.h"

#include <OpenImageIO/imageio.h>

#include <memory>
#include <stdexcept>

namespace parallax::hw {

void writePng(const Image& image, const std::string& path) {
  if (image.empty() || image.pixels.size() != image.byteSize()) {
    throw std::runtime_error(path + ": no image to write");
  }
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw std::runtime_error(path + ": " + OIIO::geterror());
  const OIIO::ImageSpec spec(image.width, image.height, bytesPerPixel(image.format),
                             OIIO::TypeDesc::UINT8);
  if (!out->open(path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, image.pixels.data()) ||
      !out->close()) {
    throw std::runtime_error(path + ": " + out->geterror());
  }
}

}  // namespace parallax::hw
