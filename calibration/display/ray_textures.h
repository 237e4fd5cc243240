#pragma once
// The constant ray textures of one module in the compact form the tracer reads: 12 bytes a
// pixel. Since every origin lies on the observer line (o.y, o.z shared by the display) and
// every s on the screen (s.z = sag(s.x)), a ray is (o.x, s.x, s.y) as floats; a NaN o.x marks a
// masked pixel (black, never traced). Regenerated only when the DisplayModel changes.

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/display/screen.h"

namespace parallax {

struct CompactRay {
  float originX;  // NaN: masked
  float screenX;
  float screenY;

  bool masked() const { return std::isnan(originX); }
};
static_assert(sizeof(CompactRay) == 12, "the compact ray texture is 12 bytes a pixel");

// What the tracer needs to expand a CompactRay (shared by all pixels of a display).
struct RayFrame {
  float observerY = 0.0f;
  float observerZ = 2.0f;
  float curvature = 0.0f;

  Eigen::Vector3f origin(const CompactRay& r) const { return {r.originX, observerY, observerZ}; }
  Eigen::Vector3f screenPoint(const CompactRay& r) const {
    return {r.screenX, r.screenY, screenSag(curvature, r.screenX)};
  }
  // Unit direction from o through s.
  Eigen::Vector3f direction(const CompactRay& r) const {
    return (screenPoint(r) - origin(r)).normalized();
  }
};

class RayTextures {
 public:
  RayTextures() = default;
  RayTextures(int width, int height, RayFrame frame);

  int width() const { return width_; }
  int height() const { return height_; }
  const RayFrame& frame() const { return frame_; }
  const CompactRay& at(int column, int row) const {
    return rays_[static_cast<size_t>(row) * static_cast<size_t>(width_) +
                 static_cast<size_t>(column)];
  }
  // Writable rays: whatever indexMask() learnt is forgotten (the caller may change any of them).
  std::span<CompactRay> rays() {
    unmasked_.clear();
    return rays_;
  }
  std::span<const CompactRay> rays() const { return rays_; }
  long validCount() const;

  // Per row, the columns [first, last) outside of which every pixel is masked, for a tracer
  // that skips them without reading their rays (a module's masked pixels, a third to a half of
  // them, lie in runs at the rows' ends). Learnt by indexMask() once the rays are written; until
  // then every row is [0, width).
  void indexMask();
  std::pair<int, int> unmaskedColumns(int row) const {
    return unmasked_.empty() ? std::pair<int, int>{0, width_} : unmasked_[static_cast<size_t>(row)];
  }

 private:
  int width_ = 0;
  int height_ = 0;
  RayFrame frame_;
  std::vector<CompactRay> rays_;
  std::vector<std::pair<int, int>> unmasked_;  // per row, or empty: not indexed
};

RayFrame rayFrameOf(const DisplayModel& model);

// Fills `out` (module width × height, row-major) in parallel. The buffer is the caller's, so a
// daemon can regenerate into memory it already holds.
void generateRayTexturesInto(const DisplayModel& model, int moduleIndex, std::span<CompactRay> out);

RayTextures generateRayTextures(const DisplayModel& model, int moduleIndex);

}  // namespace parallax
