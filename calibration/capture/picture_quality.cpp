#include "calibration/capture/picture_quality.h"

#include <fmt/format.h>

namespace parallax {

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

std::optional<std::string> blur(const SyncReading& reading, const PictureQualityLimits& limits) {
  // No lit cell at all: contrast 0 means "nothing to measure", not "blurred".
  if (!(reading.contrast > 0.0) || reading.contrast >= limits.minCodeContrast) return std::nullopt;
  return fmt::format(
      "blurred: the sync code's cells show {:.0f}% contrast (a sharp picture's is over {:.0f}%); "
      "hold the camera still, check its focus",
      100.0 * reading.contrast, 100.0 * limits.minCodeContrast);
}

}  // namespace parallax
