#include "calibration/display/ray_textures.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <limits>

#include "calibration/display/ray_function.h"
#include "common/check.h"

namespace parallax {

RayTextures::RayTextures(int width, int height, RayFrame frame)
    : width_(width),
      height_(height),
      frame_(frame),
      rays_(static_cast<size_t>(width) * static_cast<size_t>(height)) {}

long RayTextures::validCount() const {
  long count = 0;
  for (const CompactRay& r : rays_) count += r.masked() ? 0 : 1;
  return count;
}

void RayTextures::indexMask() {
  unmasked_.assign(static_cast<size_t>(height_), {0, 0});
  for (int row = 0; row < height_; ++row) {
    int first = 0, last = width_;
    while (first < last && at(first, row).masked()) ++first;
    while (last > first && at(last - 1, row).masked()) --last;
    unmasked_[static_cast<size_t>(row)] = {first, last};
  }
}

RayFrame rayFrameOf(const DisplayModel& model) {
  return RayFrame{static_cast<float>(model.observer.y), static_cast<float>(model.observer.z),
                  static_cast<float>(model.screen.curvature)};
}

void generateRayTexturesInto(const DisplayModel& model, int moduleIndex,
                             std::span<CompactRay> out) {
  const RayFunction rays(model, moduleIndex);
  const int width = rays.module().width;
  const int height = rays.module().height;
  PARALLAX_CHECK_OP(out.size(), ==, static_cast<size_t>(width) * static_cast<size_t>(height));
  constexpr float kMasked = std::numeric_limits<float>::quiet_NaN();
  tbb::parallel_for(
      tbb::blocked_range<int>(0, height, 8), [&](const tbb::blocked_range<int>& rows) {
        for (int row = rows.begin(); row != rows.end(); ++row) {
          CompactRay* line = out.data() + static_cast<size_t>(row) * static_cast<size_t>(width);
          for (int column = 0; column < width; ++column) {
            const PixelRay ray = rays.atPixel(column, row);
            if (ray.valid()) {
              line[column] = {static_cast<float>(ray.origin.x()),
                              static_cast<float>(ray.screenPoint.x()),
                              static_cast<float>(ray.screenPoint.y())};
            } else {
              line[column] = {kMasked, 0.0f, 0.0f};
            }
          }
        }
      });
}

RayTextures generateRayTextures(const DisplayModel& model, int moduleIndex) {
  const OpticalModule& m = model.modules.at(static_cast<size_t>(moduleIndex));
  RayTextures textures(m.width, m.height, rayFrameOf(model));
  generateRayTexturesInto(model, moduleIndex, textures.rays());
  textures.indexMask();
  return textures;
}

}  // namespace parallax
