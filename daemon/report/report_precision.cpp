// Ray-texture precision: float32 vs float16 vs the compact 12-byte form, error against memory
// and time.

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Core>
#include <functional>
#include <limits>

#include "calibration/display/ray_function.h"
#include "common/progress_bar.h"
#include "daemon/report/report.h"
#include "scripts/scene_argument.h"
#include "tracer/position_error.h"
#include "tracer/ray_batch.h"
#include "tracer/visibility_buffer.h"

namespace parallax::report {
namespace {

using Eigen::half;

// One storage format: bytes a pixel, and how a stored pixel becomes a ray (false: masked).
struct Format {
  std::string name, shortName;
  int bytesPerPixel;
  std::function<bool(size_t pixel, Eigen::Vector3f* origin, Eigen::Vector3f* direction)> decode;
};

VisibilityBuffer traceDecoded(const PhysicalScene& scene, int width, int height,
                              const Format& format) {
  VisibilityBuffer out(width, height);
  tbb::parallel_for(
      tbb::blocked_range<int>(0, height, 8), [&](const tbb::blocked_range<int>& rows) {
        std::vector<RTCRayHit> rays;
        std::vector<size_t> pixels;
        for (int row = rows.begin(); row < rows.end(); ++row) {
          for (int column = 0; column < width; ++column) {
            const size_t pixel =
                static_cast<size_t>(row) * static_cast<size_t>(width) + static_cast<size_t>(column);
            Eigen::Vector3f o, d;
            if (!format.decode(pixel, &o, &d)) continue;
            rays.push_back(makeRayHit(o, d));
            pixels.push_back(pixel);
          }
        }
        intersectBatch(scene.handle(), rays, Traversal::kStream, true);
        for (size_t i = 0; i < rays.size(); ++i) {
          const RTCRayHit& h = rays[i];
          if (h.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
          out.samples[pixels[i]] = {static_cast<int>(h.hit.geomID), static_cast<int>(h.hit.primID),
                                    h.hit.u, h.hit.v};
        }
      });
  return out;
}

}  // namespace

void writePrecisionSection(Report& report) {
  const DisplayModel& display = report.display();
  const int module = report.module();
  const OpticalModule& m = display.modules[static_cast<size_t>(module)];
  const size_t pixels = static_cast<size_t>(m.pixelCount());
  const PhysicalScene scene(loadSceneArgument("cornell", {}, 0.0), display.displayableBox);
  const RayTextures compact = generateRayTextures(display, module);
  const RayFrame frame = compact.frame();

  // The exact rays in double, then each format stores them its way.
  std::vector<PixelRay> exactRays(pixels);
  const RayFunction rayFunction(display, module);
  tbb::parallel_for(0, m.height, [&](int row) {
    for (int column = 0; column < m.width; ++column) {
      exactRays[static_cast<size_t>(row) * static_cast<size_t>(m.width) +
                static_cast<size_t>(column)] = rayFunction.atPixel(column, row);
    }
  });
  std::vector<float> full32(6 * pixels, std::numeric_limits<float>::quiet_NaN());
  std::vector<half> full16(6 * pixels, half(std::numeric_limits<float>::quiet_NaN()));
  std::vector<half> compact16(3 * pixels, half(std::numeric_limits<float>::quiet_NaN()));
  for (size_t i = 0; i < pixels; ++i) {
    const PixelRay& r = exactRays[i];
    if (!r.valid()) continue;
    const Eigen::Vector3d d = r.direction();
    for (int k = 0; k < 3; ++k) {
      full32[6 * i + static_cast<size_t>(k)] = static_cast<float>(r.origin[k]);
      full32[6 * i + 3 + static_cast<size_t>(k)] = static_cast<float>(d[k]);
      full16[6 * i + static_cast<size_t>(k)] = half(static_cast<float>(r.origin[k]));
      full16[6 * i + 3 + static_cast<size_t>(k)] = half(static_cast<float>(d[k]));
    }
    compact16[3 * i] = half(static_cast<float>(r.origin.x()));
    compact16[3 * i + 1] = half(static_cast<float>(r.screenPoint.x()));
    compact16[3 * i + 2] = half(static_cast<float>(r.screenPoint.y()));
  }
  auto fromFull = [](auto load) {
    return [load](size_t i, Eigen::Vector3f* o, Eigen::Vector3f* d) {
      *o = {load(6 * i), load(6 * i + 1), load(6 * i + 2)};
      if (std::isnan((*o).x())) return false;
      *d = Eigen::Vector3f(load(6 * i + 3), load(6 * i + 4), load(6 * i + 5)).normalized();
      return true;
    };
  };
  const std::vector<Format> formats = {
      {"float32 origin + direction", "float32", 24, fromFull([&](size_t k) { return full32[k]; })},
      {"float16 origin + direction", "float16", 12,
       fromFull([&](size_t k) { return static_cast<float>(full16[k]); })},
      {"compact float32 (o.x, s.x, s.y)", "compact float32", 12,
       [&](size_t i, Eigen::Vector3f* o, Eigen::Vector3f* d) {
         const CompactRay& r = compact.rays()[i];
         if (r.masked()) return false;
         *o = frame.origin(r);
         *d = frame.direction(r);
         return true;
       }},
      {"compact float16 (o.x, s.x, s.y)", "compact float16", 6,
       [&](size_t i, Eigen::Vector3f* o, Eigen::Vector3f* d) {
         const CompactRay r{static_cast<float>(compact16[3 * i]),
                            static_cast<float>(compact16[3 * i + 1]),
                            static_cast<float>(compact16[3 * i + 2])};
         if (r.masked()) return false;
         *o = frame.origin(r);
         *d = frame.direction(r);
         return true;
       }},
  };
  const VisibilityBuffer reference = tracePrimaryVisibility(scene, compact);
  const ExactSurface exact = exactSurface(scene, display, module, reference);
  const ForwardMap forwardMap(display, module);
  Table table{{"format", "bytes/pixel", "MB/module", "MB/display", "decode + primary trace ms",
               "RMS mm", "max mm", "RMS px", "max px", "coverage mismatch"},
              {},
              report.timing().describe()};
  PlotSeries memory{"RMS mm against MB/module", {}, {}, false};
  ProgressBar progress("ray-texture precision", static_cast<std::int64_t>(formats.size()));
  for (const Format& f : formats) {
    VisibilityBuffer v;
    const double ms =
        timeMedianMs(report.timing(), [&] { v = traceDecoded(scene, m.width, m.height, f); });
    const PositionError e = positionError(scene, v, exact, forwardMap);
    const double mb = static_cast<double>(f.bytesPerPixel) * static_cast<double>(pixels) / 1e6;
    table.rows.push_back({f.name, std::to_string(f.bytesPerPixel), fixed(mb, 2),
                          fixed(mb * static_cast<double>(display.modules.size()), 1), fixed(ms, 2),
                          general(e.rmsMm), general(e.maxMm), general(e.rmsPx), general(e.maxPx),
                          std::to_string(e.candidateOnly + e.exactOnly)});
    memory.add(mb, e.rmsMm, f.shortName);
    progress.advance();
  }
  progress.finish();
  report.heading("Ray-texture precision");
  report.text(fmt::format(
      "Module {}, the Cornell box's primary hits. The exact rays (double) are stored four ways and "
      "traced "
      "back; the error is the hit position against the exact one (as in the error-vs-time table), "
      "time the "
      "decoding of the stored rays plus the primary trace. The compact forms keep o.y, o.z (the "
      "observer "
      "line) and s.z (the sag) exact, so they spend their bits only where rays differ.",
      module));
  report.table("ray_texture_precision", table);
  report.figure("ray_texture_precision", {.title = "ray-texture precision: error against memory",
                                          .xLabel = "MB per module",
                                          .yLabel = "RMS position error (mm)",
                                          .logY = true,
                                          .series = {memory}});
}

}  // namespace parallax::report
