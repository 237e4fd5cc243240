#include "common/content_checksum.h"

#include <fmt/format.h>

namespace parallax {

uint64_t fnv1a64(const void* data, size_t size) {
  uint64_t hash = 0xcbf29ce484222325ull;
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 0x100000001b3ull;
  }
  return hash;
}

std::string contentChecksum(const std::string& bytes) {
  return fmt::format("fnv1a64:{:016x}", fnv1a64(bytes.data(), bytes.size()));
}

}  // namespace parallax
