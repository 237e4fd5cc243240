#include "daemon/parallaxd/module_renderer.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <stdexcept>

namespace parallax::daemon {

std::shared_ptr<const hw::Image> encodeForLink(const Frame& frame) {
  auto image = std::make_shared<hw::Image>();
  image->width = frame.width;
  image->height = frame.height;
  image->format = hw::PixelFormat::kRgb8;
  image->pixels = frame.toSrgb8();
  return image;
}

std::shared_ptr<const hw::Image> encodeForLink(const Frame& frame, const ModuleEncoder& encoder) {
  auto image = std::make_shared<hw::Image>();
  image->width = frame.width;
  image->height = frame.height;
  image->format = hw::PixelFormat::kRgb8;
  image->pixels = encoder.encode(frame);
  return image;
}

Frame frameShownBy(const hw::Image& image) {
  if (image.format != hw::PixelFormat::kRgb8)
    throw std::invalid_argument("frameShownBy: not an RGB8 image");
  return frameFromSrgb8(image.width, image.height, image.pixels);
}

namespace {

using Clock = std::chrono::steady_clock;

long long nanoseconds(Clock::duration d) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

struct ModuleImage {
  std::shared_ptr<const hw::Image> image;
  long long renderNs = 0, encodeNs = 0;
};

// The whole frame rendered into `scratch`, then encoded.
ModuleImage renderModule(const PhysicalScene& scene, const RayTextures& textures,
                         const RenderOptions& options, const ModuleEncoder* encoder,
                         FrameCache* cache, size_t module, Frame* scratch,
                         RenderCounters* counters) {
  ModuleImage out;
  const auto t0 = Clock::now();
  if (cache) {
    renderFrameInto(scene, textures, options, cache->view(module), scratch, counters);
  } else {
    renderFrameInto(scene, textures, options, scratch, counters);
  }
  const auto t1 = Clock::now();
  out.image = encoder ? encodeForLink(*scratch, *encoder) : encodeForLink(*scratch);
  out.renderNs = nanoseconds(t1 - t0);
  out.encodeNs = nanoseconds(Clock::now() - t1);
  return out;
}

// Only the footprint rendered, each tile encoded over the backdrop as soon as it is done, while
// its pixels are still in cache.
ModuleImage renderModuleFootprint(const PhysicalScene& scene, const RayTextures& textures,
                                  const RenderOptions& options, const ModuleEncoder* encoder,
                                  FrameCache* cache, const LivePixels& live, size_t module,
                                  Frame* scratch, RenderCounters* counters) {
  ModuleImage out;
  const auto t0 = Clock::now();
  const std::shared_ptr<hw::Image> image = live.startImage(module);
  std::atomic<long long> tilesNs{0};
  const TileDone encodeTile = [&](int x0, int x1, int y0, int y1) {
    const auto e0 = Clock::now();
    live.encodeTile(module, *scratch, encoder, x0, x1, y0, y1, image.get());
    tilesNs += nanoseconds(Clock::now() - e0);
  };
  const auto t1 = Clock::now();
  std::optional<StaticVisibilityView> view;
  if (cache) view = cache->view(module);
  renderFrameInto(scene, textures, options, live.footprint(module), view ? &*view : nullptr,
                  scratch, counters, &encodeTile);
  out.renderNs = nanoseconds(Clock::now() - t1) - tilesNs;
  out.encodeNs = nanoseconds(t1 - t0) + tilesNs;
  out.image = image;
  return out;
}

}  // namespace

DisplayFrame renderDisplayFrame(const PhysicalScene& scene,
                                const std::vector<RayTextures>& textures,
                                const RenderOptions& options,
                                const std::vector<ModuleEncoder>& encoders, FrameCache* cache,
                                const LivePixels* live, const ModuleDone* done) {
  DisplayFrame out;
  const size_t n = textures.size();
  if (!encoders.empty() && encoders.size() != n)
    throw std::invalid_argument("renderDisplayFrame: one encoder a module, or none");
  out.images.resize(n);
  std::vector<RenderCounters> counters(n);
  std::atomic<long long> renderNs{0}, encodeNs{0};
  const auto start = Clock::now();
  // Modules in parallel and, inside renderFrameInto, tiles in parallel: TBB balances both
  // levels, so a display of few large modules and one of many small ones both keep every core
  // busy. The module is isolated so that a worker waiting for its tiles never picks up another
  // module's task, which would reuse the same thread's scratch frame.
  tbb::parallel_for(size_t{0}, n, [&](size_t i) {
    tbb::this_task_arena::isolate([&] {
      thread_local Frame scratch;
      const ModuleEncoder* encoder = encoders.empty() ? nullptr : &encoders[i];
      const ModuleImage m = live ? renderModuleFootprint(scene, textures[i], options, encoder,
                                                         cache, *live, i, &scratch, &counters[i])
                                 : renderModule(scene, textures[i], options, encoder, cache, i,
                                                &scratch, &counters[i]);
      out.images[i] = m.image;
      if (done) (*done)(i, m.image);
      renderNs += m.renderNs;
      encodeNs += m.encodeNs;
    });
  });
  const double wallMs = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  for (const RenderCounters& c : counters) out.counters += c;
  const double total = static_cast<double>(renderNs + encodeNs);
  const double encodeShare = total > 0.0 ? static_cast<double>(encodeNs) / total : 0.0;
  out.renderMs = wallMs * (1.0 - encodeShare);
  out.encodeMs = wallMs * encodeShare;
  return out;
}

}  // namespace parallax::daemon
