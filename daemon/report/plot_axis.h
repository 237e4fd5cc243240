#pragma once
// A plot axis of the report: its range from the data and its ticks. Log axes get a tick at
// every decade (and 2, 5 labelled when they span two decades or less); integer axes (counts)
// get ticks on whole numbers only; every label of an axis has one number format (plain
// decimals, or all `1e-5` style when a label would need more than 3 decimals or 6 digits).

#include <string>
#include <vector>

namespace parallax::report {

struct PlotAxis {
  bool log = false;
  bool integer = false;
  double lo = 0, hi = 1;  // in plotted units (log10 of the value on a log axis)

  struct Tick {
    double at = 0;      // plotted units
    std::string label;  // empty: a minor tick, not labelled
  };

  // The range that holds every usable value, padded (linear) or widened to whole decades (log).
  static PlotAxis fit(const std::vector<double>& values, bool log, bool integer);
  bool usable(double v) const;
  double plotted(double v) const;  // value -> plotted units
  std::vector<Tick> ticks() const;
};

// The labels of `values` in one format (see above); `log`: the values are powers of ten and
// their 2×, 5× multiples, labelled with as few decimals as each needs.
std::vector<std::string> tickLabels(const std::vector<double>& values, bool log);

}  // namespace parallax::report
