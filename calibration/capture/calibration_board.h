#pragma once
// The board a real calibration camera is calibrated with (`parallax camera board|calibrate`):
// a checkerboard (checkerboard.h: the whole board must be seen) or a ChArUco board (OpenCV's
// aruco module: a checkerboard with an ArUco marker in every white square, so each corner is
// known by its id and a partial view still counts). One description gives the printed sheet
// and the detection, so what is printed is what is looked for.
//
// Sheet frame: millimetres from the sheet's top-left corner, x right, y down, white paper with
// black rectangles; a white margin one square wide around the squares (the detectors' quiet
// zone). Board frame (the object points): metres, z = 0 on the board — for a checkerboard
// checkerboard.h's (origin at the first inner corner), for ChArUco OpenCV's
// (CharucoBoard::chessboardCorners).

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/capture/checkerboard.h"

namespace parallax {

enum class BoardKind { kCheckerboard, kCharuco };

struct CalibrationBoard {
  BoardKind kind = BoardKind::kCheckerboard;
  int squaresX = 10, squaresY = 7;  // squares along a row, down a column
  // 10x7 squares of 20 mm with their margin: 240 x 180 mm, an A4 page in landscape.
  double squareMm = 20.0;
  double markerMm = 15.0;             // ChArUco: the marker's side inside a white square
  std::string dictionary = "4X4_50";  // ChArUco: OpenCV's predefined DICT_<name>

  // Throws InputError naming the field (`prefix` + "squares", "square_mm", "marker_mm",
  // "dictionary"; flags spell them with dashes).
  void validate(const std::string& prefix = "") const;
  CheckerboardBoard checkerboard() const;  // the same squares as checkerboard.h has them
  int cornerCount() const { return (squaresX - 1) * (squaresY - 1); }
  std::string describe() const;  // "ChArUco 10x7 squares of 25 mm, markers 18 mm (DICT_4X4_50)"
};

// "checkerboard" or "charuco"; false otherwise.
bool parseBoardKind(const std::string& text, BoardKind* kind);

struct BoardSheet {
  double widthMm = 0.0, heightMm = 0.0;
  std::vector<cv::Rect2d> black;  // mm, sheet frame; everything else is white
};

BoardSheet boardSheet(const CalibrationBoard& board);

// The sheet as an 8-bit grey picture at `dotsPerMm`, each pixel the exact share of white it
// covers (the rectangles are axis-aligned).
cv::Mat rasterizeSheet(const BoardSheet& sheet, double dotsPerMm);

// One picture's corners: board points and where they are in the picture (pixel centres at
// +0.5, conventions.h), in the same order.
struct BoardView {
  std::vector<Eigen::Vector3d> board;
  std::vector<Eigen::Vector2d> pixels;
};

// The board in an 8-bit grey or colour picture: for a checkerboard every inner corner or
// nothing; for ChArUco the corners its markers identify (subpixel), nothing when fewer than
// `minCorners` (at least 6: a homography and some to spare).
std::optional<BoardView> detectBoard(const cv::Mat& picture8, const CalibrationBoard& board,
                                     int minCorners = 6);

}  // namespace parallax
