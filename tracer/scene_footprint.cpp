#include "tracer/scene_footprint.h"

#include <algorithm>

#include "tracer/primary_ray_kernel.h"

namespace parallax {

SceneFootprint::SceneFootprint(const RayTextures& textures, const Eigen::Vector3f& boxMin,
                               const Eigen::Vector3f& boxMax)
    : width_(textures.width()), boxMin_(boxMin), boxMax_(boxMax) {
  rows_.resize(static_cast<size_t>(textures.height()));
  std::vector<Rgb> line(static_cast<size_t>(width_));
  StagedRays staged;
  PrimaryRayRow job;
  job.frame = textures.frame();
  job.boundsMin = boxMin;
  job.boundsMax = boxMax;
  job.count = width_;
  job.out = line.data();
  for (int y = 0; y < textures.height(); ++y) {
    FootprintRow& row = rows_[static_cast<size_t>(y)];
    staged.reserve(static_cast<size_t>(width_));
    job.rays = &textures.at(0, y);
    job.firstPixel = 0;
    makePrimaryRays(job, &staged);
    if (staged.size() > 0) {
      // The kernel keeps the rays in column order.
      row.begin = staged.pixels()[0];
      row.end = staged.pixels()[staged.size() - 1] + 1;
    }
    for (int x = 0; x < width_; ++x) {
      if (x >= row.begin && x < row.end) continue;
      if (textures.at(x, y).masked()) {
        ++row.masked;
      } else {
        ++row.missed;
      }
    }
    livePixels_ += row.end - row.begin;
  }
}

bool SceneFootprint::holds(const Eigen::Vector3f& boundsMin,
                           const Eigen::Vector3f& boundsMax) const {
  return !empty() && (boundsMin.array() >= boxMin_.array()).all() &&
         (boundsMax.array() <= boxMax_.array()).all();
}

}  // namespace parallax
