#pragma once
// One display frame: every module traced in parallel through its ray textures and encoded to
// the 8-bit sRGB image the link carries. Nothing is pushed from here: the caller gets either
// the whole set or an exception. It may send each module's image as soon as it is done
// (ModuleDone), since a module holds a frame until it is presented: only a whole set is.

#include <functional>
#include <memory>
#include <vector>

#include "calibration/display/ray_textures.h"
#include "daemon/parallaxd/live_pixels.h"
#include "hw/link/image.h"
#include "tracer/frame.h"
#include "tracer/frame_cache.h"
#include "tracer/module_encoder.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax::daemon {

struct DisplayFrame {
  std::vector<std::shared_ptr<const hw::Image>> images;  // sRGB 8-bit, what the modules show
  RenderCounters counters;
  // Wall clock of the whole display frame, split between the two stages by the time each
  // took inside the modules' tasks (they run fused, see renderDisplayFrame).
  double renderMs = 0.0;
  double encodeMs = 0.0;
};

// The 8-bit image of a frame as a module takes it (RGB8, rows top to bottom): plain sRGB, or
// through the module's photometric correction (module_encoder.h).
std::shared_ptr<const hw::Image> encodeForLink(const Frame& frame);
std::shared_ptr<const hw::Image> encodeForLink(const Frame& frame, const ModuleEncoder& encoder);

// What a module shows, back in linear light (for observer views).
Frame frameShownBy(const hw::Image& image);

// A module's float frame lives only in a worker's scratch buffer until it is encoded: the
// display keeps one 8-bit image per module. On `default` (72 modules of 1024×768) that is
// 170 MB where keeping the float frames too held another 680 MB.
// `encoders`: one per module when a photometric correction is installed, else empty (every
// module encoded as an ideal sRGB module, as without photometric calibration).
// `cache`: the frame cache, prepared for this frame and scene (frame_cache.h), or null.
// `live`: prepared for this frame and scene (live_pixels.h): only the footprints are traced and
// encoded, the same bytes; null: every pixel.
// Called with a module's index and image as soon as the module is rendered and encoded, on the
// thread that did it (modules run in parallel).
using ModuleDone = std::function<void(size_t module, std::shared_ptr<const hw::Image> image)>;

// `done`: null, or called for every module as above.
DisplayFrame renderDisplayFrame(const PhysicalScene& scene,
                                const std::vector<RayTextures>& textures,
                                const RenderOptions& options,
                                const std::vector<ModuleEncoder>& encoders = {},
                                FrameCache* cache = nullptr, const LivePixels* live = nullptr,
                                const ModuleDone* done = nullptr);

}  // namespace parallax::daemon
