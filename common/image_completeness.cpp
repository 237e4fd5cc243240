#include "common/image_completeness.h"

#include <fmt/format.h>
#include <zlib.h>

#include <cstdint>

#include "common/input_error.h"

namespace parallax {
namespace {

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);

// The `count`-byte big-endian number at `at` (PNG and JPEG store theirs so).
uint32_t bigEndian(std::string_view bytes, size_t at, int count) {
  uint32_t value = 0;
  for (int i = 0; i < count; ++i)
    value = value << 8 | static_cast<uint8_t>(bytes[at + static_cast<size_t>(i)]);
  return value;
}

uint32_t bigEndian32(std::string_view bytes, size_t at) { return bigEndian(bytes, at, 4); }

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

bool imageHeaderSize(std::string_view bytes, uint32_t* width, uint32_t* height) {
  // PNG: IHDR is the first chunk (its CRC is requireCompleteImage's to check).
  if (bytes.size() >= 24 && bytes.substr(0, kPngSignature.size()) == kPngSignature &&
      bytes.substr(12, 4) == "IHDR") {
    *width = bigEndian32(bytes, 16);
    *height = bigEndian32(bytes, 20);
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
