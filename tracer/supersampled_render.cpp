#include "tracer/supersampled_render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "calibration/display/ray_function.h"
#include "common/input_error.h"

namespace parallax {
namespace {

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

RayTextures generateOffsetRayTextures(const DisplayModel& model, int moduleIndex, double du,
                                      double dv) {
  const OpticalModule& m = model.modules.at(static_cast<size_t>(moduleIndex));
  RayTextures out(m.width, m.height, rayFrameOf(model));
  const RayFunction rays(model, moduleIndex);
  std::span<CompactRay> texels = out.rays();
  tbb::parallel_for(
      tbb::blocked_range<int>(0, m.height, 8), [&](const tbb::blocked_range<int>& rowRange) {
        for (int row = rowRange.begin(); row < rowRange.end(); ++row) {
          for (int column = 0; column < m.width; ++column) {
            const PixelRay r = rays.at(column + du, row + dv);
            CompactRay& t = texels[static_cast<size_t>(row) * static_cast<size_t>(m.width) +
                                   static_cast<size_t>(column)];
            if (!r.valid()) {
              t = {std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f};
              continue;
            }
            t = {static_cast<float>(r.origin.x()), static_cast<float>(r.screenPoint.x()),
                 static_cast<float>(r.screenPoint.y())};
          }
        }
      });
  return out;
}

void renderFrameInto(const PhysicalScene& scene, const DisplayModel& model, int moduleIndex,
                     const RayTextures& centres, const RenderOptions& options, Frame* frame,
                     RenderCounters* counters, SupersampleTimes* times) {
  options.validate();
  RenderOptions single = options;
  single.samplesPerPixel = 1;
  if (options.samplesPerPixel == 1) {
    const auto start = std::chrono::steady_clock::now();
    renderFrameInto(scene, centres, single, frame, counters);
    if (times) *times = {0.0, msSince(start)};
    return;
  }
  const int n =
      static_cast<int>(std::lround(std::sqrt(static_cast<double>(options.samplesPerPixel))));
  // `frame` holds the sum until the end (its memory reused when it has the right size).
  Frame& sum = *frame;
  if (sum.width != centres.width() || sum.height != centres.height() ||
      sum.pixels.size() !=
          static_cast<size_t>(centres.width()) * static_cast<size_t>(centres.height())) {
    sum = Frame(centres.width(), centres.height());
  } else {
    std::fill(sum.pixels.begin(), sum.pixels.end(), Rgb::Zero());
  }
  std::vector<int> samples(sum.pixels.size(), 0);
  SupersampleTimes spent;
  RenderCounters total;
  Frame sample;  // one sub-pixel grid's frame, its memory reused from grid to grid
  for (int b = 0; b < n; ++b) {
    for (int a = 0; a < n; ++a) {
      auto start = std::chrono::steady_clock::now();
      const RayTextures grid =
          generateOffsetRayTextures(model, moduleIndex, (a + 0.5) / n, (b + 0.5) / n);
      spent.rayGenerationMs += msSince(start);
      start = std::chrono::steady_clock::now();
      RenderCounters c;
      renderFrameInto(scene, grid, single, &sample, &c);
      total += c;
      for (size_t i = 0; i < sum.pixels.size(); ++i) {
        if (grid.rays()[i].masked()) continue;
        sum.pixels[i] += sample.pixels[i];
        ++samples[i];
      }
      spent.traceMs += msSince(start);
    }
  }
  for (size_t i = 0; i < sum.pixels.size(); ++i) {
    if (centres.rays()[i].masked() || samples[i] == 0) {
      sum.pixels[i] = Rgb::Zero();
    } else {
      sum.pixels[i] /= static_cast<float>(samples[i]);
    }
  }
  if (counters) *counters = total;
  if (times) *times = spent;
}

Frame renderFrame(const PhysicalScene& scene, const DisplayModel& model, int moduleIndex,
                  const RayTextures& centres, const RenderOptions& options,
                  RenderCounters* counters, SupersampleTimes* times) {
  Frame frame;
  renderFrameInto(scene, model, moduleIndex, centres, options, &frame, counters, times);
  return frame;
}

}  // namespace parallax
