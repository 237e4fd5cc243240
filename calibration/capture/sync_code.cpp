#include "calibration/capture/sync_code.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "calibration/display/ray_function.h"

namespace parallax {
namespace {

// Mean of a column over camera rows [y0, y1) (clipped), averaged with its two neighbours:
// a little less noise than one pixel, still inside a stripe.
double columnMean(const cv::Mat& linear, int x, double y0, double y1) {
  const int a = std::max(0, static_cast<int>(std::floor(y0)));
  const int b = std::min(linear.rows, static_cast<int>(std::ceil(y1)));
  if (b <= a) return 0.0;
  double sum = 0.0;
  int n = 0;
  for (int y = a; y < b; ++y) {
    const float* row = linear.ptr<float>(y);
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = std::clamp(x + dx, 0, linear.cols - 1);
      sum += row[xx];
      ++n;
    }
  }
  return sum / n;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Camera y range of the middle half of code cell `c` in a column.
std::pair<double, double> cellRange(const SyncGeometry& g, size_t column,
                                    const SyncCodeLayout& layout, int c) {
  const double cell = layout.cellRows * g.pxPerRow[column];
  const double centre = g.bandTop[column] + (c + 0.5) * cell;
  return {centre - 0.25 * cell, centre + 0.25 * cell};
}

// The screen height (m) module row v of `module` lands on, at the module's centre column; NaN
// when that pixel misses the screen.
double screenHeightOfRow(const DisplayModel& nominal, int module, double v) {
  const RayFunction rays(nominal, module);
  const PixelRay ray = rays.at(0.5 * nominal.modules[static_cast<size_t>(module)].width, v);
  return ray.valid() ? ray.screenPoint.y() : std::nan("");
}

// Numbers the runs of neighbouring columns (gaps of at most two) and leaves out those of
// under three columns: too narrow to tell a module's light from a stray column.
void assignStripes(SyncGeometry* g) {
  std::vector<int> stripe(g->columns.size(), 0);
  int current = 0;
  for (size_t i = 1; i < g->columns.size(); ++i) {
    if (g->columns[i] - g->columns[i - 1] > 3) ++current;
    stripe[i] = current;
  }
  std::vector<int> size(static_cast<size_t>(current) + 1, 0);
  for (int s : stripe) ++size[static_cast<size_t>(s)];
  SyncGeometry kept;
  std::vector<int> renumbered(size.size(), -1);
  int next = 0;
  for (size_t i = 0; i < g->columns.size(); ++i) {
    const size_t s = static_cast<size_t>(stripe[i]);
    if (size[s] < 3) continue;
    if (renumbered[s] < 0) renumbered[s] = next++;
    kept.columns.push_back(g->columns[i]);
    kept.stripe.push_back(renumbered[s]);
    kept.bandTop.push_back(g->bandTop[i]);
    kept.whiteTop.push_back(g->whiteTop[i]);
    kept.pxPerRow.push_back(g->pxPerRow[i]);
    kept.patternPx.push_back(g->patternPx[i]);
  }
  kept.black = g->black;
  *g = std::move(kept);
}

int stripeCount(const SyncGeometry& g) { return g.stripe.empty() ? 0 : g.stripe.back() + 1; }

}  // namespace

double pictureBlack(const cv::Mat& linear) {
  // Every other pixel of every other row: the percentile of a quarter of the picture is the
  // picture's, at a quarter of the cost.
  std::vector<float> samples;
  samples.reserve(static_cast<size_t>((linear.rows + 1) / 2) * ((linear.cols + 1) / 2));
  for (int y = 0; y < linear.rows; y += 2) {
    const float* row = linear.ptr<float>(y);
    for (int x = 0; x < linear.cols; x += 2) samples.push_back(row[x]);
  }
  if (samples.empty()) return 0.0;
  const auto at = samples.begin() + static_cast<long>(samples.size() / 50);
  std::nth_element(samples.begin(), at, samples.end());
  return std::max(0.0f, *at);
}

std::optional<SyncCodeLayout> syncLayoutFor(const DisplayModel& nominal, std::string* why) {
  const int height = nominal.modules.front().height;
  // The rows at which the modules' pictures meet the screen's top and bottom edges, over the
  // columns that meet it at all (a module's picture overfills the screen).
  int top = 0, bottom = height;
  for (size_t m = 0; m < nominal.modules.size(); ++m) {
    const RayFunction rays(nominal, static_cast<int>(m));
    const int width = nominal.modules[m].width;
    for (int i = 0; i <= 16; ++i) {
      const double u = (i + 0.5) * width / 17.0;
      int v = 0;
      while (v < height && !rays.at(u, v + 0.5).valid()) ++v;
      if (v == height) continue;
      int w = height - 1;
      while (w > v && !rays.at(u, w + 0.5).valid()) --w;
      top = std::max(top, v);
      bottom = std::min(bottom, w + 1);
    }
  }
  const int visible = bottom - top;
  SyncCodeLayout layout;
  layout.cellRows = std::max(2, visible / 48);
  layout.firstRow = top + static_cast<int>(std::ceil(0.03 * visible));
  if (visible < 16 || layout.patternTop() > top + 0.4 * visible) {
    *why = fmt::format(
        "the modules show only rows {}..{} on the screen: no room for the picture sync code", top,
        bottom - 1);
    return std::nullopt;
  }
  return layout;
}

SyncPrediction predictSync(const DisplayModel& nominal, const CameraIntrinsics& intrinsics,
                           const Eigen::Vector3d& tapeCentre, const SyncCodeLayout& layout) {
  SyncPrediction p;
  p.pxPerRow.assign(static_cast<size_t>(intrinsics.width), 0.0f);
  p.patternPx.assign(static_cast<size_t>(intrinsics.width), 0.0f);
  // Modules stand in a row at the screen's height: any one maps rows to heights alike.
  const int module = static_cast<int>(nominal.modules.size() / 2);
  const int height = nominal.modules.front().height;
  const double y0 = screenHeightOfRow(nominal, module, layout.firstRow + 0.5);
  const double y1 = screenHeightOfRow(nominal, module, layout.patternTop() + 0.5);
  double bottom = screenHeightOfRow(nominal, module, height - 0.5);
  if (!std::isfinite(bottom)) bottom = -0.5 * nominal.screen.height;
  if (!std::isfinite(y0) || !std::isfinite(y1)) return p;
  CameraPose pose;
  pose.centre = tapeCentre;
  pose.physicalFromCamera = aimCameraAt(pose.centre, Eigen::Vector3d::Zero());
  constexpr int kSamples = 256;
  for (int i = 0; i <= kSamples; ++i) {
    const double x = (-0.5 + static_cast<double>(i) / kSamples) * nominal.screen.width;
    Eigen::Vector2d a, b, c;
    if (!projectPhysical(intrinsics, pose, nominal.screen.pointAt(x, y0), &a) ||
        !projectPhysical(intrinsics, pose, nominal.screen.pointAt(x, y1), &b) ||
        !projectPhysical(intrinsics, pose, nominal.screen.pointAt(x, bottom), &c)) {
      continue;
    }
    const int column = static_cast<int>(std::floor(b.x()));
    // Neighbouring samples a few columns apart: each fills the columns up to the next.
    for (int dx = -3; dx <= 3; ++dx) {
      const int cx = column + dx;
      if (cx < 0 || cx >= intrinsics.width) continue;
      p.pxPerRow[static_cast<size_t>(cx)] =
          static_cast<float>((b.y() - a.y()) / (layout.patternTop() - layout.firstRow));
      p.patternPx[static_cast<size_t>(cx)] = static_cast<float>(c.y() - b.y());
    }
  }
  return p;
}

void drawSyncCode(cv::Mat* frame, std::optional<int> code, const SyncCodeLayout& layout) {
  const int end = std::min(frame->rows, layout.patternTop());
  if (end <= layout.firstRow) return;
  (*frame)(cv::Rect(0, layout.firstRow, frame->cols, end - layout.firstRow)).setTo(0.0f);
  if (!code) return;
  for (int b = 0; b < SyncCodeLayout::kBits; ++b) {
    const bool one = ((*code >> b) & 1) != 0;
    const int cell = 2 * b + (one ? 0 : 1);
    const int y0 = layout.firstRow + cell * layout.cellRows;
    const int y1 = std::min(end, y0 + layout.cellRows);
    if (y1 > y0) (*frame)(cv::Rect(0, y0, frame->cols, y1 - y0)).setTo(1.0f);
  }
}

std::optional<SyncGeometry> syncGeometryFromWhite(const cv::Mat& linear,
                                                  const SyncCodeLayout& layout,
                                                  const SyncPrediction& prediction,
                                                  std::string* why) {
  double brightest = 0.0;
  std::vector<double> columnMax(static_cast<size_t>(linear.cols), 0.0);
  for (int x = 0; x < linear.cols; ++x) {
    double m = 0.0;
    for (int y = 0; y < linear.rows; ++y) m = std::max(m, double(linear.at<float>(y, x)));
    columnMax[static_cast<size_t>(x)] = m;
    brightest = std::max(brightest, m);
  }
  if (!(brightest > 0.0)) {
    *why = "the picture is dark";
    return std::nullopt;
  }
  SyncGeometry g;
  g.black = static_cast<float>(pictureBlack(linear));
  int considered = 0, lit = 0, wrongBand = 0;
  const int columns = std::min(linear.cols, static_cast<int>(prediction.pxPerRow.size()));
  for (int x = 1; x + 1 < columns; ++x) {
    const double predicted = prediction.pxPerRow[static_cast<size_t>(x)];
    const double peak = columnMax[static_cast<size_t>(x)];
    if (!(predicted > 0.0) || peak < 0.25 * brightest) continue;
    ++considered;
    // Runs above half the column's peak, whose ends are the edges' half-brightness points,
    // which blur does not move: the longest is the pattern area under the band; the band is
    // the dark gap above it, under the strip of the screen above the band (firstRow's margin).
    const double threshold = 0.5 * peak;
    const auto on = [&](int y) { return linear.at<float>(y, x) >= threshold; };
    int bestTop = 0, bestLength = 0, top = -1;
    for (int y = 0; y <= linear.rows; ++y) {
      const bool bright = y < linear.rows && on(y);
      if (bright && top < 0) top = y;
      if (!bright && top >= 0) {
        if (y - top > bestLength) bestLength = y - top, bestTop = top;
        top = -1;
      }
    }
    int gapTop = bestTop - 1;
    while (gapTop >= 0 && !on(gapTop)) --gapTop;
    ++gapTop;  // the band's first row: under the last bright one above it
    const double pxPerRow = static_cast<double>(bestTop - gapTop) / layout.bandRows();
    const double expectedRun = prediction.patternPx[static_cast<size_t>(x)];
    if (gapTop == 0 || pxPerRow < 0.6 * predicted || pxPerRow > 1.6 * predicted ||
        bestLength < 0.5 * expectedRun) {
      ++wrongBand;
      continue;
    }
    const double cell = layout.cellRows * pxPerRow;
    const double white = columnMean(linear, x, bestTop + 0.5 * cell, bestTop + 1.5 * cell);
    SyncGeometry one;
    one.pxPerRow = {static_cast<float>(pxPerRow)};
    one.bandTop = {static_cast<float>(gapTop)};
    bool dark = true;
    for (int c = 0; c < layout.codeCells(); ++c) {
      const auto [y0, y1] = cellRange(one, 0, layout, c);
      if (columnMean(linear, x, y0, y1) - g.black > 0.3 * (white - g.black)) dark = false;
    }
    if (!dark) {
      ++lit;
      continue;
    }
    if (!(white > g.black)) {
      ++lit;
      continue;
    }
    g.columns.push_back(x);
    g.bandTop.push_back(static_cast<float>(gapTop));
    g.whiteTop.push_back(static_cast<float>(white));
    g.pxPerRow.push_back(static_cast<float>(pxPerRow));
    g.patternPx.push_back(static_cast<float>(bestLength));
  }
  if (considered < 8) {
    *why = "no bright area where the screen should be";
    return std::nullopt;
  }
  assignStripes(&g);
  if (g.columns.size() < std::max<size_t>(8, static_cast<size_t>(considered) / 4)) {
    *why = fmt::format(
        "not a white reference: {} of {} lit columns have no dark band of the code's height "
        "over a bright area, {} a lit one",
        wrongBand, considered, lit);
    return std::nullopt;
  }
  return g;
}

std::optional<std::string> whitesDiffer(const cv::Mat& first, const cv::Mat& second) {
  if (first.size() != second.size()) return std::string("the pictures differ in size");
  double brightest = 0.0;
  cv::minMaxLoc(first, nullptr, &brightest);
  if (!(brightest > 0.0)) return std::string("the first picture is dark");
  const cv::Mat lit = first > 0.5 * brightest;
  const double a = cv::mean(first, lit)[0], b = cv::mean(second, lit)[0];
  if (!(b > 0.0)) return std::string("the second picture is dark where the first is lit");
  cv::Mat difference;
  cv::GaussianBlur(first - second * (a / b), difference, cv::Size(7, 7), 0.0);
  const cv::Mat differs = cv::abs(difference) > 0.15 * brightest;
  const double share =
      static_cast<double>(cv::countNonZero(differs)) / static_cast<double>(first.total());
  if (share <= 0.002) return std::nullopt;
  return fmt::format("the two differ over {:.1f}% of the picture", 100.0 * share);
}

WhiteStripes compareWhiteStripes(const SyncGeometry& first, const SyncGeometry& second) {
  // The columns both show alike; both lists are in column order.
  int common = 0;
  for (size_t i = 0; i < first.columns.size(); ++i) {
    const auto j = std::lower_bound(second.columns.begin(), second.columns.end(), first.columns[i]);
    if (j == second.columns.end() || *j != first.columns[i]) continue;
    const size_t k = static_cast<size_t>(j - second.columns.begin());
    if (std::abs(first.bandTop[i] - second.bandTop[k]) <= 2.0f) ++common;
  }
  // `part` misses stripes of `whole`: nearly all its columns are shown alike there (a few at a
  // stripe's edge come and go with the noise), and `whole` has a stripe's worth more.
  const auto misses = [&](const SyncGeometry& part, const SyncGeometry& whole) {
    const int partOnly = static_cast<int>(part.columns.size()) - common;
    const int wholeOnly = static_cast<int>(whole.columns.size()) - common;
    return common > 0 && partOnly <= std::max(2, static_cast<int>(part.columns.size()) / 20) &&
           wholeOnly >= std::max(3, 2 * partOnly);
  };
  return {misses(first, second), misses(second, first)};
}

std::string SyncReading::describe() const {
  if (code) return fmt::format("code {} ({:.0f}% of the columns)", *code, 100.0 * agreement);
  if (!staleStripe.empty())
    return fmt::format("torn: most columns agree, but {} (a module still shows another frame)",
                       staleStripe);
  return fmt::format("no code ({:.0f}% of the columns readable, {:.0f}% agreeing)",
                     100.0 * readable, 100.0 * agreement);
}

SyncReading readSyncCode(const cv::Mat& linear, const SyncGeometry& geometry,
                         const SyncCodeLayout& layout) {
  SyncReading reading;
  if (geometry.columns.empty()) return reading;
  std::vector<int> votes(SyncCodeLayout::kCodes, 0);
  std::vector<double> exposures;
  // Per column: its code; kMixed where the cells are lit alike (two modules' bands meet there),
  // kDark where none is lit (a module still on a frame whose band is dark).
  constexpr int kMixed = -1, kDark = -2;
  std::vector<int> read(geometry.columns.size(), kMixed);
  int readable = 0;
  std::vector<double> contrasts;
  for (size_t i = 0; i < geometry.columns.size(); ++i) {
    int code = 0;
    bool ok = true;
    double lit = 0.0, brightest = 0.0, weakest = 1.0;
    for (int b = 0; b < SyncCodeLayout::kBits; ++b) {
      const auto [a0, a1] = cellRange(geometry, i, layout, 2 * b);
      const auto [b0, b1] = cellRange(geometry, i, layout, 2 * b + 1);
      const double one = columnMean(linear, geometry.columns[i], a0, a1);
      const double zero = columnMean(linear, geometry.columns[i], b0, b1);
      const double hi = std::max(one, zero), lo = std::min(one, zero);
      // One cell of the pair lit, the other clearly darker: a bit. Both alike: no code here.
      if (!(hi > 0.0) || lo > 0.5 * hi) ok = false;
      if (one > zero) code |= 1 << b;
      lit += hi;
      brightest = std::max(brightest, hi);
      weakest = std::min(weakest, hi > 0.0 ? (hi - lo) / hi : 0.0);
    }
    if (brightest >= 0.3 * geometry.whiteTop[i]) contrasts.push_back(weakest);
    if (!ok) {
      if (brightest < 0.3 * geometry.whiteTop[i]) read[i] = kDark;
      continue;
    }
    ++readable;
    read[i] = code;
    ++votes[static_cast<size_t>(code)];
    if (geometry.whiteTop[i] > 0.0f)
      exposures.push_back(lit / SyncCodeLayout::kBits / geometry.whiteTop[i]);
  }
  const auto best = std::max_element(votes.begin(), votes.end());
  const int columns = static_cast<int>(geometry.columns.size());
  reading.readable = static_cast<double>(readable) / columns;
  reading.contrast = median(contrasts);
  reading.agreement = readable > 0 ? static_cast<double>(*best) / readable : 0.0;
  if (readable < std::max(8, columns / 4) || reading.agreement < 0.9) return reading;
  const int code = static_cast<int>(best - votes.begin());
  const int stripes = stripeCount(geometry);
  // Per stripe: the columns that show another frame (another code, or a dark band), by what
  // they show (index 0: dark, 1 + c: code c).
  std::vector<int> size(static_cast<size_t>(stripes), 0);
  std::vector<std::vector<int>> others(size.size(), std::vector<int>(SyncCodeLayout::kCodes + 1));
  for (size_t i = 0; i < geometry.columns.size(); ++i) {
    const size_t s = static_cast<size_t>(geometry.stripe[i]);
    ++size[s];
    if (read[i] == kDark) ++others[s][0];
    if (read[i] >= 0 && read[i] != code) ++others[s][static_cast<size_t>(read[i] + 1)];
  }
  for (size_t s = 0; s < size.size(); ++s) {
    int stale = 0;
    for (int n : others[s]) stale += n;
    if (stale < std::max(3, (size[s] + 2) / 3)) continue;
    const auto most = std::max_element(others[s].begin(), others[s].end()) - others[s].begin();
    const auto first =
        std::find(geometry.stripe.begin(), geometry.stripe.end(), static_cast<int>(s));
    const auto last =
        std::find(geometry.stripe.rbegin(), geometry.stripe.rend(), static_cast<int>(s));
    reading.staleStripe =
        fmt::format("columns {}..{} read {}",
                    geometry.columns[static_cast<size_t>(first - geometry.stripe.begin())],
                    geometry.columns[geometry.columns.size() - 1 -
                                     static_cast<size_t>(last - geometry.stripe.rbegin())],
                    most == 0 ? std::string("a dark band") : fmt::format("code {}", most - 1));
    return reading;
  }
  reading.code = code;
  reading.exposure = median(exposures);
  return reading;
}

bool looksBlack(const cv::Mat& linear, const SyncGeometry& geometry, const SyncCodeLayout& layout,
                const SyncPrediction& prediction, double fraction) {
  if (geometry.columns.empty()) return false;
  std::vector<int> lit(static_cast<size_t>(stripeCount(geometry)), 0), size(lit.size(), 0);
  int litColumns = 0;
  for (size_t i = 0; i < geometry.columns.size(); ++i) {
    const double white = geometry.whiteTop[i] - geometry.black;
    // The pattern area in eight slices from its top to its bottom, each against the band (dark
    // in the black and the white reference alike, so an automatic exposure's ambient light
    // cancels): a column is lit when most of its pattern area is (a module still on the white
    // reference lights all of it, a fiducial or a glint a spot).
    double band = 0.0;
    for (int c = 0; c < layout.codeCells(); ++c) {
      const auto [y0, y1] = cellRange(geometry, i, layout, c);
      band += columnMean(linear, geometry.columns[i], y0, y1) / layout.codeCells();
    }
    const double top = geometry.bandTop[i] + layout.bandRows() * geometry.pxPerRow[i];
    const double slice = prediction.patternPx[static_cast<size_t>(geometry.columns[i])] / 8.0;
    int litSlices = 0;
    for (int s = 0; s < 8; ++s) {
      if (columnMean(linear, geometry.columns[i], top + (s + 0.25) * slice,
                     top + (s + 0.75) * slice) -
              band >=
          fraction * white)
        ++litSlices;
    }
    const size_t stripe = static_cast<size_t>(geometry.stripe[i]);
    ++size[stripe];
    if (litSlices > 4) {
      ++lit[stripe];
      ++litColumns;
    }
  }
  if (litColumns > 0.1 * static_cast<double>(geometry.columns.size())) return false;
  for (size_t s = 0; s < size.size(); ++s) {
    if (lit[s] >= std::max(3, (size[s] + 2) / 3)) return false;
  }
  return true;
}

}  // namespace parallax
