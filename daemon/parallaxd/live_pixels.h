#pragma once
// The pixels of an animated scene's frames worth making: per module the scene's footprint
// (tracer/scene_footprint.h) and the backdrop, the bytes of everything outside it — black where
// masked, the background elsewhere, through the module's encoder — which are the same in every
// frame. A frame then traces and encodes only the footprint and copies the rest from the
// backdrop: on `orbit.lua` three pixels in four lie outside, on `demo` and `default`. The images
// are byte for byte those of a full render and encode.
//
//   LivePixels live;  // the conductor's, across frames
//   live.prepare(physical, textures, texturesVersion, encoders, encodersVersion);
//   renderDisplayFrame(physical, textures, options, encoders, cache, &live);

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "calibration/display/ray_textures.h"
#include "hw/link/image.h"
#include "tracer/module_encoder.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_footprint.h"

namespace parallax::daemon {

struct LivePixelsStats {
  long builds = 0;           // footprints and backdrops made (all modules)
  double lastBuildMs = 0.0;  // wall clock of the last build
  long livePixels = 0;       // inside the footprints, all modules
  long pixels = 0;           // all modules
  std::size_t backdropBytes = 0;
  long recycledImages = 0;  // module images handed out again, the backdrop still in place
  long newImages = 0;       // made and filled with the backdrop

  std::string line() const;  // for --explain and status
};

class LivePixels {
 public:
  // Ready for this frame: builds the footprints and backdrops when there are none, when the ray
  // textures, the encoders or the background changed, or when the scene's bounds left the box
  // they were made for (the new box then holds the old one and the bounds, with a margin that
  // doubles at every such rebuild, so a scene that keeps moving out causes few). Parallel over
  // the modules.
  void prepare(const PhysicalScene& scene, const std::vector<RayTextures>& textures,
               std::uint64_t texturesVersion, const std::vector<ModuleEncoder>& encoders,
               std::uint64_t encodersVersion);
  const SceneFootprint& footprint(std::size_t module) const { return modules_[module].footprint; }
  // Module i's next image, the backdrop outside the footprint: a buffer of an earlier frame's
  // that nothing holds any more when there is one, as it is (a new 2.4 MB buffer a module and
  // frame cost more in page faults on `default` than the encode itself, and copying the
  // backdrop in again 170 MB a display frame), else a new copy of the backdrop. Inside the
  // footprint it holds anything until encodeTile wrote it. Calls for different modules may run
  // at once.
  std::shared_ptr<hw::Image> startImage(std::size_t module) const;
  // The footprint's pixels in columns [x0, x1) and rows [y0, y1) of `frame` (rendered inside it)
  // encoded into `image` (from startImage): through `encoder`, or the plain sRGB encode when
  // null. Once every tile is in, the image is byte for byte a full frame's encode.
  void encodeTile(std::size_t module, const Frame& frame, const ModuleEncoder* encoder, int x0,
                  int x1, int y0, int y1, hw::Image* image) const;
  // Forgets everything (a new scene: its box starts afresh).
  void clear();
  LivePixelsStats stats() const;

 private:
  struct Module {
    SceneFootprint footprint;
    std::vector<std::uint8_t> backdrop;  // RGB8, the module's whole image
    // The last few images handed out: one that only this holds may be written again.
    mutable std::vector<std::shared_ptr<hw::Image>> recent;
    mutable long recycled = 0, made = 0;  // images handed out (startImage)
    // The bytes inside the footprint: all that can differ between this build's images.
    std::shared_ptr<const hw::ImageRegions> regions;
  };
  // Starts `modules` modules afresh, their counts kept.
  void forget(std::size_t modules);
  std::vector<Module> modules_;
  std::uint64_t texturesVersion_ = 0, encodersVersion_ = 0;
  Rgb background_ = Rgb::Zero();
  float margin_ = 0.0f;  // of the box's diagonal, on each side (the box: the footprints')
  LivePixelsStats stats_;
  long recycledBefore_ = 0, newBefore_ = 0;  // of the modules before the last build
};

}  // namespace parallax::daemon
