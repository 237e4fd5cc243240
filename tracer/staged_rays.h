#pragma once
// Rays a SIMD kernel made, compacted, as structure-of-arrays: one contiguous float array per
// field, so a kernel writes a whole vector of lanes per field with one compress-store (the
// primary rays of primary_ray_kernel.h, the shadow rays of shadow_ray_kernel.h). Embree then
// gets them as its 16-wide packets (RayHitPackets::assign, OcclusionPackets::assign: one 64-byte
// copy per field and packet). Each array has kPadding spare floats past its capacity: a
// compress-store writes a whole vector, whatever the number of lanes it keeps.

#include <cstddef>
#include <vector>

namespace parallax {

class StagedRays {
 public:
  // Per ray: origin, unit direction, tfar, then three values its kernel defines (a shadow ray's
  // colour contribution; a primary ray's footprint width in kR).
  enum Field { kOx, kOy, kOz, kDx, kDy, kDz, kTfar, kR, kG, kB, kFields };
  static constexpr size_t kPadding = 64;  // floats: a vector of the widest target and then some

  // Room for n rays; keeps the memory (a tile reuses it frame after frame). size() becomes 0.
  void reserve(size_t n) {
    size_ = 0;
    if (n <= capacity_) return;
    capacity_ = n;
    floats_.assign(kFields * stride(), 0.0f);
    pixels_.assign(stride(), 0);
  }
  size_t size() const { return size_; }
  void setSize(size_t n) { size_ = n; }
  size_t capacity() const { return capacity_; }

  float* field(Field f) { return floats_.data() + static_cast<size_t>(f) * stride(); }
  const float* field(Field f) const { return floats_.data() + static_cast<size_t>(f) * stride(); }
  int* pixels() { return pixels_.data(); }
  const int* pixels() const { return pixels_.data(); }

 private:
  size_t stride() const { return capacity_ + kPadding; }
  std::vector<float> floats_;
  std::vector<int> pixels_;  // the frame pixel each ray adds to
  size_t capacity_ = 0;
  size_t size_ = 0;
};

}  // namespace parallax
