#pragma once
// Which pixels of a module can show the scene: per row, the columns [begin, end) outside which
// every pixel is masked (black) or has a primary ray that misses a box around the scene (the
// background). Frames of an animated scene then trace and encode only those columns; the rest of
// the module's image is the same from frame to frame (daemon/parallaxd/live_pixels.h keeps it).
//
// Built with the primary-ray kernel's own box test against a box that holds the scene's
// bounds. The slab test is monotone in the box's faces under float rounding (each face's
// distance is (face − o) · (1 / d), rounded the same way for the same ray), so a ray that misses
// the bigger box misses the scene's too: a frame rendered through the footprint is bit-identical
// to one without it, for every scene whose bounds lie in the box (holds()).

#include <Eigen/Core>
#include <vector>

#include "calibration/display/ray_textures.h"

namespace parallax {

struct FootprintRow {
  int begin = 0;   // the first column a ray of which may meet the box
  int end = 0;     // one past the last; begin == end: none does
  int masked = 0;  // masked pixels outside [begin, end)
  int missed = 0;  // unmasked pixels outside [begin, end): their rays miss the box
};

class SceneFootprint {
 public:
  SceneFootprint() = default;
  // `boxMin`, `boxMax`: physical, as PhysicalScene::boundsMin/Max.
  SceneFootprint(const RayTextures& textures, const Eigen::Vector3f& boxMin,
                 const Eigen::Vector3f& boxMax);

  bool empty() const { return rows_.empty(); }
  int width() const { return width_; }
  int height() const { return static_cast<int>(rows_.size()); }
  const FootprintRow& row(int y) const { return rows_[static_cast<size_t>(y)]; }
  // Whether a scene with these bounds renders the same through the footprint.
  bool holds(const Eigen::Vector3f& boundsMin, const Eigen::Vector3f& boundsMax) const;
  // The box it was made for.
  const Eigen::Vector3f& boxMin() const { return boxMin_; }
  const Eigen::Vector3f& boxMax() const { return boxMax_; }
  long livePixels() const { return livePixels_; }  // inside the rows' [begin, end)
  long pixels() const { return static_cast<long>(width_) * height(); }

 private:
  int width_ = 0;
  Eigen::Vector3f boxMin_ = Eigen::Vector3f::Zero(), boxMax_ = Eigen::Vector3f::Zero();
  std::vector<FootprintRow> rows_;
  long livePixels_ = 0;
};

}  // namespace parallax
