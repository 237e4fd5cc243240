#pragma once
// A 64-bit content hash of frame bytes, used to skip re-sending a frame a module already
// shows. Not cryptographic; 64 bits make an accidental match (a changed frame wrongly
// skipped) about 1 in 1.8e19 per frame. Four independent multiply-xor lanes keep it near
// memory speed (~5 GB/s here), and a final avalanche mixes the lanes and the length.

#include <cstddef>
#include <cstdint>

namespace parallax::hw {

uint64_t contentHash64(const void* data, size_t size);

}  // namespace parallax::hw
