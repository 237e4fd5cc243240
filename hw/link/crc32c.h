#pragma once
// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78, init and final XOR 0xFFFFFFFF; check
// value crc32c("123456789") = 0xE3069283), the checksum of every link packet (PROTOCOL.md).
//
// Why not zlib's CRC-32: on this machine zlib 1.2.13 runs at ~1.1 GB/s, which alone would eat
// the whole 1 GB/s link budget of a core; CRC-32C has an SSE4.2 instruction and, computed in
// three interleaved lanes, runs several times faster. A table-driven path covers CPUs without
// SSE4.2 and is the reference the tests compare against.

#include <cstddef>
#include <cstdint>

namespace parallax::hw {

// CRC of `size` bytes. Chainable: crc32c(b, nb, crc32c(a, na)) == crc32c(a || b).
uint32_t crc32c(const void* data, size_t size, uint32_t previous = 0);

// The portable table-driven implementation (same results, slower).
uint32_t crc32cPortable(const void* data, size_t size, uint32_t previous = 0);

// CRC of a || b from crc(a), crc(b) and the length of b, without touching the data.
uint32_t crc32cCombine(uint32_t crcA, uint32_t crcB, uint64_t sizeB);

}  // namespace parallax::hw
