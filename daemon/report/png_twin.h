#pragma once
// The PNG twin of a report plot: the SVG rendered by rsvg-convert (Debian's librsvg2-bin, the
// renderer GNOME uses), at the SVG's own size. Rendering the SVG itself, rather than drawing the
// plot a second time, keeps the two pictures the same; librsvg draws text with the font the
// layout was measured with (text_metrics.h).

#include <string>

namespace parallax::report {

// Writes `png` from `svg`. Returns "" on success, else why not (rsvg-convert missing or failed),
// for the report to say once.
std::string writePngTwin(const std::string& svg, const std::string& png);

}  // namespace parallax::report
