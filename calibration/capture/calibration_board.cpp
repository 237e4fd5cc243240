#include "calibration/capture/calibration_board.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "calibration/display/conventions.h"
#include "common/check.h"
#include "common/input_error.h"

namespace parallax {
namespace {

struct NamedDictionary {
  const char* name;
  cv::aruco::PREDEFINED_DICTIONARY_NAME id;
  int size;  // markers
};

constexpr NamedDictionary kDictionaries[] = {
    {"4X4_50", cv::aruco::DICT_4X4_50, 50},    {"4X4_100", cv::aruco::DICT_4X4_100, 100},
    {"4X4_250", cv::aruco::DICT_4X4_250, 250}, {"4X4_1000", cv::aruco::DICT_4X4_1000, 1000},
    {"5X5_50", cv::aruco::DICT_5X5_50, 50},    {"5X5_100", cv::aruco::DICT_5X5_100, 100},
    {"5X5_250", cv::aruco::DICT_5X5_250, 250}, {"5X5_1000", cv::aruco::DICT_5X5_1000, 1000},
    {"6X6_50", cv::aruco::DICT_6X6_50, 50},    {"6X6_100", cv::aruco::DICT_6X6_100, 100},
    {"6X6_250", cv::aruco::DICT_6X6_250, 250}, {"6X6_1000", cv::aruco::DICT_6X6_1000, 1000},
    {"7X7_50", cv::aruco::DICT_7X7_50, 50},    {"7X7_100", cv::aruco::DICT_7X7_100, 100},
    {"7X7_250", cv::aruco::DICT_7X7_250, 250}, {"7X7_1000", cv::aruco::DICT_7X7_1000, 1000},
};

const NamedDictionary* findDictionary(const std::string& name) {
  for (const NamedDictionary& d : kDictionaries)
    if (name == d.name) return &d;
  return nullptr;
}

// The ChArUco board as OpenCV describes it, in metres.
cv::Ptr<cv::aruco::CharucoBoard> charucoOf(const CalibrationBoard& board) {
  const NamedDictionary* named = findDictionary(board.dictionary);
  PARALLAX_CHECK(named != nullptr);
  return cv::aruco::CharucoBoard::create(
      board.squaresX, board.squaresY, static_cast<float>(board.squareMm / 1000.0),
      static_cast<float>(board.markerMm / 1000.0), cv::aruco::getPredefinedDictionary(named->id));
}

}  // namespace

bool parseBoardKind(const std::string& text, BoardKind* kind) {
  if (text == "checkerboard") {
    *kind = BoardKind::kCheckerboard;
    return true;
  }
  if (text == "charuco") {
    *kind = BoardKind::kCharuco;
    return true;
  }
  return false;
}

void CalibrationBoard::validate(const std::string& prefix) const {
  const auto field = [&prefix](std::string key) {
    if (prefix == "--") std::replace(key.begin(), key.end(), '_', '-');
    return prefix + key;
  };
  // A 2x2 board has one corner: no homography. 40 a side is beyond any printable board.
  if (squaresX < 3 || squaresY < 3 || squaresX > 40 || squaresY > 40) {
    throw InputError({"", field("squares"), 0},
                     fmt::format("{}x{}: each side must have 3..40 squares", squaresX, squaresY));
  }
  if (!(std::isfinite(squareMm) && squareMm >= 2.0 && squareMm <= 500.0))
    throw InputError({"", field("square_mm"), 0}, fmt::format("must be 2..500, got {}", squareMm));
  if (kind != BoardKind::kCharuco) return;
  if (!(std::isfinite(markerMm) && markerMm > 0.0 && markerMm < squareMm)) {
    throw InputError(
        {"", field("marker_mm"), 0},
        fmt::format("must be > 0 and smaller than the square ({} mm), got {}", squareMm, markerMm));
  }
  const NamedDictionary* named = findDictionary(dictionary);
  if (named == nullptr) {
    std::string names;
    for (const NamedDictionary& d : kDictionaries)
      names += (names.empty() ? "" : ", ") + std::string(d.name);
    throw InputError(
        {"", field("dictionary"), 0},
        fmt::format("unknown ArUco dictionary \"{}\": give one of {}", dictionary, names));
  }
  const int markers = squaresX * squaresY / 2;
  if (markers > named->size) {
    throw InputError(
        {"", field("dictionary"), 0},
        fmt::format("{} has {} markers, the board needs {}", dictionary, named->size, markers));
  }
}

CheckerboardBoard CalibrationBoard::checkerboard() const {
  CheckerboardBoard b;
  b.innerColumns = squaresX - 1;
  b.innerRows = squaresY - 1;
  b.squareM = squareMm / 1000.0;
  return b;
}

std::string CalibrationBoard::describe() const {
  if (kind == BoardKind::kCheckerboard)
    return fmt::format("checkerboard {}x{} squares of {:g} mm", squaresX, squaresY, squareMm);
  return fmt::format("ChArUco {}x{} squares of {:g} mm, markers {:g} mm (DICT_{})", squaresX,
                     squaresY, squareMm, markerMm, dictionary);
}

BoardSheet boardSheet(const CalibrationBoard& board) {
  board.validate();
  const double s = board.squareMm, margin = board.squareMm;
  BoardSheet sheet;
  sheet.widthMm = board.squaresX * s + 2.0 * margin;
  sheet.heightMm = board.squaresY * s + 2.0 * margin;
  const auto square = [&](int a, int b) {
    return cv::Rect2d(margin + a * s, margin + b * s, s, s);
  };
  if (board.kind == BoardKind::kCheckerboard) {
    // The top-left square black, as checkerboard.h's cell (−1, −1).
    for (int b = 0; b < board.squaresY; ++b)
      for (int a = 0; a < board.squaresX; ++a)
        if ((a + b) % 2 == 0) sheet.black.push_back(square(a, b));
    return sheet;
  }
  // ChArUco from OpenCV's own description, so the sheet is what its detector expects: a
  // marker in every white square, the other squares black. OpenCV's board frame may have y
  // up; the markers' corner order (left-top, right-top, right-bottom, left-bottom as a picture
  // shows them) says which way, and the sheet is drawn as a picture (y down).
  const cv::Ptr<cv::aruco::CharucoBoard> charuco = charucoOf(board);
  const auto& corners = charuco->objPoints;
  PARALLAX_CHECK(!corners.empty());
  const cv::Point3f right = corners[0][1] - corners[0][0], down = corners[0][3] - corners[0][0];
  const bool yUp = right.x * down.y - right.y * down.x < 0.0f;
  const double boardHeightMm = board.squaresY * s;
  const auto sheetOf = [&](const cv::Point3f& p) {
    const double x = 1000.0 * p.x, y = 1000.0 * p.y;
    return cv::Point2d(margin + x, margin + (yUp ? boardHeightMm - y : y));
  };
  std::vector<bool> hasMarker(static_cast<size_t>(board.squaresX * board.squaresY), false);
  const cv::Ptr<cv::aruco::Dictionary>& dictionary = charuco->dictionary;
  const int bitsPerSide = dictionary->markerSize;
  const int cells = bitsPerSide + 2;  // one black border cell on each side
  for (size_t m = 0; m < corners.size(); ++m) {
    const cv::Point2d topLeft = sheetOf(corners[m][0]);
    const cv::Point2d bottomRight = sheetOf(corners[m][2]);
    const double side = bottomRight.x - topLeft.x;
    PARALLAX_CHECK(std::abs(side - board.markerMm) < 1e-3 &&
                   std::abs(bottomRight.y - topLeft.y - board.markerMm) < 1e-3);
    const cv::Point2d centre = 0.5 * (topLeft + bottomRight) - cv::Point2d(margin, margin);
    const int a = static_cast<int>(centre.x / s), b = static_cast<int>(centre.y / s);
    hasMarker[static_cast<size_t>(b * board.squaresX + a)] = true;
    const cv::Mat bits = cv::aruco::Dictionary::getBitsFromByteList(
        dictionary->bytesList.rowRange(charuco->ids[m], charuco->ids[m] + 1), bitsPerSide);
    const double cell = side / cells;
    for (int r = 0; r < cells; ++r) {
      for (int c = 0; c < cells; ++c) {
        const bool border = r == 0 || c == 0 || r == cells - 1 || c == cells - 1;
        if (border || bits.at<uint8_t>(r - 1, c - 1) == 0)
          sheet.black.emplace_back(topLeft.x + c * cell, topLeft.y + r * cell, cell, cell);
      }
    }
  }
  for (int b = 0; b < board.squaresY; ++b)
    for (int a = 0; a < board.squaresX; ++a)
      if (!hasMarker[static_cast<size_t>(b * board.squaresX + a)])
        sheet.black.push_back(square(a, b));
  return sheet;
}

cv::Mat rasterizeSheet(const BoardSheet& sheet, double dotsPerMm) {
  PARALLAX_CHECK(dotsPerMm > 0.0);
  const int w = static_cast<int>(std::ceil(sheet.widthMm * dotsPerMm - 1e-9));
  const int h = static_cast<int>(std::ceil(sheet.heightMm * dotsPerMm - 1e-9));
  cv::Mat white(h, w, CV_64F, cv::Scalar(1.0));
  // The rectangles do not overlap: each takes its exact area from the pixels it covers.
  for (const cv::Rect2d& r : sheet.black) {
    const double x0 = r.x * dotsPerMm, x1 = (r.x + r.width) * dotsPerMm;
    const double y0 = r.y * dotsPerMm, y1 = (r.y + r.height) * dotsPerMm;
    for (int j = std::max(0, static_cast<int>(y0));
         j < std::min(h, static_cast<int>(std::ceil(y1))); ++j) {
      const double cy = std::min(y1, j + 1.0) - std::max(y0, static_cast<double>(j));
      double* row = white.ptr<double>(j);
      for (int i = std::max(0, static_cast<int>(x0));
           i < std::min(w, static_cast<int>(std::ceil(x1))); ++i) {
        const double cx = std::min(x1, i + 1.0) - std::max(x0, static_cast<double>(i));
        row[i] -= cx * cy;
      }
    }
  }
  cv::Mat out;
  white.convertTo(out, CV_8U, 255.0);  // rounds and saturates
  return out;
}

std::optional<BoardView> detectBoard(const cv::Mat& picture8, const CalibrationBoard& board,
                                     int minCorners) {
  cv::Mat grey = picture8;
  if (picture8.channels() == 3) cv::cvtColor(picture8, grey, cv::COLOR_BGR2GRAY);
  BoardView view;
  if (board.kind == BoardKind::kCheckerboard) {
    const CheckerboardBoard checkerboard = board.checkerboard();
    const auto corners = findCheckerboardCorners(grey, checkerboard);
    if (!corners) return std::nullopt;
    view.board = checkerboard.cornerPoints();
    view.pixels = *corners;
    return view;
  }
  const cv::Ptr<cv::aruco::CharucoBoard> charuco = charucoOf(board);
  std::vector<std::vector<cv::Point2f>> markers;
  std::vector<int> ids;
  cv::aruco::detectMarkers(grey, charuco->dictionary, markers, ids);
  if (ids.empty()) return std::nullopt;
  std::vector<cv::Point2f> corners;
  std::vector<int> cornerIds;
  cv::aruco::interpolateCornersCharuco(markers, ids, grey, charuco, corners, cornerIds);
  if (static_cast<int>(corners.size()) < std::max(minCorners, 6)) return std::nullopt;
  for (size_t i = 0; i < corners.size(); ++i) {
    const cv::Point3f& p = charuco->chessboardCorners[static_cast<size_t>(cornerIds[i])];
    view.board.emplace_back(p.x, p.y, p.z);
    view.pixels.push_back(pixelFromOpenCv({corners[i].x, corners[i].y}));
  }
  return view;
}

}  // namespace parallax
