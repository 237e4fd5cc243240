// The frame cache (issue 22) as a trade-off: the memory its records hold against the display
// frame rate of animated scenes — orbit.lua (most triangles move: its bad case) and
// sentinel.lua (one ball moves: its good case) — every module of the report's display
// rendered frame after frame with the cache off and on, in the same runs.

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
namespace {

constexpr int kFramesPerRun = 3;
constexpr double kFrameStep = 1.0 / 30.0;

struct SceneFigures {
  double offFps = 0.0, onFps = 0.0, offMs = 0.0, onMs = 0.0;
  double firstMs = 0.0;  // the cache's first frame, which builds it
  FrameCacheStats stats;
};

SceneFigures measure(const std::string& name, const DisplayModel& display,
                     const std::vector<RayTextures>& textures, const TimingRule& rule) {
  ScriptOptions scriptOptions;
  scriptOptions.quiet = true;
  std::unique_ptr<SceneScript> script =
      SceneScript::loadFile(librarySceneScript(name), scriptOptions);
  const RenderOptions options;
  FrameCache cache;
  std::unique_ptr<PhysicalScene> last;  // hands its textures to the next frame's scene
  Frame frame;
  double time = 0.0;
  // One display frame: the scene at the next time step, every module rendered.
  auto displayFrame = [&](bool cached) {
    time += kFrameStep;
    script->setTime(time);
    const Scene& scene = script->scene();
    auto built = std::make_unique<PhysicalScene>(scene, display.displayableBox,
                                                 cached ? &cache.dynamicInstances(scene) : nullptr,
                                                 last.get());
    PhysicalScene& physical = *built;
    const bool use = cached && cache.prepare(physical, textures, 1, options);
    for (size_t m = 0; m < textures.size(); ++m) {
      if (use) {
        renderFrameInto(physical, textures[m], options, cache.view(m), &frame);
      } else {
        renderFrameInto(physical, textures[m], options, &frame);
      }
    }
    last = std::move(built);
  };
  SceneFigures f;
  // The first cached frame builds the records: timed on its own, before the runs.
  const auto buildStart = std::chrono::steady_clock::now();
  displayFrame(true);
  f.firstMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - buildStart)
          .count();
  // Part 0: the frames with the cache off, part 1: on (built already); a run does both, so a
  // slow minute slows both alike.
  const MedianTimes t = timeMedian(rule, 2, [&](std::vector<double>& parts) {
    for (int k = 0; k < 2; ++k) {
      const auto start = std::chrono::steady_clock::now();
      for (int n = 0; n < kFramesPerRun; ++n) displayFrame(k == 1);
      parts[static_cast<size_t>(k)] +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
    }
  });
  f.offMs = t.partsMs[0] / kFramesPerRun;
  f.onMs = t.partsMs[1] / kFramesPerRun;
  f.offFps = 1000.0 / f.offMs;
  f.onFps = 1000.0 / f.onMs;
  f.stats = cache.stats();
  return f;
}

}  // namespace

void writeFrameCacheSection(Report& report) {
  const DisplayModel& display = report.display();
  const TimingRule& rule = report.timing();
  const std::vector<std::string> names = {"orbit", "sentinel"};
  std::vector<RayTextures> textures;
  for (size_t m = 0; m < display.modules.size(); ++m)
    textures.push_back(generateRayTextures(display, static_cast<int>(m)));

  Table table{{"scene", "frame cache", "memory MiB", "bytes a pixel", "display frames/s",
               "ms a frame", "first frame ms (builds it)"},
              {},
              rule.describe() + fmt::format("; each run renders {} display frames with the cache "
                                            "off, then {} with it on",
                                            kFramesPerRun, kFramesPerRun)};
  std::vector<PlotSeries> series;
  std::vector<std::string> ratios, notes;
  ProgressBar progress("frame cache", static_cast<std::int64_t>(names.size()));
  for (const std::string& name : names) {
    SceneFigures f;
    try {
      f = measure(name, display, textures, rule);
    } catch (const std::exception& e) {
      notes.push_back(fmt::format("scene `{}` left out: {}", name, e.what()));
      progress.advance();
      continue;
    }
    const double mib = static_cast<double>(f.stats.bytes) / (1024.0 * 1024.0);
    table.rows.push_back({name, "off", "0", "0", fixed(f.offFps, 2), fixed(f.offMs, 1), "-"});
    table.rows.push_back({name, "on", fixed(mib, 1), fixed(f.stats.bytesPerPixel(), 0),
                          fixed(f.onFps, 2), fixed(f.onMs, 1), fixed(f.firstMs, 0)});
    PlotSeries s{name + ".lua", {0.0, mib}, {f.offFps, f.onFps}, true};
    s.pointLabels = {"off", "on"};
    series.push_back(s);
    ratios.push_back(fmt::format(
        "`{}`: {:.2f}x the frame rate for {:.1f} MiB ({} static and {} moving objects, {} of its "
        "lights static; the build alone {:.0f} ms)",
        name, f.onFps / f.offFps, mib, f.stats.staticInstances, f.stats.dynamicInstances,
        f.stats.cachedLights, f.stats.lastBuildMs));
    progress.advance();
  }
  progress.finish();

  report.heading("Frame cache: memory against frame rate");
  report.text(fmt::format(
      "Animated scenes played frame after frame on every module of the display ({} modules): "
      "rendering only (no encode, no link). With the cache on, each module pixel keeps its "
      "primary hit on the static geometry and the static lights' shadows (12 bytes, "
      "`tracer/frame_cache.h`); a frame traces its primary rays and those shadow rays against "
      "the moving objects only. `orbit.lua` moves most of its triangles and turns its key light "
      "every frame (the cache's bad case); in `sentinel.lua` one ball moves (its good case).",
      display.modules.size()));
  report.table("frame_cache", table);
  for (const std::string& r : ratios) report.bullet(r);
  for (const std::string& n : notes) report.bullet(n);
  if (series.empty()) return;
  report.figure("frame_cache", {.title = "frame cache: memory against display frame rate",
                                .xLabel = "cache memory MiB",
                                .yLabel = "display frames / s",
                                .series = series});
}

}  // namespace parallax::report
