#include "tracer/observer_view.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "calibration/display_presets.h"
#include "calibration/optical_module.h"
#include "calibration/screen_transfer.h"
#include "common/check.h"
#include "common/input_error.h"

namespace parallax {
namespace {

// Bilinear lookup at continuous pixel position (u, v) (centres at +0.5), clamped to the edge.
Rgb sampleBilinear(const Frame& frame, double u, double v) {
  const double x = std::clamp(u - 0.5, 0.0, frame.width - 1.0);
  const double y = std::clamp(v - 0.5, 0.0, frame.height - 1.0);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, frame.width - 1), y1 = std::min(y0 + 1, frame.height - 1);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  return (1 - fy) * ((1 - fx) * frame.at(x0, y0) + fx * frame.at(x1, y0)) +
         fy * ((1 - fx) * frame.at(x0, y1) + fx * frame.at(x1, y1));
}

Eigen::Vector3d viewPixelOnScreen(const Screen& screen, const ObserverViewOptions& options, int i, int j) {
  const double x = (-0.5 + (i + 0.5) / options.width) * screen.width;
  const double y = (0.5 - (j + 0.5) / options.height) * screen.height;
  return screen.pointAt(x, y);
}

}  // namespace

void ObserverViewOptions::validate() const {
  if (width < 1 || height < 1 || width > 16384 || height > 16384) {
    throw InputError({"", "view resolution", 0}, fmt::format("must be 1..16384 a side, got {}x{}", width, height));
  }
}

Frame synthesizeObserverView(const DisplayModel& model, const std::vector<Frame>& frames,
                             const Eigen::Vector3d& viewer, const ObserverViewOptions& options,
                             std::vector<float>* coverage) {
  options.validate();
  PARALLAX_CHECK_OP(frames.size(), ==, model.modules.size());
  std::vector<ModuleOptics> optics;
  for (size_t i = 0; i < model.modules.size(); ++i) {
    PARALLAX_CHECK_OP(frames[i].width, ==, model.modules[i].width);
    PARALLAX_CHECK_OP(frames[i].height, ==, model.modules[i].height);
    optics.emplace_back(model.modules[i]);
  }
  // Gaussian lobe with FWHM = diffusion width, scaled by the display's mean angular pitch so
  // that a row of modules one pitch apart sums to ~1 (a single module: peak 1). Where modules
  // sit closer or further apart than the mean (a straight row seen at an angle), the screen
  // looks brighter or darker, as a real one does until its brightness is calibrated.
  const double fwhm = model.screen.diffusionDeg * std::numbers::pi / 180.0;
  const double sigma = fwhm / (2.0 * std::sqrt(2.0 * std::numbers::ln2));
  const double pitchDeg = angularPitchDeg(model);
  const double pitch = (pitchDeg > 0.0 ? pitchDeg : model.screen.diffusionDeg) * std::numbers::pi / 180.0;
  const double scale = model.modules.size() > 1 ? pitch / (sigma * std::sqrt(2.0 * std::numbers::pi)) : 1.0;
  const double cutoff = 5.0 * sigma;  // beyond it the lobe is below 4e-6 of its peak

  Frame view(options.width, options.height);
  if (coverage) coverage->assign(view.pixels.size(), 0.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, options.height), [&](const tbb::blocked_range<int>& rows) {
    for (int j = rows.begin(); j != rows.end(); ++j) {
      for (int i = 0; i < options.width; ++i) {
        const Eigen::Vector3d s = viewPixelOnScreen(model.screen, options, i, j);
        const double viewerAngle = std::atan2(viewer.x() - s.x(), viewer.z() - s.z());
        Rgb sum = Rgb::Zero();
        double weights = 0.0;
        for (size_t m = 0; m < optics.size(); ++m) {
          const Eigen::Vector3d d = (s - optics[m].position()).normalized();
          double x;
          if (!transferToObserverLine(model.screen, model.observer, s, d, &x)) continue;
          const double angle = std::atan2(x - s.x(), model.observer.z - s.z()) - viewerAngle;
          if (std::abs(angle) > cutoff) continue;
          Eigen::Vector2d pixel;
          if (!optics[m].project(d, &pixel)) continue;
          const OpticalModule& module = model.modules[m];
          if (pixel.x() < 0.0 || pixel.y() < 0.0 || pixel.x() > module.width || pixel.y() > module.height) continue;
          const double weight = scale * std::exp(-0.5 * angle * angle / (sigma * sigma));
          sum += static_cast<float>(weight) * sampleBilinear(frames[m], pixel.x(), pixel.y());
          weights += weight;
        }
        view.at(i, j) = sum;
        if (coverage) (*coverage)[static_cast<size_t>(j) * static_cast<size_t>(options.width) + static_cast<size_t>(i)] = static_cast<float>(weights);
      }
    }
  });
  return view;
}

RayTextures observerViewRays(const DisplayModel& model, double viewerX, const ObserverViewOptions& options) {
  return observerViewRays(model, model.observer.pointAt(viewerX), options);
}

RayTextures observerViewRays(const DisplayModel& model, const Eigen::Vector3d& viewer,
                             const ObserverViewOptions& options) {
  options.validate();
  // Every ray of a view starts at the viewer, so the compact form's shared o.y, o.z are the
  // viewer's, on the observer line or off it.
  RayFrame frame = rayFrameOf(model);
  frame.observerY = static_cast<float>(viewer.y());
  frame.observerZ = static_cast<float>(viewer.z());
  const double viewerX = viewer.x();
  RayTextures rays(options.width, options.height, frame);
  for (int j = 0; j < options.height; ++j) {
    for (int i = 0; i < options.width; ++i) {
      const Eigen::Vector3d s = viewPixelOnScreen(model.screen, options, i, j);
      rays.rays()[static_cast<size_t>(j) * static_cast<size_t>(options.width) + static_cast<size_t>(i)] = {
          static_cast<float>(viewerX), static_cast<float>(s.x()), static_cast<float>(s.y())};
    }
  }
  return rays;
}

double psnrDb(const Frame& a, const Frame& b, const std::vector<float>* mask) {
  PARALLAX_CHECK_OP(a.width, ==, b.width);
  PARALLAX_CHECK_OP(a.height, ==, b.height);
  if (mask) PARALLAX_CHECK_OP(mask->size(), ==, a.pixels.size());
  const std::vector<std::uint8_t> ea = a.toSrgb8(), eb = b.toSrgb8();
  double sumSquares = 0.0;
  long samples = 0;
  for (size_t i = 0; i < ea.size(); ++i) {
    if (mask && (*mask)[i / 3] < 0.5f) continue;
    const double diff = (static_cast<double>(ea[i]) - static_cast<double>(eb[i])) / 255.0;
    sumSquares += diff * diff;
    ++samples;
  }
  if (sumSquares == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(static_cast<double>(samples) / sumSquares);
}

}  // namespace parallax
