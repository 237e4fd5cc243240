#include "daemon/report/plot_axis.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace parallax::report {
namespace {

// Decimals `v` needs to be written exactly at 6 significant digits (0.25 -> 2, 100 -> 0).
int decimalsOf(double v) {
  for (int d = 0; d <= 6; ++d) {
    const double scaled = v * std::pow(10.0, d);
    if (std::abs(scaled - std::round(scaled)) < 1e-6 * std::max(1.0, std::abs(scaled))) return d;
  }
  return 6;
}

}  // namespace

std::vector<std::string> tickLabels(const std::vector<double>& values, bool log) {
  bool scientific = false;
  int decimals = 0;
  for (double v : values) {
    const double a = std::abs(v);
    if (a > 0 && (a < 1e-3 || a >= 1e6)) scientific = true;
    decimals = std::max(decimals, decimalsOf(v));
  }
  if (decimals > 3) scientific = true;
  std::vector<std::string> out;
  for (double v : values) {
    if (std::abs(v) < 1e-300 && scientific) {
      out.push_back("0");
    } else if (scientific) {
      const int exponent = static_cast<int>(std::floor(std::log10(std::abs(v)) + 1e-9));
      const double mantissa = v / std::pow(10.0, exponent);
      const int md = log ? decimalsOf(mantissa) : std::min(3, decimalsOf(mantissa));
      out.push_back(fmt::format("{:.{}f}e{}", mantissa, md, exponent));
    } else {
      out.push_back(fmt::format("{:.{}f}", v, log ? decimalsOf(v) : decimals));
    }
  }
  return out;
}

PlotAxis PlotAxis::fit(const std::vector<double>& values, bool log, bool integer) {
  PlotAxis axis;
  axis.log = log;
  axis.integer = integer && !log;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : values) {
    if (!axis.usable(v)) continue;
    lo = std::min(lo, axis.plotted(v));
    hi = std::max(hi, axis.plotted(v));
  }
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (log) {
    // Whole decades, at least one: every decade gets its tick.
    axis.lo = std::floor(lo + 1e-9);
    axis.hi = std::max(axis.lo + 1, std::ceil(hi - 1e-9));
    return axis;
  }
  if (axis.integer) {
    // Half a step beyond the first and last count, so no point sits on the frame.
    axis.lo = std::floor(lo) - 0.5, axis.hi = std::ceil(hi) + 0.5;
    return axis;
  }
  if (hi - lo < 1e-12) {
    const double pad = std::max(std::abs(lo) * 0.1, 1e-3);
    lo -= pad, hi += pad;
  }
  const double pad = 0.05 * (hi - lo);
  axis.lo = lo - pad, axis.hi = hi + pad;
  if (lo >= 0 && axis.lo < 0) axis.lo = 0;  // values that cannot be negative do not go below 0
  if (axis.lo > 0 && axis.lo < 0.2 * axis.hi) axis.lo = 0;  // start at zero when it is near
  return axis;
}

bool PlotAxis::usable(double v) const { return std::isfinite(v) && (!log || v > 0.0); }

double PlotAxis::plotted(double v) const { return log ? std::log10(v) : v; }

std::vector<PlotAxis::Tick> PlotAxis::ticks() const {
  std::vector<double> labelled;  // values
  std::vector<Tick> out;
  if (log) {
    const bool fine = hi - lo <= 2 + 1e-9, minor = hi - lo <= 6 + 1e-9;
    for (double e = lo; e <= hi + 1e-9; e += 1) {
      for (int m = 1; m <= 9; ++m) {
        const double at = e + std::log10(static_cast<double>(m));
        if (at > hi + 1e-9) break;
        if (m == 1 || (fine && (m == 2 || m == 5))) {
          labelled.push_back(m * std::pow(10.0, e));
          out.push_back({at, "x"});
        } else if (minor) {
          out.push_back({at, ""});
        }
      }
    }
  } else {
    const double raw = (hi - lo) / 6;
    const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
    double step = 10 * magnitude;
    for (double m : {1.0, 2.0, 5.0}) {
      if (m * magnitude >= raw) {
        step = m * magnitude;
        break;
      }
    }
    // Counts: every whole number while there are few (stations 2, 3, 5, 9 all get a tick).
    if (integer) step = hi - lo <= 12 ? 1.0 : std::max(1.0, std::round(step));
    for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + 1e-9 * step; t += step) {
      const double v = std::abs(t) < 1e-9 * step ? 0.0 : t;
      labelled.push_back(v);
      out.push_back({v, "x"});
    }
  }
  const std::vector<std::string> labels = tickLabels(labelled, log);
  size_t k = 0;
  for (Tick& t : out)
    if (!t.label.empty()) t.label = labels[k++];
  return out;
}

}  // namespace parallax::report
