#include "calibration/capture/camera_response.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <optional>
#include <vector>

namespace parallax {
namespace {

// Each usable pixel's N phase samples, scaled to a maximum of 1.
struct PhaseSamples {
  int steps = 0;
  std::vector<double> values;  // pixels × steps
  size_t pixels() const { return steps ? values.size() / static_cast<size_t>(steps) : 0; }
};

// With `aboveBlack`, each sample less the black reference's value at that pixel: the light a
// module's own response curve shapes, before its black and the room's light add to it.
void collect(const std::vector<cv::Mat>& frames, int steps, double minContrast, double saturated,
             int step, bool aboveBlack, PhaseSamples* out) {
  const cv::Mat& white = frames[0];
  const cv::Mat& black = frames[1];
  const size_t first = frames.size() - static_cast<size_t>(steps);
  std::vector<double> v(static_cast<size_t>(steps));
  for (int y = step / 2; y < white.rows; y += step) {
    for (int x = step / 2; x < white.cols; x += step) {
      if (!(white.at<float>(y, x) - black.at<float>(y, x) >= minContrast)) continue;
      double lo = 1e300, hi = 0.0;
      bool usable = true;
      for (int k = 0; k < steps; ++k) {
        const double recorded = frames[first + static_cast<size_t>(k)].at<float>(y, x);
        // Clipped samples say only "at least this"; zero or less has no power.
        if (!(recorded > 0.0 && recorded < saturated)) usable = false;
        const double value = aboveBlack ? recorded - black.at<float>(y, x) : recorded;
        if (!(value > 0.0)) usable = false;
        v[static_cast<size_t>(k)] = value;
        lo = std::min(lo, value);
        hi = std::max(hi, value);
      }
      // A flat pixel (the sinusoid's modulation lost in blur or ambient light) carries no shape.
      if (!usable || !(hi > 0.0) || (hi - lo) < 0.2 * hi) continue;
      for (double value : v) out->values.push_back(value / hi);
    }
  }
}

// Σ harmonics² / Σ fundamental² of the samples raised to e, over pixels i ≡ part (mod parts).
double harmonicRatio(const PhaseSamples& s, double e, size_t part, size_t parts) {
  const int n = s.steps;
  double harmonics = 0.0, fundamental = 0.0;
  std::vector<double> v(static_cast<size_t>(n));
  for (size_t p = part; p < s.pixels(); p += parts) {
    for (int k = 0; k < n; ++k)
      v[static_cast<size_t>(k)] =
          std::pow(s.values[p * static_cast<size_t>(n) + static_cast<size_t>(k)], e);
    for (int j = 1; j <= n / 2; ++j) {
      std::complex<double> x = 0.0;
      for (int k = 0; k < n; ++k)
        x += v[static_cast<size_t>(k)] *
             std::polar(1.0, -2.0 * std::numbers::pi * static_cast<double>(j * k) / n);
      if (j == 1)
        fundamental += std::norm(x);
      else
        harmonics += std::norm(x) * ((2 * j == n) ? 1.0 : 2.0);  // bins j and N − j
    }
  }
  return fundamental > 0.0 ? harmonics / fundamental : 1e300;
}

// The exponent in [lo, hi] (log-spaced grid, then golden section) that minimises the ratio.
double bestExponent(const PhaseSamples& s, double lo, double hi, size_t part, size_t parts) {
  constexpr int kGrid = 40;
  const double a = std::log(lo), b = std::log(hi);
  int best = 0;
  double bestCost = 1e300;
  for (int i = 0; i <= kGrid; ++i) {
    const double cost = harmonicRatio(s, std::exp(a + (b - a) * i / kGrid), part, parts);
    if (cost < bestCost) {
      bestCost = cost;
      best = i;
    }
  }
  double l = a + (b - a) * std::max(best - 1, 0) / kGrid;
  double r = a + (b - a) * std::min(best + 1, kGrid) / kGrid;
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double c = r - g * (r - l), d = l + g * (r - l);
  double fc = harmonicRatio(s, std::exp(c), part, parts);
  double fd = harmonicRatio(s, std::exp(d), part, parts);
  for (int i = 0; i < 30; ++i) {
    if (fc < fd) {
      r = d;
      d = c;
      fd = fc;
      c = r - g * (r - l);
      fc = harmonicRatio(s, std::exp(c), part, parts);
    } else {
      l = c;
      c = d;
      fc = fd;
      d = l + g * (r - l);
      fd = harmonicRatio(s, std::exp(d), part, parts);
    }
  }
  return std::exp(0.5 * (l + r));
}

// The exponent over the whole search range [0.2, 5], or nullopt when the search ended at one of
// its bounds (no minimum inside: nothing measured).
std::optional<double> measuredExponent(const PhaseSamples& s) {
  constexpr double kLo = 0.2, kHi = 5.0;
  const double e = bestExponent(s, kLo, kHi, 0, 1);
  if (!(std::isfinite(e) && e > kLo * 1.01 && e < kHi / 1.01)) return std::nullopt;
  return e;
}

}  // namespace

CameraResponseCheck checkCameraResponse(const CalibrationCaptures& captures,
                                        const CameraResponseOptions& options) {
  CameraResponseCheck check;
  check.assumedGamma = captures.camera.responseGamma;
  check.stated = captures.camera.responseGammaStated;
  check.measuredGamma = check.assumedGamma;
  const int steps = captures.patterns.phaseSteps;
  if (steps < 4 || captures.stations.empty()) return check;  // no harmonic bin to look at
  const cv::Mat& any = captures.stations.front().columnFrames.front();
  // Twice the frames' pixels (columns and rows) per set; about a quarter pass the checks.
  const double candidates = 2.0 * static_cast<double>(captures.stations.size()) * any.total();
  const int step =
      std::max(1, static_cast<int>(std::sqrt(candidates / (4.0 * std::max(options.maxPixels, 1)))));
  const double saturated = clippedLinear(captures.camera.responseGamma);
  const auto gather = [&](bool aboveBlack) {
    PhaseSamples samples;
    samples.steps = steps;
    for (const StationCaptures& s : captures.stations) {
      collect(s.columnFrames, steps, captures.patterns.minContrast, saturated, step, aboveBlack,
              &samples);
      collect(s.rowFrames, steps, captures.patterns.minContrast, saturated, step, aboveBlack,
              &samples);
    }
    // Every k-th pixel when more passed than the measurement needs.
    const size_t keep = static_cast<size_t>(std::max(options.maxPixels, 1));
    if (samples.pixels() > keep) {
      const size_t stride = (samples.pixels() + keep - 1) / keep;
      const size_t n = static_cast<size_t>(steps);
      size_t kept = 0;
      for (size_t p = 0; p < samples.pixels(); p += stride, ++kept)
        std::copy_n(samples.values.begin() + static_cast<long>(p * n), n,
                    samples.values.begin() + static_cast<long>(kept * n));
      samples.values.resize(kept * n);
    }
    return samples;
  };
  const PhaseSamples samples = gather(false);
  check.pixels = static_cast<int>(samples.pixels());
  if (check.pixels < options.minPixels) return check;
  const std::optional<double> found = measuredExponent(samples);
  check.measured = found.has_value();
  if (!check.measured) return check;
  const double e = *found;
  // σ from the spread over disjoint subsets, each searched near the whole set's answer.
  constexpr size_t kParts = 8;
  double sum = 0.0, sumSq = 0.0;
  for (size_t part = 0; part < kParts; ++part) {
    const double ep = bestExponent(samples, e / 1.5, e * 1.5, part, kParts);
    sum += ep;
    sumSq += ep * ep;
  }
  const double mean = sum / kParts;
  const double spread =
      std::sqrt(std::max(sumSq / kParts - mean * mean, 0.0) * kParts / (kParts - 1));
  check.measuredGamma = check.assumedGamma * e;
  check.sigma = check.assumedGamma * spread / std::sqrt(static_cast<double>(kParts));
  const double difference = std::abs(check.measuredGamma - check.assumedGamma);
  check.disagrees =
      difference > 3.0 * check.sigma && difference > options.relativeTolerance * check.assumedGamma;
  check.corrected = check.disagrees && !check.stated;
  // The same shape above the black reference: the modules' response when it is theirs (the
  // decoder tells which end bends). Their black and the room's light add after it, so raised
  // whole, a dim flank's samples bend otherwise than a bright centre's.
  if (check.corrected) {
    const PhaseSamples above = gather(true);
    if (static_cast<int>(above.pixels()) >= options.minPixels) {
      check.aboveBlackExponent = measuredExponent(above).value_or(0.0);
    }
  }
  return check;
}

}  // namespace parallax
