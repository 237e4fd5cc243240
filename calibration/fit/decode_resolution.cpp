#include "calibration/fit/decode_resolution.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <tuple>

namespace parallax {
namespace {

double median(std::vector<double>* values) {
  if (values->empty()) return 0.0;
  const auto mid = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  std::nth_element(values->begin(), mid, values->end());
  return *mid;
}

// Decodes farther apart than this on a row or column are not neighbours: the module's image
// may bend between them.
constexpr double kMostCameraPxApart = 16.0;

}  // namespace

std::vector<StationResolution> decodeResolution(const std::vector<Correspondence>& decoded) {
  // Per (station, module, axis, row or column): the decodes along it, as (camera px, module px).
  // The lens blur's correction moves a camera pixel by under half a pixel, so the floor of the
  // other coordinate still names its row or column.
  std::map<std::tuple<int, int, int, long>, std::vector<std::pair<double, double>>> lines;
  for (const Correspondence& c : decoded) {
    for (int axis = 0; axis < 2; ++axis) {
      const long line = static_cast<long>(std::floor(c.cameraPx[1 - axis]));
      lines[{c.camera, c.module, axis, line}].emplace_back(c.cameraPx[axis], c.modulePx[axis]);
    }
  }
  std::map<int, std::array<std::vector<double>, 2>> ratios;  // per station, per axis
  for (auto& [key, points] : lines) {
    std::sort(points.begin(), points.end());
    for (size_t i = 1; i < points.size(); ++i) {
      const double camera = points[i].first - points[i - 1].first;
      if (!(camera > 0.5 && camera <= kMostCameraPxApart)) continue;
      ratios[std::get<0>(key)][static_cast<size_t>(std::get<2>(key))].push_back(
          std::abs(points[i].second - points[i - 1].second) / camera);
    }
  }
  std::vector<StationResolution> out;
  for (auto& [station, axes] : ratios) {
    StationResolution r;
    r.station = station;
    r.pairs = static_cast<int>(axes[0].size() + axes[1].size());
    r.modulePxACameraPx = std::max(median(&axes[0]), median(&axes[1]));
    out.push_back(r);
  }
  return out;
}

}  // namespace parallax
