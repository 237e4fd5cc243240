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
  static std::mutex mutex;
  static std::map<std::pair<std::string, int>, double> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  const auto key = std::make_pair(text, sizePx);
  if (const auto hit = cache.find(key); hit != cache.end()) return hit->second;
  double width = 0.0;
  const OIIO::ROI box = plotFontFile().empty()
                            ? OIIO::ROI()
                            : OIIO::ImageBufAlgo::text_size(text, sizePx, plotFontFile());
  if (box.defined()) {
    width = std::max(0, box.xend);
  } else {
    long characters = 0;  // UTF-8 code points: count the bytes that start one
    for (unsigned char c : text) characters += (c & 0xC0) != 0x80;
    width = 0.65 * sizePx * static_cast<double>(characters);
  }
  cache.emplace(key, width);
  return width;
}

}  // namespace parallax::report
