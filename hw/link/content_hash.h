#pragma once
// A 64-bit content hash of frame bytes, used to skip re-sending a frame a module already
// shows, and as the checksum of cached ray textures. Not cryptographic; 64 bits make an
// accidental match (a changed frame wrongly skipped) about 1 in 1.8e19 per frame. It is
// xxHash's XXH3 (Debian's libxxhash): about twice the speed of the multiply-xor lanes it
// replaced here (19 against 10 GB/s on a frame in cache).

#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>

namespace parallax::hw {

uint64_t contentHash64(const void* data, size_t size);

// The content hash of a frame made from the frame of hash `base` by writing `data`'s bytes
// [begin, end) of each range over it: a hash of the base's hash, the ranges and their bytes.
// Equal hashes still mean equal bytes (to the odds above); equal bytes reached another way may
// hash differently, which only costs a frame sent that could have been skipped.
uint64_t patchContentHash(uint64_t base, const uint8_t* data,
                          std::span<const std::pair<uint32_t, uint32_t>> ranges);

}  // namespace parallax::hw
