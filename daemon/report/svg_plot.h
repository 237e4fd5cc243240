#pragma once
// A small SVG line/scatter plot for the report: axes with ticks (linear or log10), labelled
// series, a legend. SVG is text, so the report needs no plotting dependency and its figures
// diff in review.

#include <string>
#include <vector>

namespace parallax::report {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;  // points with a non-finite or (on a log axis) non-positive
                             // coordinate are left out
  bool lines = true;         // joined in order; false: markers only
};

struct SvgPlot {
  std::string title;
  std::string xLabel, yLabel;
  bool logX = false, logY = false;
  std::string caption;  // small print under the plot (machine, command, date)
  std::vector<PlotSeries> series;

  // Throws InputError naming the file when it cannot be written.
  void write(const std::string& path) const;
  std::string render() const;
};

}  // namespace parallax::report
