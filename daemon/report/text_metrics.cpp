#include "daemon/report/text_metrics.h"

#include <OpenImageIO/imagebufalgo.h>

#include <filesystem>
#include <map>
#include <mutex>

namespace parallax::report {

const std::string& plotFontFile() {
  static const std::string file = [] {
    const char* kCandidates[] = {"/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
                                 "/usr/share/fonts/dejavu/DejaVuSans.ttf"};
    for (const char* path : kCandidates)
      if (std::filesystem::is_regular_file(path)) return std::string(path);
    return std::string();
  }();
  return file;
}

double textWidth(const std::string& text, int sizePx) {
  // FreeType hints glyphs at small sizes, rounding every advance to whole pixels, while librsvg
  // (Pango) lays text out unhinted: at 10 px a 150-character caption measured 740 px and drew
  // 753, past its canvas. Measured once at a size where hinting no longer matters, the width
  // scales with the size as Pango's does.
  constexpr int kReferencePx = 200;
  static std::mutex mutex;
  static std::map<std::string, double> cache;  // width at kReferencePx
  double reference = 0.0;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (const auto hit = cache.find(text); hit != cache.end()) {
      reference = hit->second;
    } else {
      const OIIO::ROI box = plotFontFile().empty()
                                ? OIIO::ROI()
                                : OIIO::ImageBufAlgo::text_size(text, kReferencePx, plotFontFile());
      if (box.defined()) {
        reference = std::max(0, box.xend);
      } else {
        long characters = 0;  // UTF-8 code points: count the bytes that start one
        for (unsigned char c : text) characters += (c & 0xC0) != 0x80;
        reference = 0.65 * kReferencePx * static_cast<double>(characters);
      }
      cache.emplace(text, reference);
    }
  }
  return reference * sizePx / kReferencePx;
}

}  // namespace parallax::report
