#include "hw/link/content_hash.h"

#include <xxhash.h>

namespace parallax::hw {

uint64_t contentHash64(const void* data, size_t size) { return XXH3_64bits(data, size); }

}  // namespace parallax::hw
