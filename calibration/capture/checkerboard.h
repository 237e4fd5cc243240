#pragma once
// The checkerboard the calibration camera photographs to learn its own intrinsics, and finding
// it in a picture. The board is a printed grid of (innerColumns + 1) × (innerRows + 1) squares
// with a white margin one square wide around it (the quiet zone OpenCV's detector needs).
//
// Board frame (what cv::calibrateCamera calls the object points): origin at the first inner
// corner (where four squares meet), x along a row of inner corners, y down the columns, z = 0
// on the board; inner corner (i, j) is at (i·square, j·square, 0). Grid cell (a, b) is the
// square [a, a+1)·square × [b, b+1)·square: the squares are cells −1..innerColumns − 1 by
// −1..innerRows − 1, the one at cell (−1, −1) (upper left of the first corner) is black.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

namespace parallax {

struct CheckerboardBoard {
  int innerColumns = 9;   // inner corners along a row
  int innerRows = 6;      // inner corners down a column
  double squareM = 0.04;  // side of one square (m)

  // Throws InputError naming the field ("inner_corners", "square_m").
  void validate() const;
  int cornerCount() const { return innerColumns * innerRows; }
  // Inner corners in the board frame, row by row (the order the detector returns them).
  std::vector<Eigen::Vector3d> cornerPoints() const;
  // The printed sheet: squares plus the white margin, in the board frame (x0, y0, x1, y1).
  Eigen::Vector4d sheetBounds() const;
  // Reflectance class of a point (x, y) of the board frame: 0 black square, 1 white square or
  // margin, 2 beyond the sheet. cellOf gives the grid cell it lies in (equal cells ⇒ equal
  // class), which the renderer uses to skip supersampling inside one cell.
  int classAt(double x, double y) const;
  Eigen::Vector2i cellOf(double x, double y) const;
};

// The inner corners in a recorded 8-bit grey picture, row by row, at subpixel precision
// (cv::findChessboardCorners, falling back to findChessboardCornersSB, then cv::cornerSubPix
// with a window sized from the corners' spacing); pixel centres at +0.5 (conventions.h).
// nullopt when the whole board is not found.
std::optional<std::vector<Eigen::Vector2d>> findCheckerboardCorners(const cv::Mat& picture8,
                                                                    const CheckerboardBoard& board);

}  // namespace parallax
