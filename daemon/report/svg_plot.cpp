#include "daemon/report/svg_plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "common/input_error.h"
#include "daemon/report/plot_axis.h"
#include "daemon/report/text_metrics.h"

namespace parallax::report {
namespace {

constexpr double kMinWidth = 760, kPlotHeight = 320, kMargin = 10;
constexpr int kTitleSize = 15, kTextSize = 12, kSmallSize = 10;
const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
enum class Marker { kCircle, kSquare, kTriangle, kDiamond, kTriangleDown, kCross, kPlus };
constexpr int kMarkers = 7;

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

// Text boxes: a line of text at size s reaches ~0.8 s above its baseline and ~0.25 s below.
TextBox boxAt(const std::string& text, int size, double x, double baseline, const char* anchor) {
  const double w = textWidth(text, size);
  const double x0 = anchor[0] == 'm' ? x - w / 2 : (anchor[0] == 'e' ? x - w : x);
  return {text, x0, baseline - 0.8 * size, x0 + w, baseline + 0.25 * size};
}

bool overlaps(const TextBox& a, const TextBox& b) {
  return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
}

// Splits `text` into lines no wider than `width` at `size`, at spaces (a word wider than a
// line is cut between its characters).
std::vector<std::string> wrap(const std::string& text, int size, double width) {
  std::vector<std::string> lines;
  std::istringstream words(text);
  std::string word, line;
  while (words >> word) {
    while (textWidth(word, size) > width) {
      size_t cut = 0;  // the longest prefix that fits, ending on a UTF-8 character boundary
      for (size_t i = 1; i < word.size(); ++i) {
        if ((static_cast<unsigned char>(word[i]) & 0xC0) == 0x80) continue;
        if (textWidth(word.substr(0, i), size) > width) break;
        cut = i;
      }
      if (cut == 0) break;
      if (!line.empty()) lines.push_back(line), line.clear();
      lines.push_back(word.substr(0, cut));
      word = word.substr(cut);
    }
    const std::string candidate = line.empty() ? word : line + " " + word;
    if (!line.empty() && textWidth(candidate, size) > width) {
      lines.push_back(line);
      line = word;
    } else {
      line = candidate;
    }
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

std::string marker(Marker shape, double x, double y, const char* colour) {
  const double r = 4.5;
  const std::string style =
      fmt::format("fill=\"white\" fill-opacity=\"0.6\" stroke=\"{}\" stroke-width=\"1.6\"", colour);
  switch (shape) {
    case Marker::kCircle:
      return fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{}\" {}/>", x, y, r, style);
    case Marker::kSquare:
      return fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{}\" height=\"{}\" {}/>", x - r,
                         y - r, 2 * r, 2 * r, style);
    case Marker::kTriangle:
      return fmt::format("<polygon points=\"{:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f}\" {}/>", x,
                         y - 1.2 * r, x + 1.1 * r, y + 0.8 * r, x - 1.1 * r, y + 0.8 * r, style);
    case Marker::kDiamond:
      return fmt::format(
          "<polygon points=\"{:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f}\" {}/>", x,
          y - 1.3 * r, x + 1.3 * r, y, x, y + 1.3 * r, x - 1.3 * r, y, style);
    case Marker::kTriangleDown:
      return fmt::format("<polygon points=\"{:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f}\" {}/>", x,
                         y + 1.2 * r, x + 1.1 * r, y - 0.8 * r, x - 1.1 * r, y - 0.8 * r, style);
    case Marker::kCross:
      return fmt::format(
          "<path d=\"M{:.1f},{:.1f}L{:.1f},{:.1f}M{:.1f},{:.1f}L{:.1f},{:.1f}\" stroke=\"{}\" "
          "stroke-width=\"2\"/>",
          x - r, y - r, x + r, y + r, x - r, y + r, x + r, y - r, colour);
    case Marker::kPlus:
      return fmt::format(
          "<path d=\"M{:.1f},{:.1f}L{:.1f},{:.1f}M{:.1f},{:.1f}L{:.1f},{:.1f}\" stroke=\"{}\" "
          "stroke-width=\"2\"/>",
          x - 1.2 * r, y, x + 1.2 * r, y, x, y - 1.2 * r, x, y + 1.2 * r, colour);
  }
  return "";
}

}  // namespace

std::string SvgPlot::render(Layout* layoutOut) const {
  std::vector<double> xs, ys;
  {
    const PlotAxis probeX{logX}, probeY{logY};
    for (const PlotSeries& s : series) {
      for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        if (probeX.usable(s.x[i]) && probeY.usable(s.y[i]))
          xs.push_back(s.x[i]), ys.push_back(s.y[i]);
      }
    }
  }
  const PlotAxis ax = PlotAxis::fit(xs, logX, integerX), ay = PlotAxis::fit(ys, logY, integerY);
  const std::vector<PlotAxis::Tick> xTicks = ax.ticks(), yTicks = ay.ticks();

