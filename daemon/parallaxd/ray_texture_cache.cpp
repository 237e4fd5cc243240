#include "daemon/parallaxd/ray_texture_cache.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <cstring>
#include <filesystem>

#include "calibration/display/display_model_json.h"
#include "common/atomic_file.h"
#include "hw/link/content_hash.h"

namespace parallax::daemon {
namespace {

constexpr char kMagic[8] = {'P', 'X', 'R', 'A', 'Y', 'S', '0', '1'};

struct FileHeader {
  char magic[8];
  int32_t width, height;
  float observerY, observerZ, curvature, reserved;
};
static_assert(sizeof(FileHeader) == 32);

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

// False when the file is missing, short or made for another size or frame.
bool readTextures(const std::string& path, const FileHeader& expected, RayTextures* out) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  FileHeader h{};
  bool ok = std::fread(&h, sizeof h, 1, f) == 1 && std::memcmp(&h, &expected, sizeof h) == 0;
  if (ok) {
    std::span<CompactRay> rays = out->rays();
    ok = std::fread(rays.data(), sizeof(CompactRay), rays.size(), f) == rays.size() &&
         std::fgetc(f) == EOF;
  }
  std::fclose(f);
  return ok;
}

void writeTextures(const std::string& path, const FileHeader& header, const RayTextures& textures) {
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
  const std::string folder = folderFor(displayContentHash(model));
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  const bool canStore = !ec;
  if (ec)
    spdlog::warn("ray-texture cache {} unusable ({}): generating without caching", folder,
                 ec.message());
  const RayFrame frame = rayFrameOf(model);
  const int total = static_cast<int>(model.modules.size());
  std::vector<RayTextures> all;
  all.reserve(model.modules.size());
  RayTextureCacheStats local;
  for (int i = 0; i < total; ++i) {
    const OpticalModule& m = model.modules[static_cast<size_t>(i)];
    const FileHeader header = headerFor(m.width, m.height, frame);
    const std::string path = fmt::format("{}/module_{:03d}.rays", folder, i);
    RayTextures textures(m.width, m.height, frame);
    if (readTextures(path, header, &textures)) {
      ++local.loaded;
    } else {
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
    all.push_back(std::move(textures));
    if (progress) progress(i + 1, total);
  }
  if (stats) *stats = local;
  return all;
}

}  // namespace parallax::daemon
