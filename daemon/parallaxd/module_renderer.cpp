#include "daemon/parallaxd/module_renderer.h"

#include <tbb/parallel_for.h>

#include <chrono>
#include <mutex>

namespace parallax::daemon {

std::shared_ptr<const hw::Image> encodeForLink(const Frame& frame) {
  auto image = std::make_shared<hw::Image>();
  image->width = frame.width;
  image->height = frame.height;
  image->format = hw::PixelFormat::kRgb8;
  image->pixels = frame.toSrgb8();
  return image;
}

DisplayFrame renderDisplayFrame(const PhysicalScene& scene, const std::vector<RayTextures>& textures,
                                const RenderOptions& options) {
  using Clock = std::chrono::steady_clock;
  DisplayFrame out;
  const size_t n = textures.size();
  out.frames.resize(n);
  out.images.resize(n);
  std::vector<RenderCounters> counters(n);
  // Modules in parallel and, inside renderFrame, tiles in parallel: TBB balances both levels,
  // so a display of few large modules and one of many small ones both keep every core busy.
  const auto start = Clock::now();
  tbb::parallel_for(size_t{0}, n, [&](size_t i) { out.frames[i] = renderFrame(scene, textures[i], options, &counters[i]); });
  const auto rendered = Clock::now();
  tbb::parallel_for(size_t{0}, n, [&](size_t i) { out.images[i] = encodeForLink(out.frames[i]); });
  const auto encoded = Clock::now();
  for (const RenderCounters& c : counters) out.counters += c;
  out.renderMs = std::chrono::duration<double, std::milli>(rendered - start).count();
  out.encodeMs = std::chrono::duration<double, std::milli>(encoded - rendered).count();
  return out;
}

}  // namespace parallax::daemon
