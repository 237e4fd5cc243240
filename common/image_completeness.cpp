#include "common/image_completeness.h"

#include <fmt/format.h>
#include <zlib.h>

#include <cstdint>

#include "common/input_error.h"

namespace parallax {
namespace {

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);

uint32_t bigEndian32(std::string_view bytes, size_t at) {
  const auto b = [&](size_t i) {
    return static_cast<uint32_t>(static_cast<uint8_t>(bytes[at + i]));
  };
  return b(0) << 24 | b(1) << 16 | b(2) << 8 | b(3);
}

void requireCompletePng(const std::string& path, std::string_view bytes) {
  const auto fail = [&](const std::string& why) { throw InputError({path, "", 0}, why); };
  size_t at = kPngSignature.size();
  while (true) {
    if (bytes.size() - at < 12) {
      fail(fmt::format("the PNG is truncated: it ends at byte {} before its IEND chunk",
                       bytes.size()));
    }
    const uint32_t length = bigEndian32(bytes, at);
    const std::string_view type = bytes.substr(at + 4, 4);
    if (length > bytes.size() - at - 12) {
      fail(fmt::format("the PNG is truncated: its {} chunk at byte {} needs {} bytes, {} are left",
                       type, at, length + 12, bytes.size() - at));
    }
    const auto* typeAndData = reinterpret_cast<const Bytef*>(bytes.data() + at + 4);
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), typeAndData, static_cast<uInt>(length + 4));
    if (crc != bigEndian32(bytes, at + 8 + length)) {
      fail(fmt::format("the PNG is damaged: its {} chunk at byte {} fails its CRC", type, at));
    }
    at += 12 + length;
    if (type == "IEND") return;
  }
}

}  // namespace

void requireCompleteImage(const std::string& path, std::string_view bytes) {
  if (bytes.substr(0, kPngSignature.size()) == kPngSignature) {
    requireCompletePng(path, bytes);
  } else if (bytes.size() >= 2 && bytes.substr(0, 2) == "\xff\xd8") {
    // A JPEG may carry padding after its end-of-image marker; look for it near the end.
    const size_t tail = bytes.size() > 64 ? bytes.size() - 64 : 0;
    if (bytes.substr(tail).find("\xff\xd9") == std::string_view::npos) {
      throw InputError({path, "", 0},
                       fmt::format("the JPEG is truncated: no end-of-image marker in its last "
                                   "bytes ({} in all)",
                                   bytes.size()));
    }
  }
}

}  // namespace parallax
