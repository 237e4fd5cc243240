#include "hw/link/content_hash.h"

#include <xxhash.h>

#include <new>

namespace parallax::hw {

uint64_t contentHash64(const void* data, size_t size) { return XXH3_64bits(data, size); }

uint64_t patchContentHash(uint64_t base, const uint8_t* data,
                          std::span<const std::pair<uint32_t, uint32_t>> ranges) {
  XXH3_state_t* state = XXH3_createState();
  if (!state) throw std::bad_alloc();
  XXH3_64bits_reset_withSeed(state, base);
  for (const auto& [begin, end] : ranges) {
    const uint32_t where[2] = {begin, end};
    XXH3_64bits_update(state, where, sizeof where);
    XXH3_64bits_update(state, data + begin, end - begin);
  }
  const uint64_t hash = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return hash;
}

}  // namespace parallax::hw
