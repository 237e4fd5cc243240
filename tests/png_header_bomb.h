#pragma once
// A PNG of a few dozen bytes whose header claims a huge picture (a decompression bomb without
// the bulk): for tests that a file's size is read from its header before any pixel is allocated.

#include <cstdint>
#include <fstream>
#include <string>

namespace parallax {

// CRC-32 as PNG chunks carry it (bitwise: a test needs no table).
inline uint32_t pngCrc(const std::string& bytes) {
  uint32_t crc = 0xffffffffu;
  for (unsigned char b : bytes) {
    crc ^= b;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xffffffffu;
}

inline std::string pngChunk(const std::string& type, const std::string& data) {
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  return be32(static_cast<uint32_t>(data.size())) + type + data + be32(pngCrc(type + data));
}

// Writes an 8-bit grey PNG that claims 30000x30000 pixels (900 MB decoded) to `path`; its one
// image chunk is an empty zlib stream.
inline void writePngClaiming30000Squared(const std::string& path) {
  const std::string ihdr{0, 0, 0x75, 0x30, 0, 0, 0x75, 0x30, 8, 0, 0, 0, 0};
  std::ofstream(path, std::ios::binary)
      << std::string("\x89PNG\r\n\x1a\n", 8) + pngChunk("IHDR", ihdr) +
             pngChunk("IDAT", std::string("\x78\x9c\x03\x00\x00\x00\x00\x01", 8)) +
             pngChunk("IEND", "");
}

}  // namespace parallax
