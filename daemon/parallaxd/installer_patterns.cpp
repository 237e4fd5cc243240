#include "daemon/parallaxd/installer_patterns.h"

#include <algorithm>
#include <array>
#include <string>
#include <utility>

namespace parallax::daemon {
namespace {

// 5×7 digit glyphs, one string per row, '#' lit.
constexpr std::array<std::array<const char*, 7>, 10> kDigits = {{
    {" ### ", "#   #", "#  ##", "# # #", "##  #", "#   #", " ### "},
    {"  #  ", " ##  ", "  #  ", "  #  ", "  #  ", "  #  ", " ### "},
    {" ### ", "#   #", "    #", "   # ", "  #  ", " #   ", "#####"},
    {"#####", "   # ", "  #  ", "   # ", "    #", "#   #", " ### "},
    {"   # ", "  ## ", " # # ", "#  # ", "#####", "   # ", "   # "},
    {"#####", "#    ", "#### ", "    #", "    #", "#   #", " ### "},
    {"  ## ", " #   ", "#    ", "#### ", "#   #", "#   #", " ### "},
    {"#####", "    #", "   # ", "  #  ", " #   ", " #   ", " #   "},
    {" ### ", "#   #", "#   #", " ### ", "#   #", "#   #", " ### "},
    {" ### ", "#   #", "#   #", " ####", "    #", "   # ", " ##  "},
}};

// Module images are seen mirrored from the front: flip them so the viewer sees them upright.
void mirrorColumns(Frame& f) {
  for (int y = 0; y < f.height; ++y) {
    for (int x = 0; x < f.width / 2; ++x) std::swap(f.at(x, y), f.at(f.width - 1 - x, y));
  }
}

void drawNumber(Frame& f, int number, const Rgb& colour) {
  const std::string text = std::to_string(number);
  const int glyphs = static_cast<int>(text.size());
  // Cells of 6×8 (a glyph and its spacing); as large as fits in 80% of either side.
  const int cell = std::max(1, std::min(f.width * 8 / 10 / (6 * glyphs), f.height * 8 / 10 / 8));
  const int textWidth = (6 * glyphs - 1) * cell, textHeight = 7 * cell;
  const int left = (f.width - textWidth) / 2, top = (f.height - textHeight) / 2;
  for (int g = 0; g < glyphs; ++g) {
    const auto& glyph = kDigits[static_cast<size_t>(text[static_cast<size_t>(g)] - '0')];
    for (int y = 0; y < 7 * cell; ++y) {
      for (int x = 0; x < 5 * cell; ++x) {
        if (glyph[static_cast<size_t>(y / cell)][x / cell] != '#') continue;
        const int px = left + g * 6 * cell + x, py = top + y;
        if (px >= 0 && px < f.width && py >= 0 && py < f.height) f.at(px, py) = colour;
      }
    }
  }
}

}  // namespace

Frame identifyFrame(int width, int height, int moduleIndex, bool mirrored) {
  Frame f(width, height);
  const int border = std::max(1, std::min(width, height) / 50);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool edge = x < border || y < border || x >= width - border || y >= height - border;
      if (edge) f.at(x, y) = Rgb(0.8f, 0.8f, 0.0f);
    }
  }
  drawNumber(f, moduleIndex, Rgb(1.0f, 1.0f, 1.0f));
  if (mirrored) mirrorColumns(f);
  return f;
}

Frame testCardFrame(int width, int height, int moduleIndex, bool mirrored) {
  Frame f(width, height);
  // Colour bars: white, yellow, cyan, green, magenta, red, blue, black (75% SMPTE order).
  const std::array<Rgb, 8> bars = {Rgb(0.75f, 0.75f, 0.75f), Rgb(0.75f, 0.75f, 0.0f),
                                   Rgb(0.0f, 0.75f, 0.75f),  Rgb(0.0f, 0.75f, 0.0f),
                                   Rgb(0.75f, 0.0f, 0.75f),  Rgb(0.75f, 0.0f, 0.0f),
                                   Rgb(0.0f, 0.0f, 0.75f),   Rgb(0.0f, 0.0f, 0.0f)};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) f.at(x, y) = bars[static_cast<size_t>(x * 8 / width)];
  }
  // Crosshatch: 16 cells across, square cells, lines one pixel (or 1/256 of the width) wide.
  const int pitch = std::max(2, width / 16);
  const int line = std::max(1, width / 256);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if ((x % pitch) < line || (y % pitch) < line || x >= width - line || y >= height - line) {
        f.at(x, y) = Rgb(1.0f, 1.0f, 1.0f);
      }
    }
  }
  // The module's number in a corner, small, so a photo of the card says which module it was.
  Frame label(std::max(8, width / 6), std::max(8, height / 6));
  drawNumber(label, moduleIndex, Rgb(1.0f, 1.0f, 1.0f));
  for (int y = 0; y < label.height && y + line < height; ++y) {
    for (int x = 0; x < label.width && x + line < width; ++x) {
      if (label.at(x, y).maxCoeff() > 0.0f) f.at(x + line * 2, y + line * 2) = label.at(x, y);
    }
  }
  if (mirrored) mirrorColumns(f);
  return f;
}

}  // namespace parallax::daemon
