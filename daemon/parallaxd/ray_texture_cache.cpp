#include "daemon/parallaxd/ray_texture_cache.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstddef>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "calibration/display/display_model_json.h"
#include "common/atomic_file.h"
#include "hw/link/content_hash.h"

namespace parallax::daemon {
namespace {

constexpr char kMagic[8] = {'P', 'X', 'R', 'A', 'Y', 'S', '0', '3'};  // 03: XXH3 checksums

// The header repeats what the file must be for (size, frame) and carries the checksum of the
// ray bytes behind it, so a file damaged inside its data (header intact) is caught too.
struct FileHeader {
  char magic[8];
  int32_t width, height;
  float observerY, observerZ, curvature;
  uint32_t reserved;
  uint64_t raysChecksum;  // hw::contentHash64 of the ray bytes
};
static_assert(sizeof(FileHeader) == 40);

FileHeader headerFor(int width, int height, const RayFrame& frame) {
  FileHeader h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.width = width;
  h.height = height;
  h.observerY = frame.observerY;
  h.observerZ = frame.observerZ;
  h.curvature = frame.curvature;
  return h;
}

uint64_t raysChecksum(const RayTextures& textures) {
  const std::span<const CompactRay> rays = textures.rays();
  return hw::contentHash64(rays.data(), rays.size_bytes());
}

enum class CacheRead { kLoaded, kMissing, kStale, kCorrupt };

// kMissing: no file; kStale: made for another size, frame or format (expected after a
// change, regenerated quietly); kCorrupt: the right header but short, long or failing its
// checksum (damage on disk: regenerated and logged).
CacheRead readTextures(const std::string& path, const FileHeader& expected, RayTextures* out) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return CacheRead::kMissing;
  FileHeader h{};
  CacheRead result = CacheRead::kStale;
  if (std::fread(&h, sizeof h, 1, f) == 1 &&
      std::memcmp(&h, &expected, offsetof(FileHeader, raysChecksum)) == 0) {
    std::span<CompactRay> rays = out->rays();
    const bool complete =
        std::fread(rays.data(), sizeof(CompactRay), rays.size(), f) == rays.size() &&
        std::fgetc(f) == EOF;
    result =
        complete && raysChecksum(*out) == h.raysChecksum ? CacheRead::kLoaded : CacheRead::kCorrupt;
  }
  std::fclose(f);
  return result;
}

void writeTextures(const std::string& path, FileHeader header, const RayTextures& textures) {
  header.raysChecksum = raysChecksum(textures);
  std::string bytes(sizeof header + textures.rays().size_bytes(), '\0');
  std::memcpy(bytes.data(), &header, sizeof header);
  std::memcpy(bytes.data() + sizeof header, textures.rays().data(), textures.rays().size_bytes());
  writeFileAtomically(path, bytes);
}

}  // namespace

uint64_t displayContentHash(const DisplayModel& model) {
  const std::string canonical = displayModelToJson(model).dump();
  return hw::contentHash64(canonical.data(), canonical.size());
}

std::string hashHex(uint64_t hash) { return fmt::format("{:016x}", hash); }

std::string RayTextureCache::folderFor(uint64_t hash) const {
  return directory_ + "/raytex/" + hashHex(hash);
}

std::vector<RayTextures> RayTextureCache::texturesFor(
    const DisplayModel& model, RayTextureCacheStats* stats,
    const std::function<void(int, int)>& progress) const {
  std::vector<int> every(model.modules.size());
  for (size_t i = 0; i < every.size(); ++i) every[i] = static_cast<int>(i);
  return texturesFor(model, every, stats, progress);
}

std::vector<RayTextures> RayTextureCache::texturesFor(
    const DisplayModel& model, const std::vector<int>& modules, RayTextureCacheStats* stats,
    const std::function<void(int, int)>& progress) const {
  const std::string folder = folderFor(displayContentHash(model));
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  const bool canStore = !ec;
  if (ec)
    spdlog::warn("ray-texture cache {} unusable ({}): generating without caching", folder,
                 ec.message());
  const RayFrame frame = rayFrameOf(model);
  const int total = static_cast<int>(modules.size());
  std::vector<RayTextures> all;
  all.reserve(modules.size());
  RayTextureCacheStats local;
  for (int done = 0; done < total; ++done) {
    const int i = modules[static_cast<size_t>(done)];
    const OpticalModule& m = model.modules.at(static_cast<size_t>(i));
    const FileHeader header = headerFor(m.width, m.height, frame);
    const std::string path = fmt::format("{}/module_{:03d}.rays", folder, i);
    RayTextures textures(m.width, m.height, frame);
    const CacheRead read = readTextures(path, header, &textures);
    if (read == CacheRead::kLoaded) {
      ++local.loaded;
    } else {
      if (read == CacheRead::kCorrupt) {
        spdlog::warn("ray-texture cache: {} is damaged (checksum or size): discarded, regenerating",
                     path);
        ++local.discarded;
      }
      generateRayTexturesInto(model, i, textures.rays());
      ++local.generated;
      if (canStore) {
        try {
          writeTextures(path, header, textures);
        } catch (const std::exception& e) {
          spdlog::warn("ray-texture cache: {}", e.what());  // still usable from memory
        }
      }
    }
    textures.indexMask();
    all.push_back(std::move(textures));
    if (progress) progress(done + 1, total);
  }
  if (stats) *stats = local;
  return all;
}

}  // namespace parallax::daemon
