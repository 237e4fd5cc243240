#include "calibration/capture/structured_light.h"

#include <cmath>
#include <numbers>

#include "common/input_error.h"

namespace parallax {
namespace {

int gray(int n) { return n ^ (n >> 1); }

int fromGray(int g) {
  int n = 0;
  for (; g; g >>= 1) n ^= g;
  return n;
}

}  // namespace

void StructuredLightOptions::validate() const {
  if (periodPx < 4 || periodPx > 4096) throw InputError({"", "period_px", 0}, "must be 4..4096");
  if (phaseSteps < 3 || phaseSteps > 32) throw InputError({"", "phase_steps", 0}, "must be 3..32");
  if (!(minContrast > 0.0 && minContrast < 1.0))
    throw InputError({"", "min_contrast", 0}, "must be in (0, 1)");
}

int grayBitCount(int extent, int periodPx) {
  const int periods = (extent + periodPx - 1) / periodPx;
  int bits = 0;
  while ((1 << bits) < periods) ++bits;
  return bits;
}

std::vector<cv::Mat> makePatternFrames(int width, int height, PatternAxis axis,
                                       const StructuredLightOptions& options) {
  options.validate();
  const int extent = axis == PatternAxis::kColumns ? width : height;
  const int bits = grayBitCount(extent, options.periodPx);
  std::vector<cv::Mat> frames;
  frames.push_back(cv::Mat(height, width, CV_32F, cv::Scalar(1.0f)));
  frames.push_back(cv::Mat(height, width, CV_32F, cv::Scalar(0.0f)));
  auto fill = [&](auto valueAt) {
    cv::Mat frame(height, width, CV_32F);
    for (int y = 0; y < height; ++y) {
      float* row = frame.ptr<float>(y);
      for (int x = 0; x < width; ++x) row[x] = valueAt(axis == PatternAxis::kColumns ? x : y);
    }
    frames.push_back(frame);
  };
  for (int b = bits - 1; b >= 0; --b) {
    fill([&](int i) { return static_cast<float>((gray(i / options.periodPx) >> b) & 1); });
  }
  for (int k = 0; k < options.phaseSteps; ++k) {
    fill([&](int i) {
      const double u = i + 0.5;
      return static_cast<float>(0.5 +
                                0.5 * std::cos(2.0 * std::numbers::pi * u / options.periodPx -
                                               2.0 * std::numbers::pi * k / options.phaseSteps));
    });
  }
  return frames;
}

std::optional<double> decodePixel(const std::vector<float>& I, int extent,
                                  const StructuredLightOptions& options) {
  const int bits = grayBitCount(extent, options.periodPx);
  if (static_cast<int>(I.size()) != 2 + bits + options.phaseSteps) return std::nullopt;
  const double white = I[0], black = I[1];
  if (!(white - black >= options.minContrast)) return std::nullopt;
  const double threshold = 0.5 * (white + black);
  int code = 0;
  for (int b = 0; b < bits; ++b)
    code = (code << 1) | (I[static_cast<size_t>(2 + b)] > threshold ? 1 : 0);
  const int period = fromGray(code);
  double s = 0.0, c = 0.0;
  for (int k = 0; k < options.phaseSteps; ++k) {
    const double delta = 2.0 * std::numbers::pi * k / options.phaseSteps;
    const double value = I[static_cast<size_t>(2 + bits + k)];
    s += value * std::sin(delta);
    c += value * std::cos(delta);
  }
  double theta = std::atan2(s, c);
  if (theta < 0.0) theta += 2.0 * std::numbers::pi;
  const double P = options.periodPx;
  const double fine = theta * P / (2.0 * std::numbers::pi);
  const double coarse = period * P + 0.5 * P;
  const double u = fine + P * std::round((coarse - fine) / P);
  if (!(u >= 0.0 && u <= extent) || !std::isfinite(u)) return std::nullopt;
  return u;
}

}  // namespace parallax
