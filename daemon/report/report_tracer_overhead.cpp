// The tracer's full frame against raw Embree on exactly the same rays (ray_log.h): what the
// integrator costs beyond the intersections it asks for, per scene. The same figure as
// `parallax bench tracer`'s ratio, here under the report's timing rule.

#include <fmt/format.h>

#include <chrono>
#include <memory>

#include "common/progress_bar.h"
#include "daemon/report/report.h"
#include "scripts/scene_argument.h"
#include "tracer/ray_log.h"
#include "tracer/whitted_integrator.h"

namespace parallax::report {

void writeTracerOverheadSection(Report& report) {
  const DisplayModel& display = report.display();
  const int module = report.module();
  const TimingRule& rule = report.timing();
  const std::vector<std::string> names = {"cornell", "shapes", "statue"};
  const RayTextures textures = generateRayTextures(display, module);
  const RenderOptions options;

  Table table{{"scene", "rays a frame", "full frame ms", "raw Embree ms (same rays)",
               "full / raw (median of runs)", "outside Embree %"},
              {},
              rule.describe() +
                  "; each run times one full frame, then the raw replay of its "
                  "rays, so a slow minute slows both"};
  PlotSeries full{"full frame", {}, {}, false}, raw{"raw Embree (full = raw)", {}, {}, true};
  std::vector<std::string> notes;
  ProgressBar progress("tracer against raw Embree", static_cast<std::int64_t>(names.size()));
  double longest = 0.0;
  for (const std::string& name : names) {
    std::unique_ptr<PhysicalScene> scene;
    try {
      scene =
          std::make_unique<PhysicalScene>(loadSceneArgument(name, {}, 0.0), display.displayableBox);
    } catch (const std::exception& e) {
      notes.push_back(fmt::format("scene `{}` left out: {}", name, e.what()));
      progress.advance();
      continue;
    }
    RayLog log;
    Frame frame = renderFrame(*scene, textures, options, nullptr, &log);
    long rays = 0;
    std::vector<double> rawMs, ratios;
    // Part 0: the full frame; the replay is timed by replayRayLog (Embree calls only).
    const MedianTimes t = timeMedian(rule, 1, [&](std::vector<double>& parts) {
      const auto start = std::chrono::steady_clock::now();
      renderFrameInto(*scene, textures, options, &frame);
      parts[0] +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      rawMs.push_back(replayRayLog(*scene, log, options.traversal, RayKind::kAll, &rays));
      ratios.push_back(parts[0] / rawMs.back());
    });
    // The warm-up's replay is left out, as its frame is.
    rawMs.erase(rawMs.begin(), rawMs.begin() + rule.warmups);
    ratios.erase(ratios.begin(), ratios.begin() + rule.warmups);
    const double fullMs = t.partsMs[0], rawMedian = median(rawMs), ratio = median(ratios);
    table.rows.push_back({name, std::to_string(rays), fixed(fullMs, 2), fixed(rawMedian, 2),
                          fixed(ratio, 2), fixed(100.0 * (1.0 - 1.0 / ratio), 0)});
    full.add(rawMedian, fullMs, name);
    longest = std::max({longest, rawMedian, fullMs});
    progress.advance();
  }
  progress.finish();
  raw.x = {0.0, longest}, raw.y = {0.0, longest};
  raw.markers = false;  // a reference line, not measurements

  report.heading("Tracer against raw Embree");
  report.text(fmt::format(
      "Module {}: the full Whitted frame (`renderFrame`: ray generation from the ray textures, "
      "traversal, shading, shadow and secondary rays, gather) against Embree tracing exactly the "
      "rays that frame traced, recorded and replayed with no shading (`tracer/ray_log.h`, "
      "traversal `{}`). The error is the same (same rays, same hits); the difference is what the "
      "integrator costs beyond Embree. `outside Embree %` is 1 − raw / full.",
      module, traversalName(options.traversal)));
  report.table("tracer_vs_embree", table);
  for (const std::string& n : notes) report.bullet(n);
  report.figure(
      "tracer_vs_embree",
      {.title = fmt::format("full frame against raw Embree on the same rays (module {})", module),
       .xLabel = "raw Embree ms / frame",
       .yLabel = "full frame ms",
       .series = {full, raw}});
}

}  // namespace parallax::report
