#include "daemon/parallaxd/image_message.h"

#include <cstdint>
#include <cstring>

#include "common/check.h"

namespace parallax::daemon {
namespace {

struct ImageHeader {
  int32_t id = 0, width = 0, height = 0, format = 0;
  uint64_t bytes = 0;
};

}  // namespace

void appendImageMessage(std::string* out, int id, const hw::Image& image) {
  const ImageHeader h{id, image.width, image.height, static_cast<int32_t>(image.format),
                      image.pixels.size()};
  out->append(reinterpret_cast<const char*>(&h), sizeof h);
  out->append(reinterpret_cast<const char*>(image.pixels.data()), image.pixels.size());
}

std::vector<std::pair<int, std::shared_ptr<const hw::Image>>> readImageMessage(
    const std::string& message, size_t from) {
  std::vector<std::pair<int, std::shared_ptr<const hw::Image>>> images;
  size_t at = from;
  while (at < message.size()) {
    PARALLAX_CHECK_OP(message.size() - at, >=, sizeof(ImageHeader));
    ImageHeader h;
    std::memcpy(&h, message.data() + at, sizeof h);
    at += sizeof h;
    PARALLAX_CHECK_OP(message.size() - at, >=, h.bytes);
    auto image = std::make_shared<hw::Image>();
    image->width = h.width;
    image->height = h.height;
    image->format = static_cast<hw::PixelFormat>(h.format);
    image->pixels.assign(message.data() + at, message.data() + at + h.bytes);
    at += h.bytes;
    images.emplace_back(h.id, std::move(image));
  }
  return images;
}

}  // namespace parallax::daemon
