#include "tracer/observer_view.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "calibration/display/conventions.h"
#include "calibration/display/optical_module.h"
#include "calibration/display/screen_transfer.h"
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

Eigen::Vector3d viewPixelOnScreen(const Screen& screen, const ObserverViewOptions& options, int i,
                                  int j) {
  const double x = (-0.5 + (i + 0.5) / options.width) * screen.width;
  const double y = (0.5 - (j + 0.5) / options.height) * screen.height;
  return screen.pointAt(x, y);
}

// Half the angle between the nearest neighbours of row position k that have an exit angle (the
// angle to the one neighbour at an end of the row); 0 when k has none.
double angularShare(const std::vector<double>& exitAngle, size_t k) {
  std::optional<double> before, after;
  for (size_t b = k; b-- > 0;) {
    if (!std::isnan(exitAngle[b])) {
      before = exitAngle[b];
      break;
    }
  }
  for (size_t a = k + 1; a < exitAngle.size(); ++a) {
    if (!std::isnan(exitAngle[a])) {
      after = exitAngle[a];
      break;
    }
  }
  if (before && after) return 0.5 * std::abs(*after - *before);
  if (before) return std::abs(exitAngle[k] - *before);
  if (after) return std::abs(*after - exitAngle[k]);
  return 0.0;
}

}  // namespace

void ObserverViewOptions::validate() const {
  if (width < 1 || height < 1 || width > 16384 || height > 16384) {
    throw InputError({"", "view resolution", 0},
                     fmt::format("must be 1..16384 a side, got {}x{}", width, height));
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
  // Gaussian lobe with FWHM = diffusion width. At each screen point the modules' exit angles
  // sample the lobe, so each module's lobe is weighted by its own share of those angles (half
  // the gap to its neighbours in the row, seen from that point): the sum is then a quadrature
  // of the lobe's integral, ~1 wherever the lobes overlap, whatever the row's spacing — the
  // brightness calibration a real display gets (a straight row is denser in angle toward its
  // ends; uncompensated, the middle of the screen would look darker). Where the diffusion is
  // too narrow for the pitch the sum still dips between modules: the dark gaps stay visible.
  // A single module has no neighbours: its lobe peaks at 1.
  const double fwhm = radians(model.screen.diffusionDeg);
  const double sigma = fwhm / (2.0 * std::sqrt(2.0 * std::numbers::ln2));
  const double lobeIntegral = sigma * std::sqrt(2.0 * std::numbers::pi);
  const double cutoff = 5.0 * sigma;  // beyond it the lobe is below 4e-6 of its peak
  std::vector<size_t> rowOrder(model.modules.size());
  for (size_t m = 0; m < rowOrder.size(); ++m) rowOrder[m] = m;
  std::sort(rowOrder.begin(), rowOrder.end(), [&](size_t a, size_t b) {
    return model.modules[a].position.x() < model.modules[b].position.x();
  });

  Frame view(options.width, options.height);
  if (coverage) coverage->assign(view.pixels.size(), 0.0f);
  tbb::parallel_for(
      tbb::blocked_range<int>(0, options.height), [&](const tbb::blocked_range<int>& rows) {
        std::vector<double> exitAngle;  // per row position, NaN where the transfer has no solution
        for (int j = rows.begin(); j != rows.end(); ++j) {
          for (int i = 0; i < options.width; ++i) {
            const Eigen::Vector3d s = viewPixelOnScreen(model.screen, options, i, j);
            const double viewerAngle = std::atan2(viewer.x() - s.x(), viewer.z() - s.z());
            exitAngle.assign(rowOrder.size(), std::numeric_limits<double>::quiet_NaN());
            for (size_t k = 0; k < rowOrder.size(); ++k) {
              const Eigen::Vector3d d = (s - optics[rowOrder[k]].position()).normalized();
              double x;
              if (transferToObserverLine(model.screen, model.observer, s, d, &x)) {
                exitAngle[k] = std::atan2(x - s.x(), model.observer.z - s.z());
              }
            }
            Rgb sum = Rgb::Zero();
            double weights = 0.0;
            for (size_t k = 0; k < rowOrder.size(); ++k) {
              if (std::isnan(exitAngle[k])) continue;
              const double angle = exitAngle[k] - viewerAngle;
              if (std::abs(angle) > cutoff) continue;
              const size_t m = rowOrder[k];
              Eigen::Vector2d pixel;
              const Eigen::Vector3d d = (s - optics[m].position()).normalized();
              if (!optics[m].project(d, &pixel)) continue;
              const OpticalModule& module = model.modules[m];
              if (pixel.x() < 0.0 || pixel.y() < 0.0 || pixel.x() > module.width ||
                  pixel.y() > module.height)
                continue;
              const double share = angularShare(exitAngle, k);
              const double scale = share > 0.0 ? share / lobeIntegral : 1.0;
              const double weight = scale * std::exp(-0.5 * angle * angle / (sigma * sigma));
              sum += static_cast<float>(weight) * sampleBilinear(frames[m], pixel.x(), pixel.y());
              weights += weight;
            }
            view.at(i, j) = sum;
            if (coverage)
              (*coverage)[static_cast<size_t>(j) * static_cast<size_t>(options.width) +
                          static_cast<size_t>(i)] = static_cast<float>(weights);
          }
        }
      });
  return view;
}

RayTextures observerViewRays(const DisplayModel& model, double viewerX,
                             const ObserverViewOptions& options) {
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
      rays.rays()[static_cast<size_t>(j) * static_cast<size_t>(options.width) +
                  static_cast<size_t>(i)] = {static_cast<float>(viewerX), static_cast<float>(s.x()),
                                             static_cast<float>(s.y())};
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
