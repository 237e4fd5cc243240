#pragma once
// A 64-bit content hash of frame bytes, used to skip re-sending a frame a module already
// shows, and as the checksum of cached ray textures. Not cryptographic; 64 bits make an
// accidental match (a changed frame wrongly skipped) about 1 in 1.8e19 per frame. It is
// xxHash's XXH3 (Debian's libxxhash): about twice the speed of the multiply-xor lanes it
// replaced here (19 against 10 GB/s on a frame in cache).

#include <cstddef>
#include <cstdint>

namespace parallax::hw {

uint64_t contentHash64(const void* data, size_t size);

}  // namespace parallax::hw