  // --- Layout, from measured text widths, before anything is drawn.
  Layout L;
  double yTickWidth = 0;
  for (const PlotAxis::Tick& t : yTicks)
    yTickWidth = std::max(yTickWidth, textWidth(t.label, kTextSize));
  double legendWidth = 0;
  for (const PlotSeries& s : series)
    legendWidth = std::max(legendWidth, textWidth(s.label, kTextSize));
  legendWidth += 34;  // marker swatch and gap
  const bool legendRight = legendWidth <= 0.34 * kMinWidth;
  double xTickWidth = 0;
  for (const PlotAxis::Tick& t : xTicks)
    xTickWidth = std::max(xTickWidth, textWidth(t.label, kTextSize));
  const double left = kMargin + 16 + 8 + yTickWidth + 6;  // y label, gap, tick labels, gap
  // Wide enough for the title, and for a legend under the frame that starts where it does.
  L.width = std::ceil(std::max({kMinWidth, textWidth(title, kTitleSize) + 2 * kMargin,
                                legendRight ? 0.0 : left + legendWidth + kMargin}));
  // The last x tick label is centred on the frame's right edge: half of it must fit too.
  const double right =
      std::max(legendRight ? legendWidth + 2 * kMargin : 2 * kMargin, xTickWidth / 2 + kMargin);
  L.plotX0 = left;
  L.plotX1 = L.width - right;
  L.plotY0 = 40;
  L.plotY1 = L.plotY0 + kPlotHeight;
  const double plotW = L.plotX1 - L.plotX0, plotH = L.plotY1 - L.plotY0;
  auto px = [&](double x) { return L.plotX0 + (ax.plotted(x) - ax.lo) / (ax.hi - ax.lo) * plotW; };
  auto py = [&](double y) { return L.plotY1 - (ay.plotted(y) - ay.lo) / (ay.hi - ay.lo) * plotH; };

  std::ostringstream body;
  auto text = [&](const std::string& s, int size, double x, double baseline, const char* anchor,
                  const std::string& extra = "") {
    const TextBox box = boxAt(s, size, x, baseline, anchor);
    L.texts.push_back(box);
    body << fmt::format(
        "<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"{}\" text-anchor=\"{}\" "
        "data-box=\"{:.1f} {:.1f} {:.1f} {:.1f}\"{}>{}</text>\n",
        x, baseline, size, anchor, box.x0, box.y0, box.x1, box.y1, extra, escape(s));
  };

