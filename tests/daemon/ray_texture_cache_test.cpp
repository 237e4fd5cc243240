// A ray-texture cache entry damaged on disk (issue 18, defect 5: bytes overwritten inside a
// module's ray data, header and size intact) is discarded and regenerated, never used: the
// textures handed out are the ones a fresh generation gives, to the bit.

#include "daemon/parallaxd/ray_texture_cache.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "calibration/display/display_presets.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;

bool sameRays(const RayTextures& a, const RayTextures& b) {
  return a.rays().size() == b.rays().size() &&
         std::memcmp(a.rays().data(), b.rays().data(), a.rays().size_bytes()) == 0;
}

TEST(RayTextureCache, ADamagedEntryIsRegeneratedNotUsed) {
  const fs::path folder =
      fs::temp_directory_path() / ("plx-raycache-" + std::to_string(::getpid()));
  fs::remove_all(folder);
  NominalDisplayOptions o;
  o.preset = "demo";
  o.modules = 3;
  o.width = 64;
  o.height = 48;
  const DisplayModel model = makeNominalDisplay(o);
  const RayTextureCache cache(folder.string());
  RayTextureCacheStats stats;
  const std::vector<RayTextures> fresh = cache.texturesFor(model, &stats);
  ASSERT_EQ(stats.generated, 3);

  // Overwrite 4 KiB in the middle of module 1's rays: same size, same header.
  const fs::path entry = fs::path(cache.folderFor(displayContentHash(model))) / "module_001.rays";
  const auto size = fs::file_size(entry);
  {
    std::fstream f(entry, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(size / 2));
    const std::string junk(4096, '\x5a');
    f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  ASSERT_EQ(fs::file_size(entry), size);

  const std::vector<RayTextures> again = cache.texturesFor(model, &stats);
  EXPECT_EQ(stats.loaded, 2);
  EXPECT_EQ(stats.generated, 1);
  EXPECT_EQ(stats.discarded, 1);
  for (size_t i = 0; i < fresh.size(); ++i) EXPECT_TRUE(sameRays(again[i], fresh[i])) << i;
  // The regenerated entry was stored again and now loads.
  cache.texturesFor(model, &stats);
  EXPECT_EQ(stats.loaded, 3);
  fs::remove_all(folder);
}

}  // namespace
}  // namespace parallax::daemon
