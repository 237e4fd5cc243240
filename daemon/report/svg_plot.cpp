#include "daemon/report/svg_plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "common/input_error.h"

namespace parallax::report {
namespace {

constexpr double kWidth = 760, kHeight = 470;
constexpr double kLeft = 80, kRight = 200, kTop = 40, kBottom = 90;
const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

struct Axis {
  bool log = false;
  double lo = 0, hi = 1;  // in plotted units (log10 when log)

  double value(double v) const { return log ? std::log10(v) : v; }
  bool usable(double v) const { return std::isfinite(v) && (!log || v > 0.0); }
  void fit(const std::vector<double>& values) {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (double v : values) {
      if (!usable(v)) continue;
      lo = std::min(lo, value(v));
      hi = std::max(hi, value(v));
    }
    if (!std::isfinite(lo)) lo = 0, hi = 1;
    if (hi - lo < 1e-12) {
      const double pad = log ? 0.5 : std::max(std::abs(lo) * 0.1, 1e-3);
      lo -= pad, hi += pad;
    }
    if (log) {
      lo = std::floor(lo), hi = std::ceil(hi);
    } else {
      const double pad = 0.05 * (hi - lo);
      lo -= pad, hi += pad;
      if (lo > 0 && lo < 0.2 * hi) lo = 0;  // start at zero when it is near
    }
  }
  std::vector<double> ticks() const {
    std::vector<double> out;
    if (log) {
      for (double e = lo; e <= hi + 1e-9; e += 1) out.push_back(e);
      return out;
    }
    const double raw = (hi - lo) / 6;
    const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
    double step = magnitude;
    for (double m : {1.0, 2.0, 5.0, 10.0}) {
      if (m * magnitude >= raw) {
        step = m * magnitude;
        break;
      }
    }
    for (double t = std::ceil(lo / step) * step; t <= hi + 1e-9 * step; t += step) out.push_back(t);
    return out;
  }
  std::string label(double t) const {
    if (log) return fmt::format("{:g}", std::pow(10.0, t));
    return fmt::format("{:.4g}", std::abs(t) < 1e-12 ? 0.0 : t);
  }
};

}  // namespace

std::string SvgPlot::render() const {
  Axis ax{logX}, ay{logY};
  std::vector<double> xs, ys;
  for (const PlotSeries& s : series) {
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (ax.usable(s.x[i]) && ay.usable(s.y[i])) xs.push_back(s.x[i]), ys.push_back(s.y[i]);
    }
  }
  ax.fit(xs);
  ay.fit(ys);
  const double plotW = kWidth - kLeft - kRight, plotH = kHeight - kTop - kBottom;
  auto px = [&](double x) { return kLeft + (ax.value(x) - ax.lo) / (ax.hi - ax.lo) * plotW; };
  auto py = [&](double y) {
    return kTop + plotH - (ay.value(y) - ay.lo) / (ay.hi - ay.lo) * plotH;
  };
  std::ostringstream svg;
  svg << fmt::format(
             R"(<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-family="sans-serif" font-size="12">)",
             kWidth, kHeight)
      << "\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << fmt::format("<text x=\"{}\" y=\"22\" font-size=\"15\" text-anchor=\"middle\">{}</text>\n",
                     kWidth / 2, escape(title));
  svg << fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n",
      kLeft, kTop, plotW, plotH);
  for (double t : ax.ticks()) {
    const double x = kLeft + (t - ax.lo) / (ax.hi - ax.lo) * plotW;
    svg << fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#ddd\"/>"
        "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\">{4}</text>\n",
        x, kTop, kTop + plotH, kTop + plotH + 16, ax.label(t));
  }
  for (double t : ay.ticks()) {
    const double y = kTop + plotH - (t - ay.lo) / (ay.hi - ay.lo) * plotH;
    svg << fmt::format(
        "<line x1=\"{1}\" y1=\"{0:.1f}\" x2=\"{2}\" y2=\"{0:.1f}\" stroke=\"#ddd\"/>"
        "<text x=\"{3}\" y=\"{4:.1f}\" text-anchor=\"end\">{5}</text>\n",
        y, kLeft, kLeft + plotW, kLeft - 6, y + 4, ay.label(t));
  }
  svg << fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
                     kLeft + plotW / 2, kTop + plotH + 36, escape(xLabel + (logX ? " (log)" : "")));
  svg << fmt::format(
      "<text transform=\"translate(18,{}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
      kTop + plotH / 2, escape(yLabel + (logY ? " (log)" : "")));
  for (size_t k = 0; k < series.size(); ++k) {
    const PlotSeries& s = series[k];
    const char* colour = kColours[k % std::size(kColours)];
    std::string path;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!ax.usable(s.x[i]) || !ay.usable(s.y[i])) continue;
      const double x = px(s.x[i]), y = py(s.y[i]);
      path += fmt::format("{}{:.1f},{:.1f} ", path.empty() ? "M" : "L", x, y);
      svg << fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3\" fill=\"{}\"/>\n", x, y,
                         colour);
    }
    if (s.lines && !path.empty()) {
      svg << fmt::format("<path d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"/>\n",
                         path, colour);
    }
    const double ly = kTop + 10 + 18 * static_cast<double>(k);
    svg << fmt::format(
        "<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"{3}\" stroke-width=\"2\"/>"
        "<text x=\"{4}\" y=\"{5}\">{6}</text>\n",
        kLeft + plotW + 10, ly, kLeft + plotW + 30, colour, kLeft + plotW + 36, ly + 4,
        escape(s.label));
  }
  // The caption may be long: wrap it at ~120 characters a line.
  std::string rest = caption;
  double y = kHeight - 34;
  while (!rest.empty() && y < kHeight) {
    size_t cut = rest.size() <= 120 ? rest.size() : rest.rfind(' ', 120);
    if (cut == std::string::npos || cut == 0) cut = std::min<size_t>(rest.size(), 120);
    svg << fmt::format("<text x=\"10\" y=\"{}\" font-size=\"10\" fill=\"#555\">{}</text>\n", y,
                       escape(rest.substr(0, cut)));
    rest = rest.substr(std::min(rest.size(), cut + 1));
    y += 13;
  }
  svg << "</svg>\n";
  return svg.str();
}

void SvgPlot::write(const std::string& path) const {
  std::ofstream out(path);
  out << render();
  if (!out) throw InputError({path, "", 0}, "cannot write the plot");
}

}  // namespace parallax::report