  text(title, kTitleSize, L.width / 2, 24, "middle");
  body << fmt::format(
      "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"none\" "
      "stroke=\"black\"/>\n",
      L.plotX0, L.plotY0, plotW, plotH);
  for (const PlotAxis::Tick& t : xTicks) {
    const double x = L.plotX0 + (t.at - ax.lo) / (ax.hi - ax.lo) * plotW;
    body << fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\" stroke=\"{3}\"/>\n", x,
        L.plotY0, L.plotY1, t.label.empty() ? "#f0f0f0" : "#d8d8d8");
    if (t.label.empty()) continue;
    text(t.label, kTextSize, x, L.plotY1 + 16, "middle");
    L.xTicks.push_back(ax.log ? std::pow(10.0, t.at) : t.at);
    L.xTickLabels.push_back(t.label);
  }
  for (const PlotAxis::Tick& t : yTicks) {
    const double y = L.plotY1 - (t.at - ay.lo) / (ay.hi - ay.lo) * plotH;
    body << fmt::format(
        "<line x1=\"{1:.1f}\" y1=\"{0:.1f}\" x2=\"{2:.1f}\" y2=\"{0:.1f}\" stroke=\"{3}\"/>\n", y,
        L.plotX0, L.plotX1, t.label.empty() ? "#f0f0f0" : "#d8d8d8");
    if (t.label.empty()) continue;
    text(t.label, kTextSize, L.plotX0 - 6, y + 4, "end");
    L.yTicks.push_back(ay.log ? std::pow(10.0, t.at) : t.at);
    L.yTickLabels.push_back(t.label);
  }
  double y = L.plotY1 + 36;
  text(xLabel + (logX ? " (log scale)" : ""), kTextSize, (L.plotX0 + L.plotX1) / 2, y, "middle");
  {
    // The y label, turned: its box is the turned one.
    const std::string label = yLabel + (logY ? " (log scale)" : "");
    const double w = textWidth(label, kTextSize), cx = kMargin + 12, cy = (L.plotY0 + L.plotY1) / 2;
    const TextBox box{label, cx - 0.8 * kTextSize, cy - w / 2, cx + 0.25 * kTextSize, cy + w / 2};
    L.texts.push_back(box);
    body << fmt::format(
        "<text transform=\"translate({:.1f},{:.1f}) rotate(-90)\" font-size=\"{}\" "
        "text-anchor=\"middle\" data-box=\"{:.1f} {:.1f} {:.1f} {:.1f}\">{}</text>\n",
        cx, cy, kTextSize, box.x0, box.y0, box.x1, box.y1, escape(label));
  }

  // --- Series: lines under markers, then the point labels where they collide with nothing.
  std::vector<TextBox> placed;
  for (size_t k = 0; k < series.size(); ++k) {
    const PlotSeries& s = series[k];
    const char* colour = kColours[k % std::size(kColours)];
    const Marker shape = static_cast<Marker>(k % kMarkers);
    std::string path, markers;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!ax.usable(s.x[i]) || !ay.usable(s.y[i])) continue;
      const double x = px(s.x[i]), yy = py(s.y[i]);
      path += fmt::format("{}{:.1f},{:.1f} ", path.empty() ? "M" : "L", x, yy);
      if (!s.markers) continue;
      markers += marker(shape, x, yy, colour) + "\n";
      placed.push_back({"", x - 5, yy - 5, x + 5, yy + 5});
    }
    if (s.lines && !path.empty()) {
      body << fmt::format("<path d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"/>\n",
                          path, colour);
    }
    body << markers;
  }
  for (size_t k = 0; k < series.size(); ++k) {
    const PlotSeries& s = series[k];
    const char* colour = kColours[k % std::size(kColours)];
    for (size_t i = 0; i < s.pointLabels.size() && i < s.x.size() && i < s.y.size(); ++i) {
      if (s.pointLabels[i].empty() || !ax.usable(s.x[i]) || !ay.usable(s.y[i])) continue;
      const double x = px(s.x[i]), yy = py(s.y[i]);
      // Right-above, right-below, left-above, left-below, above, below: the first that stays in
      // the frame and covers no other label or marker.
      struct Spot {
        double dx, dy;
        const char* anchor;
      };
      const Spot spots[] = {{7, -6, "start"}, {7, 14, "start"},   {-7, -6, "end"},
                            {-7, 14, "end"},  {0, -10, "middle"}, {0, 19, "middle"}};
      TextBox chosen;
      const Spot* where = nullptr;
      for (const Spot& spot : spots) {
        const TextBox b =
            boxAt(s.pointLabels[i], kSmallSize, x + spot.dx, yy + spot.dy, spot.anchor);
        if (b.x0 < L.plotX0 + 1 || b.x1 > L.plotX1 - 1 || b.y0 < L.plotY0 + 1 ||
            b.y1 > L.plotY1 - 1)
          continue;
        bool clear = true;
        for (const TextBox& other : placed) clear = clear && !overlaps(b, other);
        if (clear) {
          chosen = b, where = &spot;
          break;
        }
      }
      if (!where) {
        // Crowded: keep the label inside the frame, over whatever is there.
        where = &spots[0];
        chosen = boxAt(s.pointLabels[i], kSmallSize, x + 7, yy - 6, "start");
        const double shiftX =
            std::min(0.0, L.plotX1 - 1 - chosen.x1) + std::max(0.0, L.plotX0 + 1 - chosen.x0);
        const double shiftY =
            std::max(0.0, L.plotY0 + 1 - chosen.y0) + std::min(0.0, L.plotY1 - 1 - chosen.y1);
        chosen = boxAt(s.pointLabels[i], kSmallSize, x + 7 + shiftX, yy - 6 + shiftY, "start");
        placed.push_back(chosen);
        text(s.pointLabels[i], kSmallSize, x + 7 + shiftX, yy - 6 + shiftY, "start",
             fmt::format(" fill=\"{}\"", colour));
        continue;
      }
      placed.push_back(chosen);
      text(s.pointLabels[i], kSmallSize, x + where->dx, yy + where->dy, where->anchor,
           fmt::format(" fill=\"{}\"", colour));
    }
  }

  // --- Legend: right of the frame when it fits in a third of the canvas, else under it.
  double legendX = legendRight ? L.plotX1 + kMargin : L.plotX0,
         legendY = legendRight ? L.plotY0 + 12 : y + 22;
  for (size_t k = 0; k < series.size(); ++k) {
    const char* colour = kColours[k % std::size(kColours)];
    const double ly = legendY + 18 * static_cast<double>(k);
    if (series[k].lines) {
      body << fmt::format(
          "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" stroke=\"{3}\" "
          "stroke-width=\"1.5\"/>\n",
          legendX, ly, legendX + 24, colour);
    }
    if (series[k].markers)
      body << marker(static_cast<Marker>(k % kMarkers), legendX + 12, ly, colour) << "\n";
    text(series[k].label, kTextSize, legendX + 30, ly + 4, "start");
  }
  if (!legendRight) y = legendY + 18 * static_cast<double>(series.size()) - 6;

  // --- The caption (provenance), wrapped to the canvas.
  y += 22;
  for (const std::string& line : wrap(caption, kSmallSize, L.width - 2 * kMargin)) {
    text(line, kSmallSize, kMargin, y, "start", " fill=\"#555\"");
    y += 13;
  }
  L.height = std::ceil(y);

  std::ostringstream svg;
  svg << fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} "
      "{1}\" font-family=\"DejaVu Sans, Verdana, sans-serif\">\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
      L.width, L.height);
  svg << body.str() << "</svg>\n";
  if (layoutOut) *layoutOut = std::move(L);
  return svg.str();
}

void SvgPlot::write(const std::string& path) const {
  std::ofstream out(path);
  out << render();
  if (!out) throw InputError({path, "", 0}, "cannot write the plot");
}

}  // namespace parallax::report
