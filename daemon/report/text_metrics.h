#pragma once
// How wide a line of the report's plot text is, measured with the font the plots name first
// (DejaVu Sans, fonts-dejavu-core) through OpenImageIO's FreeType text layout: the plots place
// legends and labels from these widths, and the PNG twins (rsvg-convert) draw with that font.

#include <string>

namespace parallax::report {

// The font file the widths come from; "" when it is not installed.
const std::string& plotFontFile();
// The width in px of `text` at `sizePx` (its ink, from the pen's start). Without the font, a
// conservative estimate (0.65 em a character) so layouts still fit.
double textWidth(const std::string& text, int sizePx);

}  // namespace parallax::report
