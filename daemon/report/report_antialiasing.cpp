// Anti-aliasing: samples per pixel against image error (vs a high-sample reference) and time.

#include <fmt/format.h>

#include <cmath>

#include "common/progress_bar.h"
#include "daemon/report/report.h"
#include "scripts/scene_argument.h"
#include "tracer/supersampled_render.h"

namespace parallax::report {
namespace {

// RMS and max difference of sRGB-encoded values in [0, 1] over the pixels lit by rays.
void imageError(const Frame& a, const Frame& b, const RayTextures& textures, double* rms,
                double* max) {
  double sum = 0.0, worst = 0.0;
  long count = 0;
  const std::vector<std::uint8_t> ea = a.toSrgb8(), eb = b.toSrgb8();
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    if (textures.rays()[i].masked()) continue;
    for (size_t k = 0; k < 3; ++k) {
      const double d =
          (static_cast<double>(ea[3 * i + k]) - static_cast<double>(eb[3 * i + k])) / 255.0;
      sum += d * d;
      worst = std::max(worst, std::abs(d));
    }
    ++count;
  }
  *rms = count ? std::sqrt(sum / (3.0 * static_cast<double>(count))) : 0.0;
  *max = worst;
}

}  // namespace

void writeAntialiasingSection(Report& report) {
  const bool quick = report.options().quick;
  const TimingRule& rule = report.timing();
  const DisplayModel& display = report.display();
  const int module = report.module();
  const std::vector<int> samples = {1, 4, 9, 16};
  const int referenceSamples = quick ? 64 : 36;
  const PhysicalScene scene(loadSceneArgument("cornell", {}, 0.0), display.displayableBox);
  const RayTextures textures = generateRayTextures(display, module);

  ProgressBar progress("anti-aliasing", static_cast<std::int64_t>(samples.size()) + 1);
  RenderOptions options;
  options.samplesPerPixel = referenceSamples;
  const Frame reference = renderFrame(scene, display, module, textures, options);
  progress.advance();
  Table table{{"samples per pixel", "frame ms", partOf("trace ms", "frame ms"),
               partOf("sub-pixel ray generation ms", "frame ms"), "RMS error (sRGB)",
               "max error (sRGB)", "PSNR dB"},
              {},
              rule.describe()};
  PlotSeries curve{"cornell", {}, {}, true};
  for (int n : samples) {
    options.samplesPerPixel = n;
    Frame frame;
    const MedianTimes t = timeMedian(rule, 2, [&](std::vector<double>& parts) {
      SupersampleTimes times;
      frame = renderFrame(scene, display, module, textures, options, nullptr, &times);
      parts[0] += times.traceMs;
      parts[1] += times.rayGenerationMs;
    });
    double rms = 0.0, max = 0.0;
    imageError(frame, reference, textures, &rms, &max);
    const double psnr =
        rms > 0.0 ? -20.0 * std::log10(rms) : std::numeric_limits<double>::infinity();
    table.rows.push_back({std::to_string(n), fixed(t.ms, 1), fixed(t.partsMs[0], 1),
                          fixed(t.partsMs[1], 1), general(rms), general(max),
                          rms > 0.0 ? fixed(psnr, 2) : "identical"});
    curve.add(t.partsMs[0], rms, fmt::format("{} spp", n));
    progress.advance();
  }
  progress.finish();
  report.heading("Anti-aliasing");
  report.text(fmt::format(
      "The Cornell box on module {}: n×n sub-pixel rays at the stratum centres, from the ray "
      "function "
      "(`RenderOptions::samplesPerPixel`), against a {}-sample reference. Error over the unmasked "
      "pixels, "
      "sRGB-encoded values in [0, 1]. Trace time is the frames' tracing and shading; the sub-pixel "
      "ray "
      "textures are constants of the display (a daemon would cache them), so their generation is "
      "listed apart (both are parts of the frame's time).",
      module, referenceSamples));
  report.table("antialiasing", table);
  report.figure(
      "antialiasing",
      {.title = fmt::format("anti-aliasing: image error against trace time (module {})", module),
       .xLabel = "trace ms / frame",
       .yLabel = fmt::format("RMS error vs {} spp (sRGB)", referenceSamples),
       .logX = true,
       .logY = true,
       .series = {curve}});
}

}  // namespace parallax::report
