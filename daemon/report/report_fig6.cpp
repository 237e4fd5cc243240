// The paper's Fig. 6: the xyz triangle (colour = world position) rasterized, ray traced, and
// their difference ×4, on one module.

#include <fmt/format.h>

#include "daemon/report/report.h"
#include "tracer/position_error.h"
#include "tracer/rasterizer.h"
#include "tracer/scene_fixtures.h"
#include "tracer/whitted_integrator.h"

namespace parallax::report {

void writeFig6Section(Report& report) {
  const DisplayModel& display = report.display();
  const int module = report.module();
  const PhysicalScene scene(makeXyzTriangleScene(), display.displayableBox);
  const RayTextures textures = generateRayTextures(display, module);
  const Frame traced = renderFrame(scene, textures, RenderOptions{});
  const Rasterizer rasterizer(display, module);
  report.heading("Fig. 6: the xyz triangle, rasterized and ray traced");
  report.text(fmt::format(
      "The triangle (1,0,0), (0,1,0), (0,0,1) with its world position as colour, on module {} of "
      "`{}`. "
      "Rasterized: vertices through the forward map, colours interpolated linearly in the module "
      "image "
      "(level 0, no tessellation). The difference ×4 is |traced − rasterized|·4 per channel "
      "(linear RGB, "
      "written as sRGB): dark where the two agree. Traced colours are exact to 1e-5 "
      "(tests/tracer); the "
      "rasterized ones bend with the double perspective.",
      module, report.options().display));
  Table table{{"image", "interpolation", "max |difference| (world units)", "mean |difference|"},
              {}};
  for (Interpolation mode : {Interpolation::kLinear, Interpolation::kPerspective}) {
    RasterOptions options;
    options.interpolation = mode;
    const Frame rasterized = rasterizeFrame(rasterizer, scene, textures, options);
    Frame difference(traced.width, traced.height);
    double worst = 0.0, sum = 0.0;
    long count = 0;
    for (size_t i = 0; i < traced.pixels.size(); ++i) {
      const Rgb d = (traced.pixels[i] - rasterized.pixels[i]).cwiseAbs();
      difference.pixels[i] = 4.0f * d;
      // Only where both show the triangle: at its edges one of them shows background.
      if (traced.pixels[i].sum() > 0.0f && rasterized.pixels[i].sum() > 0.0f) {
        worst = std::max(worst, static_cast<double>(d.maxCoeff()));
        sum += d.maxCoeff();
        ++count;
      }
    }
    const std::string name = interpolationName(mode);
    writePng(rasterized, report.path("fig6_xyz_rasterized_" + name + ".png"));
    writePng(difference, report.path("fig6_xyz_difference_x4_" + name + ".png"));
    table.rows.push_back({"fig6_xyz_difference_x4_" + name + ".png", name, general(worst),
                          general(count ? sum / static_cast<double>(count) : 0.0)});
  }
  writePng(traced, report.path("fig6_xyz_traced.png"));
  report.images(
      {{"fig6_xyz_rasterized_linear.png", "rasterized (linear)"},
       {"fig6_xyz_traced.png", "ray traced"},
       {"fig6_xyz_difference_x4_linear.png", "difference ×4 (linear)"},
       {"fig6_xyz_difference_x4_perspective.png", "difference ×4 (perspective-correct)"}});
  report.table("fig6_xyz_difference", table);
}

}  // namespace parallax::report
