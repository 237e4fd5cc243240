// The screen transfer: `linear` vs `conical` on the same display, row by row: how far apart
// their rays land at the observer line, and which pixel each would use for the same point.

#include <fmt/format.h>

#include <cmath>

#include "calibration/display/forward_map.h"
#include "calibration/display/ray_function.h"
#include "daemon/report/report.h"

namespace parallax::report {
namespace {

// "2nd", "4th": the steps in the prose.
std::string ordinal(int n) {
  const int tens = n % 100, units = n % 10;
  const char* suffix = tens >= 11 && tens <= 13 ? "th"
                       : units == 1             ? "st"
                       : units == 2             ? "nd"
                       : units == 3             ? "rd"
                                                : "th";
  return std::to_string(n) + suffix;
}

}  // namespace

void writeTransferSection(Report& report) {
  DisplayModel linear = report.display(), conical = report.display();
  linear.screen.transfer = ScreenTransfer::kLinear;
  conical.screen.transfer = ScreenTransfer::kConical;
  const int module = report.module();
  const OpticalModule& m = linear.modules[static_cast<size_t>(module)];
  const RayFunction linearRays(linear, module), conicalRays(conical, module);
  const ForwardMap conicalMap(conical, module);
  const int rowStep = std::max(1, m.height / 48), columnStep = std::max(1, m.width / 32);
  // Depth planes where the point shown by a linear-model pixel is carried into the conical
  // module image: the back and front faces of B_P.
  const double zBack = linear.displayableBox.min.z(), zFront = linear.displayableBox.max.z();

  Table table{
      {"row", "observer-line mm mean", "observer-line mm max", "module px mean (back of B_P)",
       "module px max (back)", "module px mean (front of B_P)", "module px max (front)", "columns"},
      {}};
  PlotSeries meanMm{"observer line: mean mm", {}, {}, true},
      maxMm{"observer line: max mm", {}, {}, true};
  PlotSeries backPx{"module px (back of B_P), max", {}, {}, true},
      frontPx{"module px (front of B_P), max", {}, {}, true};
  for (int row = 0; row < m.height; row += rowStep) {
    double sumMm = 0, worstMm = 0, sumBack = 0, worstBack = 0, sumFront = 0, worstFront = 0;
    long count = 0, countBack = 0, countFront = 0;
    for (int column = columnStep / 2; column < m.width; column += columnStep) {
      const PixelRay a = linearRays.atPixel(column, row), b = conicalRays.atPixel(column, row);
      if (!a.valid() || !b.valid()) continue;
      const double mm = 1e3 * std::abs(a.origin.x() - b.origin.x());
      sumMm += mm, worstMm = std::max(worstMm, mm), ++count;
      const Eigen::Vector3d d = a.direction();
      for (bool back : {true, false}) {
        const double t = ((back ? zBack : zFront) - a.origin.z()) / d.z();
        const ForwardMapResult r = conicalMap.pixelOf(a.origin + t * d);
        if (!r.ok) continue;
        const double px = (r.pixel - Eigen::Vector2d(column + 0.5, row + 0.5)).norm();
        if (back)
          sumBack += px, worstBack = std::max(worstBack, px), ++countBack;
        else
          sumFront += px, worstFront = std::max(worstFront, px), ++countFront;
      }
    }
    if (count == 0) continue;
    table.rows.push_back({std::to_string(row), fixed(sumMm / static_cast<double>(count), 2),
                          fixed(worstMm, 2),
                          countBack ? fixed(sumBack / static_cast<double>(countBack), 3) : "",
                          countBack ? fixed(worstBack, 3) : "",
                          countFront ? fixed(sumFront / static_cast<double>(countFront), 3) : "",
                          countFront ? fixed(worstFront, 3) : "", std::to_string(count)});
    meanMm.add(row, sumMm / static_cast<double>(count));
    maxMm.add(row, worstMm);
    if (countBack) backPx.add(row, worstBack);
    if (countFront) frontPx.add(row, worstFront);
  }
  report.heading("Screen transfer: linear against conical");
  report.text(fmt::format(
      "Module {} of the same display under both transfers. For every {} row, over every {} "
      "column: how far "
      "apart the two rays of the same pixel land on the observer line (|Δo.x|, mm), and, in the "
      "module image, "
      "how far from the pixel the conical display would draw the point the linear model shows "
      "there, taken "
      "where the linear ray crosses the back (z = {:.2f} m) and front (z = {:.2f} m) faces of B_P "
      "(module px, "
      "through the conical forward map). They agree on the row whose module ray already heads for "
      "the "
      "observer line's height. Rows whose module rays all miss the screen (a 4:3 image covering a "
      "16:9 screen's "
      "width overshoots its height) are left out.",
      module, ordinal(rowStep), ordinal(columnStep), zBack, zFront));
  report.table("transfer_linear_vs_conical", table);
  report.figure("transfer_observer_line",
                {.title = "linear vs conical: distance at the observer line, by module row",
                 .xLabel = "module row",
                 .yLabel = "|Δo.x| (mm)",
                 .integerX = true,
                 .series = {meanMm, maxMm}});
  report.figure("transfer_module_image",
                {.title = "linear vs conical: distance in the module image, by row",
                 .xLabel = "module row",
                 .yLabel = "module px",
                 .integerX = true,
                 .series = {backPx, frontPx}});
}

}  // namespace parallax::report
