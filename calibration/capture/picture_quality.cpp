#include "calibration/capture/picture_quality.h"

#include <fmt/format.h>

#include <algorithm>

namespace parallax {
namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

std::optional<std::string> overExposure(const cv::Mat& linear, const PictureQualityLimits& limits) {
  const int lit = cv::countNonZero(linear > 0.1f);
  // A dark picture (the black reference, a dark frame) has nothing to clip: its few lit
  // pixels are fiducials and glints.
  if (lit < static_cast<int>(0.005 * static_cast<double>(linear.total()))) return std::nullopt;
  const int clipped = cv::countNonZero(linear >= 0.995f);
  const double share = static_cast<double>(clipped) / lit;
  if (share <= limits.maxClippedShare) return std::nullopt;
  return fmt::format(
      "over-exposed: {:.0f}% of the lit screen at the sensor's full scale (at most {:.0f}%); "
      "take it with less exposure",
      100.0 * share, 100.0 * limits.maxClippedShare);
}

std::optional<std::string> BlurCheck::against(double contrast, double sessionMedian) const {
  if (!(contrast > 0.0) || contrast >= limits_.minContrastRatio * sessionMedian)
    return std::nullopt;
  return fmt::format(
      "blurred: the sync code's cells show {:.0f}% contrast, the session's pictures {:.0f}% "
      "(median); hold the camera still, check its focus",
      100.0 * contrast, 100.0 * sessionMedian);
}

std::optional<std::string> BlurCheck::judge(double contrast) const {
  if (static_cast<int>(contrasts_.size()) < limits_.minPicturesForBlur) return std::nullopt;
  return against(contrast, median(contrasts_));
}

std::optional<std::pair<size_t, std::string>> BlurCheck::firstBlurred() const {
  if (static_cast<int>(contrasts_.size()) < limits_.minPicturesForBlur) return std::nullopt;
  const double m = median(contrasts_);
  for (size_t i = 0; i < contrasts_.size(); ++i) {
    if (std::optional<std::string> why = against(contrasts_[i], m)) return std::pair{i, *why};
  }
  return std::nullopt;
}

}  // namespace parallax
