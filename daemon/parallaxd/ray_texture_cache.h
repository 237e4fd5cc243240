#pragma once
// The ray textures of a calibration, cached on disk by the calibration's content hash
// (DESIGN.md: "regenerated only when the DisplayModel changes"). A calibration the daemon has
// seen before — a restart, a rollback — loads its textures instead of generating them again.
//
// Layout: <cache_dir>/raytex/<hash as 16 hex digits>/module_NNN.rays, each the compact form
// (12 bytes a pixel) behind a small header that repeats the size and the RayFrame and holds a
// checksum of the rays, so a file that does not match what the model expects, or whose bytes
// were damaged on disk, is regenerated (a damaged one logged), never used.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/display/ray_textures.h"

namespace parallax::daemon {

// A 64-bit hash of the model's canonical JSON form: equal models (to the last bit of every
// double) hash alike, any changed parameter changes it.
uint64_t displayContentHash(const DisplayModel& model);
std::string hashHex(uint64_t hash);

struct RayTextureCacheStats {
  int loaded = 0;     // modules read from the cache
  int generated = 0;  // modules computed (and then stored)
  int discarded = 0;  // cached files found damaged (checksum, size): regenerated, never used
};

class RayTextureCache {
 public:
  explicit RayTextureCache(std::string directory) : directory_(std::move(directory)) {}

  // Every module's textures for `model`, from the cache where a valid file exists, else
  // generated and stored. `progress(done, total)` is called after each module.
  std::vector<RayTextures> texturesFor(const DisplayModel& model,
                                       RayTextureCacheStats* stats = nullptr,
                                       const std::function<void(int, int)>& progress = {}) const;
  // The same for some modules only (in the order given): a cluster rank's own modules.
  std::vector<RayTextures> texturesFor(const DisplayModel& model, const std::vector<int>& modules,
                                       RayTextureCacheStats* stats = nullptr,
                                       const std::function<void(int, int)>& progress = {}) const;

  std::string folderFor(uint64_t hash) const;

 private:
  std::string directory_;
};

}  // namespace parallax::daemon
