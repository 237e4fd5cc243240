#pragma once
// A small SVG line/scatter plot for the report: axes with ticks (linear, integer or log10),
// series told apart by marker shape and colour, points labelled with the setting they are, a
// legend. The layout is computed from measured text widths (text_metrics.h) before anything is
// drawn, and kept: every text element carries its box (`data-box="x0 y0 x1 y1"`), so a test can
// check that nothing leaves the canvas. SVG is text, so figures diff in review; the PNG twin is
// rendered from it (png_twin.h).

#include <string>
#include <utility>
#include <vector>

namespace parallax::report {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;  // points with a non-finite or (on a log axis) non-positive
                             // coordinate are left out
  bool lines = true;         // joined in order; false: markers only
  // Empty, or one per point: the setting the point is ("4 spp", "float16"), written beside it.
  std::vector<std::string> pointLabels = {};
  bool markers = true;  // false: a line only (a reference such as y = x)

  // A point, with the setting it is when `setting` is given.
  void add(double px, double py, std::string setting = {}) {
    x.push_back(px), y.push_back(py);
    if (!setting.empty()) pointLabels.push_back(std::move(setting));
  }
};

// A text element's box on the canvas, px, y down.
struct TextBox {
  std::string text;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

// An aggregate: sections write one as designated initializers, naming only what they set.
struct SvgPlot {
  std::string title = {};
  std::string xLabel = {}, yLabel = {};
  bool logX = false, logY = false;
  bool integerX = false, integerY = false;  // counts: ticks on whole numbers only
  std::string caption = {};  // small print under the plot (provenance), wrapped to the canvas
  std::vector<PlotSeries> series = {};

  struct Layout {
    double width = 0, height = 0;
    double plotX0 = 0, plotY0 = 0, plotX1 = 0, plotY1 = 0;  // the axes' frame
    std::vector<TextBox> texts;                             // every text drawn, legend included
    std::vector<double> xTicks, yTicks;                     // data values of the labelled ticks
    std::vector<std::string> xTickLabels, yTickLabels;
  };

  std::string render(Layout* layout = nullptr) const;
  // Throws InputError naming the file when it cannot be written.
  void write(const std::string& path) const;
};

}  // namespace parallax::report
