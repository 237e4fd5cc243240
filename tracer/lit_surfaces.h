#pragma once
// The diffuse hits of one ray generation of a tile, waiting for their shadow rays: what every
// light's test needs, with the path's weight folded into the colours. Structure-of-arrays, so
// the shadow-ray kernel (shadow_ray_kernel.h) loads each field a SIMD vector at a time; shading
// writes one surface at a time (set). Each array has kPadding spare entries past the capacity:
// the kernel reads whole vectors.

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tracer/scene.h"

namespace parallax {

class LitSurfaces {
 public:
  // Per surface: its position (point lights measure from here; the shadow rays start off it,
  // along the geometric normal), the shading normal, the geometric normal (light from behind
  // the face is cut), weight × albedo; with a highlight, the view direction mirrored about the
  // normal, weight × specular colour and the shininess.
  enum Field {
    // clang-format off
    kPx, kPy, kPz, kNx, kNy, kNz, kGx, kGy, kGz,
    kRx, kRy, kRz, kDr, kDg, kDb, kSr, kSg, kSb, kShininess,
    kFields
    // clang-format on
  };
  // flags(): bit 0 the surface has a highlight; bit 1 it lies on a bare face of its mesh
  // (PhysicalMesh::bareFaces, the side its shadow rays leave by), so they cannot meet that mesh
  // again; bits 8..15 the frame cache's answers for the static lights (StaticHit::lights()), 0
  // when it has none; bits 16..30 its mesh (geomID, kOtherMesh past that).
  static constexpr std::int32_t kHighlight = 1;
  static constexpr std::int32_t kLeavesMesh = 2;
  static constexpr int kStaticLightsShift = 8;
  static constexpr int kMeshShift = 16;
  static constexpr std::int32_t kOtherMesh = 0x7fff;
  // The mesh bits of flags() for a surface on mesh `geomID`.
  static std::int32_t meshFlags(unsigned geomID, bool leavesMesh) {
    return static_cast<std::int32_t>(std::min<unsigned>(geomID, kOtherMesh)) << kMeshShift |
           (leavesMesh ? kLeavesMesh : 0);
  }
  static constexpr size_t kPadding = 64;

  // Room for n surfaces; size() becomes 0 (the memory is kept from tile to tile).
  void reset(size_t n) {
    size_ = 0;
    if (n <= capacity_) return;
    capacity_ = n;
    floats_.assign(kFields * stride(), 0.0f);
    flags_.assign(stride(), 0);
    pixels_.assign(stride(), 0);
  }
  size_t size() const { return size_; }

  // Appends a surface (`meshFlags`: meshFlags()); reflected, specular and shininess are read only
  // with a highlight.
  void push(const Eigen::Vector3f& position, const Eigen::Vector3f& normal,
            const Eigen::Vector3f& geometric, const Rgb& diffuse, int pixel,
            std::uint8_t staticLights, std::int32_t meshFlags) {
    const size_t i = size_++;
    float* f = floats_.data();
    const size_t s = stride();
    set3(f + kPx * s + i, s, position);
    set3(f + kNx * s + i, s, normal);
    set3(f + kGx * s + i, s, geometric);
    set3(f + kDr * s + i, s, diffuse);
    pixels_[i] = pixel;
    flags_[i] = static_cast<std::int32_t>(staticLights) << kStaticLightsShift | meshFlags;
  }
  // The last surface pushed has a Phong highlight.
  void setHighlight(const Eigen::Vector3f& reflected, const Rgb& specular, float shininess) {
    const size_t i = size_ - 1;
    float* f = floats_.data();
    const size_t s = stride();
    set3(f + kRx * s + i, s, reflected);
    set3(f + kSr * s + i, s, specular);
    f[kShininess * s + i] = shininess;
    flags_[i] |= kHighlight;
  }

  // n more surfaces, written by a kernel through the mutable pointers; returns the first's index.
  size_t extend(size_t n) {
    const size_t first = size_;
    size_ += n;
    return first;
  }
  // Surface `from` copied over surface `to` (a kernel's output closed up over lanes it left out).
  void copy(size_t from, size_t to) {
    float* f = floats_.data();
    const size_t s = stride();
    for (size_t k = 0; k < kFields; ++k) f[k * s + to] = f[k * s + from];
    flags_[to] = flags_[from];
    pixels_[to] = pixels_[from];
  }
  float* mutableField(Field f) { return floats_.data() + static_cast<size_t>(f) * stride(); }
  std::int32_t* mutableFlags() { return flags_.data(); }
  int* mutablePixels() { return pixels_.data(); }

  const float* field(Field f) const { return floats_.data() + static_cast<size_t>(f) * stride(); }
  const std::int32_t* flags() const { return flags_.data(); }
  const int* pixels() const { return pixels_.data(); }

 private:
  size_t stride() const { return capacity_ + kPadding; }
  static void set3(float* first, size_t s, const Eigen::Vector3f& v) {
    first[0] = v.x();
    first[s] = v.y();
    first[2 * s] = v.z();
  }
  std::vector<float> floats_;
  std::vector<std::int32_t> flags_;
  std::vector<int> pixels_;
  size_t capacity_ = 0;
  size_t size_ = 0;
};

}  // namespace parallax
