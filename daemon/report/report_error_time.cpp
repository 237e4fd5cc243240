// Error against run time: the rasterizer at tessellation levels 0..5 (linear and
// perspective-correct) and the ray tracer, on the xyz triangle and the three paper scenes.

#include <fmt/format.h>

#include <cmath>
#include <memory>

#include "common/progress_bar.h"
#include "daemon/report/report.h"
#include "scripts/scene_argument.h"
#include "tracer/direct_shading.h"
#include "tracer/position_error.h"
#include "tracer/rasterizer.h"
#include "tracer/scene_fixtures.h"
#include "tracer/visibility_buffer.h"
#include "tracer/whitted_integrator.h"

namespace parallax::report {
namespace {

struct Row {
  std::string scene, method;
  int level = -1;  // −1: the tracer
  double ms = 0.0;
  PositionError error;
  long triangles = 0, failedVertices = 0;
  double projectMs = 0.0, scanMs = 0.0;  // rasterizer: parts of ms, from the same runs
};

std::vector<std::string> cells(const Row& r) {
  return {r.scene,
          r.method,
          r.level < 0 ? "" : std::to_string(r.level),
          fixed(r.ms, 2),
          r.level < 0 ? "" : fixed(r.projectMs, 2),
          r.level < 0 ? "" : fixed(r.scanMs, 2),
          general(r.error.rmsMm),
          general(r.error.maxMm),
          general(r.error.rmsPx),
          general(r.error.maxPx),
          std::to_string(r.error.compared),
          std::to_string(r.error.candidateOnly + r.error.exactOnly),
          std::to_string(r.triangles),
          std::to_string(r.failedVertices)};
}

}  // namespace

void writeErrorVsTimeSection(Report& report) {
  const bool quick = report.options().quick;
  const DisplayModel& display = report.display();
  const int module = report.module();
  const int maxLevel = 5;
  // Projection cost grows as triangles × 4^level; levels beyond this many small triangles are
  // left out (named in the report) so the default run stays within minutes.
  const long triangleBudget = quick ? 40000 : 3000000;
  const std::vector<std::string> names = {"xyz", "cornell", "shapes", "statue"};

  report.heading("Error against run time");
  report.text(fmt::format(
      "Module {} of `{}`. Error: world position of what each pixel shows against the exact answer "
      "(the pixel "
      "centre's ray from the ray function in double precision, met with the plane of the triangle "
      "the tracer "
      "found), over the pixels both cover: in physical mm and in module pixels (the forward map of "
      "the shown "
      "point against the pixel centre; taken on up to 20,000 pixels a frame). `coverage mismatch` "
      "counts pixels "
      "that show a surface in one and not the other (silhouettes). Time: ms for one frame; the "
      "rasterizer's includes projecting every vertex through the forward map (a Newton solve per "
      "vertex under `conical`), scan conversion and its direct shading (the projection and the "
      "scan conversion alone are its parts, from the same runs); the tracer's is the "
      "full Whitted frame (`renderFrame`) and, as `tracer (depth 1)`, primary rays with shadow "
      "rays only. The "
      "rasterizer cannot trace mirrors and glass (direct shading only), so times compare unequal "
      "work: the "
      "tracer does more. In the plots, L0–L5 label the rasterizer's tessellation levels.",
      module, report.options().display));

  const RayTextures textures = generateRayTextures(display, module);
  const ForwardMap forwardMap(display, module);
  const Rasterizer rasterizer(display, module);
  std::vector<Row> rows;
  std::vector<std::string> notes;
  ProgressBar progress("error vs time",
                       static_cast<std::int64_t>(names.size()) * (2 * (maxLevel + 1) + 2));
  for (const std::string& name : names) {
    std::unique_ptr<PhysicalScene> scene;
    try {
      const Scene source =
          name == "xyz" ? makeXyzTriangleScene() : loadSceneArgument(name, {}, 0.0);
      scene = std::make_unique<PhysicalScene>(source, display.displayableBox);
    } catch (const std::exception& e) {
      notes.push_back(fmt::format("scene `{}` left out: {}", name, e.what()));
      progress.advance(2 * (maxLevel + 1) + 2);
      continue;
    }
    const VisibilityBuffer traced = tracePrimaryVisibility(*scene, textures);
    const ExactSurface exact = exactSurface(*scene, display, module, traced);
    long sourceTriangles = 0;
    for (const PhysicalMesh& m : scene->meshes())
      sourceTriangles += static_cast<long>(m.triangles.size());

    Row tracer;
    tracer.scene = name;
    tracer.method = "tracer";
    tracer.error = positionError(*scene, traced, exact, forwardMap);
    tracer.triangles = sourceTriangles;
    tracer.ms =
        timeMedianMs(report.timing(), [&] { renderFrame(*scene, textures, RenderOptions{}); });
    progress.advance();
    Row shallow = tracer;
    shallow.method = "tracer (depth 1)";
    RenderOptions depthOne;
    depthOne.maxDepth = 1;
    shallow.ms = timeMedianMs(report.timing(), [&] { renderFrame(*scene, textures, depthOne); });
    progress.advance();
    for (Interpolation mode : {Interpolation::kLinear, Interpolation::kPerspective}) {
      for (int level = 0; level <= maxLevel; ++level) {
        progress.advance();
        if (sourceTriangles * (1L << (2 * level)) > triangleBudget) {
          notes.push_back(fmt::format(
              "`{}` rasterizer {} level {} left out: {} triangles over the budget of {}", name,
              interpolationName(mode), level, sourceTriangles * (1L << (2 * level)),
              triangleBudget));
          continue;
        }
        RasterOptions options;
        options.tessellationLevel = level;
        options.interpolation = mode;
        Row row;
        row.scene = name;
        row.method = fmt::format("raster {}", interpolationName(mode));
        row.level = level;
        RasterCounters counters;
        VisibilityBuffer visibility;
        const MedianTimes times = timeMedian(report.timing(), 2, [&](std::vector<double>& parts) {
          visibility = rasterizer.rasterize(*scene, textures, options, &counters);
          parts[0] += counters.projectMs;
          parts[1] += counters.rasterMs;
          shadeDirect(*scene, visibility, textures);
        });
        row.ms = times.ms;
        row.projectMs = times.partsMs[0];
        row.scanMs = times.partsMs[1];
        row.error = positionError(*scene, visibility, exact, forwardMap);
        row.triangles = counters.drawnTriangles;
        row.failedVertices = counters.failedVertices;
        rows.push_back(row);
      }
    }
    rows.push_back(tracer);
    rows.push_back(shallow);

    SvgPlot plot{.title = fmt::format("{}: position error against time (module {} of {})", name,
                                      module, report.options().display),
                 .xLabel = "ms / frame",
                 .yLabel = "RMS position error (mm, physical)",
                 .logX = true,
                 .logY = true};
    for (const char* method :
         {"raster linear", "raster perspective", "tracer", "tracer (depth 1)"}) {
      PlotSeries s;
      s.label = method;
      s.lines = std::string(method).rfind("raster", 0) == 0;
      for (const Row& r : rows) {
        if (r.scene != name || r.method != method) continue;
        // The tracer's error is float rounding (~1e-7 m); a log axis shows it as it is.
        s.add(r.ms, r.error.rmsMm, r.level >= 0 ? fmt::format("L{}", r.level) : "");
      }
      plot.series.push_back(s);
    }
    report.figure("error_vs_time_" + name, plot);
  }
  progress.finish();
  Table table{{"scene", "method", "level", "ms/frame", partOf("projection ms", "ms/frame"),
               partOf("scan conversion ms", "ms/frame"), "RMS mm", "max mm", "RMS px", "max px",
               "pixels compared", "coverage mismatch", "triangles drawn", "failed vertices"},
              {},
              report.timing().describe()};
  for (const Row& r : rows) table.rows.push_back(cells(r));
  report.table("error_vs_time", table);
  for (const std::string& n : notes) report.bullet(n);
}

}  // namespace parallax::report
