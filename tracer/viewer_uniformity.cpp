#include "tracer/viewer_uniformity.h"

#include <algorithm>

#include "calibration/display/colour_difference.h"
#include "tracer/observer_view.h"

namespace parallax {

ViewerUniformity measureViewerUniformity(const DisplayModel& model, const std::vector<Frame>& light,
                                         const Eigen::Vector3d& expected,
                                         const Eigen::Vector3d& white,
                                         const std::vector<double>& viewerXs, int width,
                                         int height) {
  const Eigen::Vector3d expectedLab = labFromLinearSrgb(expected, white);
  ObserverViewOptions view;
  view.width = width;
  view.height = height;
  ViewerUniformity u;
  double lo = 1e300, hi = 0.0, sum = 0.0;
  for (double x : viewerXs) {
    const Eigen::Vector3d viewer(x, model.observer.y, model.observer.z);
    std::vector<float> coverage;
    const Frame seen = synthesizeObserverView(model, light, viewer, view, &coverage);
    for (size_t p = 0; p < seen.pixels.size(); ++p) {
      if (coverage[p] < 0.9f) continue;  // the display's edge, seen through few lobes
      const Eigen::Vector3d colour = seen.pixels[p].cast<double>() / coverage[p];
      const double de = ciede2000(labFromLinearSrgb(colour, white), expectedLab);
      u.meanDeltaE += de;
      u.worstDeltaE = std::max(u.worstDeltaE, de);
      const double y = luminance(colour);
      lo = std::min(lo, y);
      hi = std::max(hi, y);
      sum += y;
      ++u.pixels;
    }
  }
  if (u.pixels > 0) {
    u.meanDeltaE /= u.pixels;
    u.nonUniformity = (hi - lo) / (sum / u.pixels);
  }
  return u;
}

}  // namespace parallax
