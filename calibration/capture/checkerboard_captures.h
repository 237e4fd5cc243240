#pragma once
// The calibration camera's checkerboard pictures in a captures folder (beside the screen
// pictures, calibration_captures.h), from which `parallax calibrate` learns the camera's
// intrinsics — a real installation calibrates its camera from its own pictures:
//
//   checkerboard.json  {"format": "parallax-checkerboard", "version": 1,
//                       "inner_corners": [columns, rows], "square_m": side of a square (m),
//                       "pictures": ["checkerboard/board_00.png", ...]}   (inside the folder)
//   checkerboard/board_NN.png   8-bit grey, the camera's size (camera.json intrinsics.width/height)

#include <string>
#include <vector>

#include "calibration/capture/checkerboard.h"
#include "calibration/capture/checkerboard_calibration.h"

namespace parallax {

struct CheckerboardCaptures {
  CheckerboardBoard board;
  std::vector<CheckerboardPicture> pictures;  // names are paths inside the captures folder
};

constexpr const char* kCheckerboardFileName = "checkerboard.json";

bool hasCheckerboardCaptures(const std::string& directory);

// Writes the pictures as DIR/checkerboard/board_NN.png (in order; their names are not used)
// and DIR/checkerboard.json (atomically).
void saveCheckerboardCaptures(const CheckerboardCaptures& captures, const std::string& directory);

// Reads checkerboard.json and every picture it lists; each must be readable, 8-bit and
// width × height. Errors name the file (and the field of checkerboard.json). The pictures'
// names become DIR/NAME, as reports and later errors name them.
CheckerboardCaptures loadCheckerboardCaptures(const std::string& directory, int width, int height);

}  // namespace parallax
