// The frame cache (issue 22) as a trade-off: the memory its records hold against the display
// frame rate of an animated scene (orbit.lua), every module of the report's display rendered
// frame after frame with the cache off and on, in the same runs.

#include <fmt/format.h>

#include <chrono>
#include <memory>

#include "common/progress_bar.h"
#include "daemon/report/report.h"
#include "scripts/scene_argument.h"
#include "scripts/scene_script.h"
#include "tracer/frame_cache.h"
#include "tracer/whitted_integrator.h"

namespace parallax::report {

void writeFrameCacheSection(Report& report) {
  const DisplayModel& display = report.display();
  const TimingRule& rule = report.timing();
  constexpr int kFramesPerRun = 3;
  constexpr double kFrameStep = 1.0 / 30.0;
  ScriptOptions scriptOptions;
  scriptOptions.quiet = true;
  std::unique_ptr<SceneScript> script =
      SceneScript::loadFile(librarySceneScript("orbit"), scriptOptions);

  std::vector<RayTextures> textures;
  for (size_t m = 0; m < display.modules.size(); ++m)
    textures.push_back(generateRayTextures(display, static_cast<int>(m)));
  const RenderOptions options;
  FrameCache cache;
  Frame frame;
  double time = 0.0;
  // One display frame: the scene at the next time step, every module rendered.
  auto displayFrame = [&](bool cached) {
    time += kFrameStep;
    script->setTime(time);
    const Scene& scene = script->scene();
    PhysicalScene physical(scene, display.displayableBox,
                           cached ? &cache.dynamicInstances(scene) : nullptr);
    const bool use = cached && cache.prepare(physical, textures, 1, options);
    for (size_t m = 0; m < textures.size(); ++m) {
      if (use) {
        renderFrameInto(physical, textures[m], options, cache.view(m), &frame);
      } else {
        renderFrameInto(physical, textures[m], options, &frame);
      }
    }
  };
  // The first cached frame builds the records: timed on its own, before the runs.
  const auto buildStart = std::chrono::steady_clock::now();
  displayFrame(true);
  const double firstMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - buildStart)
          .count();

  ProgressBar progress("frame cache", 1);
  // Part 0: the frames with the cache off, part 1: on (built already); a run does both, so a
  // slow minute slows both alike.
  const MedianTimes t = timeMedian(rule, 2, [&](std::vector<double>& parts) {
    for (int k = 0; k < 2; ++k) {
      const auto start = std::chrono::steady_clock::now();
      for (int f = 0; f < kFramesPerRun; ++f) displayFrame(k == 1);
      parts[static_cast<size_t>(k)] +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
    }
  });
  progress.finish();
  const FrameCacheStats& stats = cache.stats();
  const double offFps = 1000.0 * kFramesPerRun / t.partsMs[0];
  const double onFps = 1000.0 * kFramesPerRun / t.partsMs[1];
  const double mib = static_cast<double>(stats.bytes) / (1024.0 * 1024.0);

  Table table{{"frame cache", "memory MiB", "bytes a pixel", "display frames/s", "ms a frame"},
              {},
              rule.describe() + fmt::format("; each run renders {} display frames with the cache "
                                            "off, then {} with it on",
                                            kFramesPerRun, kFramesPerRun)};
  table.rows.push_back({"off", "0", "0", fixed(offFps, 2), fixed(t.partsMs[0] / kFramesPerRun, 1)});
  table.rows.push_back({"on", fixed(mib, 1), fixed(stats.bytesPerPixel(), 0), fixed(onFps, 2),
                        fixed(t.partsMs[1] / kFramesPerRun, 1)});

  report.heading("Frame cache: memory against frame rate");
  report.text(fmt::format(
      "`orbit.lua` played frame after frame on every module of the display ({} modules, {} "
      "pixels): rendering only (no encode, no link). With the cache on, each module pixel keeps "
      "its primary hit on the static geometry and the static lights' shadows (12 bytes, "
      "`tracer/frame_cache.h`); a frame traces its primary rays and those shadow rays against "
      "the moving objects only. The cache's first frame, which builds it, took {:.0f} ms (the "
      "build alone {:.0f} ms); {} static and {} moving objects, {} of the scene's lights static. "
      "On/off: {:.2f}x the frame rate for {:.1f} MiB.",
      display.modules.size(), stats.pixels, firstMs, stats.lastBuildMs, stats.staticInstances,
      stats.dynamicInstances, stats.cachedLights, onFps / offFps, mib));
  report.table("frame_cache", table);
  PlotSeries series{"orbit.lua", {0.0, mib}, {offFps, onFps}, false};
  series.pointLabels = {"cache off", "cache on"};
  SvgPlot plot;
  plot.title = "frame cache: memory against display frame rate (orbit.lua)";
  plot.xLabel = "cache memory MiB";
  plot.yLabel = "display frames / s";
  plot.series = {series};
  report.figure("frame_cache", plot);
}

}  // namespace parallax::report
