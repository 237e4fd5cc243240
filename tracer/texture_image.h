#pragma once
// A diffuse texture as the tracer samples it: a mip pyramid (built with OpenImageIO's
// ImageBufAlgo) of linear RGB floats and a trilinear lookup whose level comes from the ray's
// footprint (ray_cone.h). Row 0 is the image's top; uv (0, 0) is its bottom-left corner and uv
// wraps (repeats).

#include <string>
#include <vector>

#include "tracer/scene.h"

namespace parallax {

// floor(f) wrapped into [0, n) (a texel column or row); f may be any finite float (huge uvs
// included).
int wrapFloor(float f, int n);

class TextureImage {
 public:
  TextureImage() = default;
  // `rgb`: width × height × 3 linear floats, row 0 at the top. Builds the pyramid.
  TextureImage(int width, int height, std::vector<float> rgb);
  // A 1×1 texture of one colour (the fallback of a texture that failed to load).
  static TextureImage constant(const Rgb& color);
  // The most pixels one texture file may have, and a scene's texture files together: a small
  // compressed file can claim a huge picture, which costs 16 bytes a pixel here with its
  // pyramid (and up to as much again while it is read).
  static constexpr long kMaxFilePixels = 16L << 20;   // 4096 x 4096
  static constexpr long kMaxScenePixels = 64L << 20;  // about 1 GiB
  // Reads through OpenImageIO; 8- and 16-bit files are sRGB-decoded when `srgb`. Returns false
  // and fills `error` when the file cannot be read, or when its header says it has more than
  // `maxPixels` pixels (checked before any pixel is read).
  static bool load(const std::string& path, bool srgb, long maxPixels, TextureImage* out,
                   std::string* error);

  int width() const { return levels_.empty() ? 0 : levels_[0].width; }
  int height() const { return levels_.empty() ? 0 : levels_[0].height; }
  int levelCount() const { return static_cast<int>(levels_.size()); }

  // Nearest texel of a level (x right, y down from the top row); wraps.
  Rgb texel(int level, int x, int y) const;
  // Bilinear within `level` at continuous texel coordinates of level 0 scaled to it.
  Rgb bilinear(int level, float u, float v) const;
  // Trilinear: `lod` = log2 of the footprint in level-0 texels (≤ 0: bilinear on level 0).
  Rgb lookup(float u, float v, float lod) const;

  // A level's size and texels (row-major RGB, row 0 at the top), for the SIMD lookup
  // (texture_lookup_kernel.h).
  struct LevelView {
    int width = 0, height = 0;
    const float* rgb = nullptr;
  };
  LevelView level(int i) const {
    const Level& l = levels_[static_cast<size_t>(i)];
    return {l.width, l.height, l.rgb.data()};
  }

 private:
  struct Level {
    int width = 0, height = 0;
    std::vector<float> rgb;
  };
  void buildPyramid();
  std::vector<Level> levels_;
};

}  // namespace parallax
