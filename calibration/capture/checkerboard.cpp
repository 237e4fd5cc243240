#include "calibration/capture/checkerboard.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calibration/display/conventions.h"
#include "common/input_error.h"

namespace parallax {

void CheckerboardBoard::validate() const {
  // Inner corners both odd and even (e.g. 9 × 6) make the grid's ordering unambiguous up to
  // a half turn; at least 3 × 3 for a homography per picture; at most 100 a side.
  if (innerColumns < 3 || innerRows < 3 || innerColumns > 100 || innerRows > 100) {
    throw InputError({"", "inner_corners", 0}, "must be 3..100 inner corners each way");
  }
  if (innerColumns == innerRows) {
    throw InputError({"", "inner_corners", 0},
                     "must differ each way (a square grid's orientation is ambiguous)");
  }
  if (!(squareM > 0.0 && squareM < 1.0))
    throw InputError({"", "square_m", 0}, "must be in (0, 1) m");
}

std::vector<Eigen::Vector3d> CheckerboardBoard::cornerPoints() const {
  std::vector<Eigen::Vector3d> points;
  points.reserve(static_cast<size_t>(cornerCount()));
  for (int j = 0; j < innerRows; ++j) {
    for (int i = 0; i < innerColumns; ++i) points.emplace_back(i * squareM, j * squareM, 0.0);
  }
  return points;
}

Eigen::Vector4d CheckerboardBoard::sheetBounds() const {
  // Inner corner i sits between cells i − 1 and i, so the squares are cells −1..innerColumns − 1
  // (innerColumns + 1 of them); the margin is one more cell each side.
  return {-2.0 * squareM, -2.0 * squareM, (innerColumns + 1) * squareM, (innerRows + 1) * squareM};
}

Eigen::Vector2i CheckerboardBoard::cellOf(double x, double y) const {
  const Eigen::Vector4d sheet = sheetBounds();
  if (!(x >= sheet[0] && x < sheet[2] && y >= sheet[1] && y < sheet[3])) return {INT_MIN, INT_MIN};
  return {static_cast<int>(std::floor(x / squareM)), static_cast<int>(std::floor(y / squareM))};
}

int CheckerboardBoard::classAt(double x, double y) const {
  const Eigen::Vector2i cell = cellOf(x, y);
  if (cell.x() == INT_MIN) return 2;
  const bool inSquares =
      cell.x() >= -1 && cell.x() < innerColumns && cell.y() >= -1 && cell.y() < innerRows;
  if (!inSquares) return 1;  // the white margin
  return ((cell.x() + cell.y()) % 2 == 0) ? 0 : 1;
}

std::optional<std::vector<Eigen::Vector2d>> findCheckerboardCorners(
    const cv::Mat& picture8, const CheckerboardBoard& board) {
  board.validate();
  cv::Mat grey = picture8;
  if (picture8.channels() == 3) cv::cvtColor(picture8, grey, cv::COLOR_BGR2GRAY);
  if (grey.empty() || grey.type() != CV_8UC1) return std::nullopt;
  const cv::Size pattern(board.innerColumns, board.innerRows);
  std::vector<cv::Point2f> corners;
  // FAST_CHECK first rejects a picture without a board in milliseconds (without it the quad
  // detector spends seconds on a noisy empty picture).
  bool found = cv::findChessboardCorners(
      grey, pattern, corners,
      cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK);
  // The sector-based detector finds boards the quad detector misses (strong tilt, blur).
  if (!found)
    found = cv::findChessboardCornersSB(grey, pattern, corners, cv::CALIB_CB_NORMALIZE_IMAGE);
  if (!found || corners.size() != static_cast<size_t>(board.cornerCount())) return std::nullopt;

  // cornerSubPix's window must stay inside the four squares around a corner: size it from the
  // shortest distance between neighbouring corners in the picture.
  double spacing = 1e9;
  for (int j = 0; j < board.innerRows; ++j) {
    for (int i = 0; i < board.innerColumns; ++i) {
      const cv::Point2f& c = corners[static_cast<size_t>(j * board.innerColumns + i)];
      if (i + 1 < board.innerColumns)
        spacing = std::min(
            spacing, cv::norm(corners[static_cast<size_t>(j * board.innerColumns + i + 1)] - c));
      if (j + 1 < board.innerRows)
        spacing = std::min(
            spacing, cv::norm(corners[static_cast<size_t>((j + 1) * board.innerColumns + i)] - c));
    }
  }
  if (!(spacing >= 4.0)) return std::nullopt;  // squares under 4 px: no subpixel corner to find
  const int half = std::clamp(static_cast<int>(0.4 * spacing), 2, 11);
  cv::cornerSubPix(grey, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  std::vector<Eigen::Vector2d> out;
  out.reserve(corners.size());
  for (const cv::Point2f& c : corners) {
    if (!std::isfinite(c.x) || !std::isfinite(c.y)) return std::nullopt;
    out.push_back(pixelFromOpenCv({c.x, c.y}));
  }
  return out;
}

}  // namespace parallax
