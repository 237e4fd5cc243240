#include "daemon/cli/ray_texture_files.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <vector>

#include "common/input_error.h"

namespace parallax {
namespace {

void writeExr(const std::string& path, int width, int height, int channels,
              const std::vector<float>& pixels) {
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw InputError({path, "", 0}, "OpenImageIO cannot create an EXR writer");
  OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::FLOAT);
  spec.attribute("compression", "zip");
  if (!out->open(path, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()) ||
      !out->close()) {
    throw InputError({path, "", 0}, "cannot write: " + out->geterror());
  }
}

}  // namespace

RayTextureFileNames rayTextureFileNames(const std::string& directory, int moduleId) {
  const std::string base = fmt::format("{}/module_{:03d}_", directory, moduleId);
  return {base + "origins.exr", base + "directions.exr", base + "mask.exr"};
}

void writeRayTextureFiles(const RayTextures& textures, const std::string& directory, int moduleId) {
  const int w = textures.width(), h = textures.height();
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  std::vector<float> origins(3 * n, 0.0f), directions(3 * n, 0.0f), mask(n, 0.0f);
  const RayFrame& frame = textures.frame();
  for (size_t i = 0; i < n; ++i) {
    const CompactRay& ray = textures.rays()[i];
    if (ray.masked()) continue;
    const Eigen::Vector3f o = frame.origin(ray);
    const Eigen::Vector3f d = frame.direction(ray);
    for (int c = 0; c < 3; ++c) {
      origins[3 * i + static_cast<size_t>(c)] = o[c];
      directions[3 * i + static_cast<size_t>(c)] = d[c];
    }
    mask[i] = 1.0f;
  }
  const RayTextureFileNames names = rayTextureFileNames(directory, moduleId);
  writeExr(names.origins, w, h, 3, origins);
  writeExr(names.directions, w, h, 3, directions);
  writeExr(names.mask, w, h, 1, mask);
}

}  // namespace parallax
