#include "daemon/parallaxd/module_renderer.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
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

DisplayFrame renderDisplayFrame(const PhysicalScene& scene,
                                const std::vector<RayTextures>& textures,
                                const RenderOptions& options,
                                const std::vector<ModuleEncoder>& encoders, FrameCache* cache) {
  using Clock = std::chrono::steady_clock;
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
      const auto t0 = Clock::now();
      if (cache) {
        renderFrameInto(scene, textures[i], options, cache->view(i), &scratch, &counters[i]);
      } else {
        renderFrameInto(scene, textures[i], options, &scratch, &counters[i]);
      }
      const auto t1 = Clock::now();
      out.images[i] =
          encoders.empty() ? encodeForLink(scratch) : encodeForLink(scratch, encoders[i]);
      const auto t2 = Clock::now();
      renderNs += std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count();
      encodeNs += std::chrono::duration_cast<std::chrono::nanoseconds>(t2 - t1).count();
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
