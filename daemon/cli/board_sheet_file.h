#pragma once
// The printable calibration board (`parallax camera board --out board.png|board.pdf`) at true
// scale. PDF: vector rectangles on an A4 (else A3, else fitted) landscape page, a line of text
// naming the board and its square size, and a 100 mm scale bar to check the print with a
// ruler. PNG: the sheet rasterized at `dpi`, the DPI stored in the file (pHYs) and the board
// named in its description, so that an image viewer prints it at size.

#include <string>

#include "calibration/capture/calibration_board.h"

namespace parallax::cli {

// Throws InputError naming the file when it cannot be written, or `--out` when its extension
// is neither .png nor .pdf.
void writeBoardSheet(const CalibrationBoard& board, const std::string& path, double dpi);

}  // namespace parallax::cli
