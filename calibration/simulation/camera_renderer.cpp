#include "calibration/simulation/camera_renderer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/conventions.h"
#include "calibration/simulation/synthetic_observations.h"
#include "common/input_error.h"

namespace parallax {
namespace {

// Bilinear sample of a CV_32F image at a continuous pixel position (centres at +0.5); zero
// outside the image (no light beyond the module's frame).
float sampleBilinear(const cv::Mat& image, float u, float v) {
  const float x = u - 0.5f, y = v - 0.5f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  auto at = [&](int xx, int yy) {
    xx = std::clamp(xx, 0, image.cols - 1);
    yy = std::clamp(yy, 0, image.rows - 1);
    return image.at<float>(yy, xx);
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
         fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

// The markers: each a disc of radius r on the screen frame, facing the observer line, drawn
// with 4×4 supersampling (its centroid is then the projected centre to well under 0.1 px).
cv::Mat renderMarkers(const Screen& screen, const CameraIntrinsics& intrinsics,
                      const CameraPose& pose, const CameraRenderOptions& options) {
  cv::Mat markers(intrinsics.height, intrinsics.width, CV_32F, cv::Scalar(0));
  if (options.fiducialRadiusM <= 0.0) return markers;
  const double r = options.fiducialRadiusM;
  for (const Eigen::Vector2d& f : screenFiducials(screen)) {
    const Eigen::Vector3d centre = screen.pointAt(f.x(), f.y());
    Eigen::Vector2d c, edgeX, edgeY;
    if (!projectPhysical(intrinsics, pose, centre, &c) ||
        !projectPhysical(intrinsics, pose, centre + Eigen::Vector3d(r, 0, 0), &edgeX) ||
        !projectPhysical(intrinsics, pose, centre + Eigen::Vector3d(0, r, 0), &edgeY)) {
      continue;
    }
    // The disc's image is (nearly) an ellipse with these semi-axes.
    const double ax = std::max((edgeX - c).norm(), 0.5), ay = std::max((edgeY - c).norm(), 0.5);
    const int x0 = std::max(0, static_cast<int>(std::floor(c.x() - ax - 1)));
    const int x1 = std::min(intrinsics.width - 1, static_cast<int>(std::ceil(c.x() + ax + 1)));
    const int y0 = std::max(0, static_cast<int>(std::floor(c.y() - ay - 1)));
    const int y1 = std::min(intrinsics.height - 1, static_cast<int>(std::ceil(c.y() + ay + 1)));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        int inside = 0;
        for (int sy = 0; sy < 4; ++sy) {
          for (int sx = 0; sx < 4; ++sx) {
            const double dx = (x + (sx + 0.5) / 4.0 - c.x()) / ax,
                         dy = (y + (sy + 0.5) / 4.0 - c.y()) / ay;
            inside += dx * dx + dy * dy <= 1.0 ? 1 : 0;
          }
        }
        markers.at<float>(y, x) += static_cast<float>(options.fiducialBrightness * inside / 16.0);
      }
    }
  }
  return markers;
}

}  // namespace

void CameraRenderOptions::validate() const {
  auto check = [](bool ok, const char* field, const char* why) {
    if (!ok) throw InputError({"", field, 0}, why);
  };
  check(ambient >= 0.0 && ambient < 1.0, "ambient", "must be 0..1");
  check(gamma >= 0.2 && gamma <= 5.0, "gamma", "must be 0.2..5");
  check(noiseSigma >= 0.0 && noiseSigma < 0.5, "noise_sigma", "must be 0..0.5");
  check(blurSigmaPx >= 0.0 && blurSigmaPx < 20.0, "blur_sigma_px", "must be 0..20");
  check(minLobeWeight > 0.0 && minLobeWeight < 0.5, "min_lobe_weight", "must be in (0, 0.5)");
  check(fiducialRadiusM >= 0.0 && fiducialRadiusM < 0.1, "fiducial_radius_m", "must be 0..0.1");
  check(fiducialBrightness >= 0.0 && fiducialBrightness <= 1.0, "fiducial_brightness",
        "must be 0..1");
}

int supersamplingFor(const DisplayModel& truth, const CameraIntrinsics& intrinsics,
                     const CameraPose& pose) {
  constexpr int kMostSupersampling = 7;
  constexpr double kModulePxARenderPx = 2.0;
  const Eigen::Vector3d centre = truth.screen.pointAt(0.0, 0.0);
  double modulePxACameraPx = 0.0;
  for (const Eigen::Vector3d& beside :
       {truth.screen.pointAt(0.01, 0.0), truth.screen.pointAt(0.0, 0.01)}) {
    Eigen::Vector2d c0, c1;
    if (!projectPhysical(intrinsics, pose, centre, &c0) ||
        !projectPhysical(intrinsics, pose, beside, &c1))
      continue;
    const double cameraPx = (c1 - c0).norm();
    if (!(cameraPx > 0.0)) continue;
    for (const OpticalModule& m : truth.modules) {
      const ModuleOptics optics(m);
      Eigen::Vector2d u0, u1;
      if (optics.project(centre - m.position, &u0) && optics.project(beside - m.position, &u1))
        modulePxACameraPx = std::max(modulePxACameraPx, (u1 - u0).norm() / cameraPx);
    }
  }
  const int needed = static_cast<int>(std::ceil(modulePxACameraPx / kModulePxARenderPx));
  return std::clamp(needed | 1, 1, kMostSupersampling);
}

StationView viewFromStation(const DisplayModel& truth, const CameraIntrinsics& intrinsics,
                            const CameraPose& pose, const CameraRenderOptions& options) {
  options.validate();
  StationView view;
  const int s = supersamplingFor(truth, intrinsics, pose);
  view.supersampling = s;
  view.width = intrinsics.width * s;
  view.height = intrinsics.height * s;
  std::vector<ModuleOptics> optics;
  for (const OpticalModule& m : truth.modules) optics.emplace_back(m);
  // FWHM = diffusion width ⇒ σ = FWHM / (2 √(2 ln 2)).
  const double sigma = diffusionSigma(truth.screen.diffusionDeg);
  const auto camera = packCamera(pose);
  // Rows in parallel, each into its own list; joined in row order below.
  std::vector<std::vector<LobeContribution>> rowContributions(static_cast<size_t>(view.height));
  std::vector<std::vector<uint32_t>> rowCounts(static_cast<size_t>(view.height));
  tbb::parallel_for(0, view.height, [&](int y) {
    auto& out = rowContributions[static_cast<size_t>(y)];
    auto& counts = rowCounts[static_cast<size_t>(y)];
    counts.assign(static_cast<size_t>(view.width), 0);
    for (int x = 0; x < view.width; ++x) {
      const Eigen::Vector2d n = intrinsics.normalized({(x + 0.5) / s, (y + 0.5) / s});
      Vec3<double> p;
      if (!screenPointOfCameraRay(truth.screen.curvature, camera.data(), n.x(), n.y(), &p))
        continue;
      if (!truth.screen.contains(p.x(), p.y())) continue;
      const size_t begin = out.size();
      for (size_t m = 0; m < truth.modules.size(); ++m) {
        const double angle = stripeAngle(truth.screen, p, truth.modules[m].position, pose.centre);
        const double weight = std::exp(-0.5 * (angle / sigma) * (angle / sigma));
        if (!(weight >= options.minLobeWeight)) continue;
        Eigen::Vector2d uv;
        if (!optics[m].project(p - truth.modules[m].position, &uv)) continue;
        const OpticalModule& mod = truth.modules[m];
        if (uv.x() < 0.0 || uv.y() < 0.0 || uv.x() > mod.width || uv.y() > mod.height) continue;
        out.push_back({static_cast<int>(m), static_cast<float>(uv.x()), static_cast<float>(uv.y()),
                       static_cast<float>(weight)});
      }
      std::sort(
          out.begin() + static_cast<std::ptrdiff_t>(begin), out.end(),
          [](const LobeContribution& a, const LobeContribution& b) { return a.weight > b.weight; });
      counts[static_cast<size_t>(x)] = static_cast<uint32_t>(out.size() - begin);
    }
  });
  view.first.reserve(static_cast<size_t>(view.width) * static_cast<size_t>(view.height) + 1);
  view.first.push_back(0);
  for (int y = 0; y < view.height; ++y) {
    for (uint32_t count : rowCounts[static_cast<size_t>(y)])
      view.first.push_back(view.first.back() + count);
    const auto& row = rowContributions[static_cast<size_t>(y)];
    view.contributions.insert(view.contributions.end(), row.begin(), row.end());
  }
  view.markers = renderMarkers(truth.screen, intrinsics, pose, options);
  return view;
}

cv::Mat renderFrame(const StationView& view, const std::vector<cv::Mat>& moduleImages,
                    const CameraRenderOptions& options, SeededRandom& random) {
  cv::Mat linear(view.height, view.width, CV_32F);
  tbb::parallel_for(0, view.height, [&](int y) {
    float* row = linear.ptr<float>(y);
    for (int x = 0; x < view.width; ++x) {
      float value = static_cast<float>(options.ambient);
      for (const LobeContribution& c : view.at(x, y)) {
        const cv::Mat& image = moduleImages[static_cast<size_t>(c.module)];
        if (image.empty()) continue;
        value += c.weight * sampleBilinear(image, c.u, c.v);
      }
      row[x] = value;
    }
  });
  if (view.supersampling > 1)
    return sensorResponse(cameraPixelLight(linear, view, options.blurSigmaPx), options, random);
  if (!view.markers.empty()) linear += view.markers;
  return recordThroughSensor(linear, options, random);
}

cv::Mat cameraPixelLight(const cv::Mat& renderLight, const StationView& view, double blurSigmaPx) {
  const int s = view.supersampling;
  // Into new buffers: the caller's light and the view's markers stay as they were (the view
  // renders every frame of its station).
  cv::Mat blurred;
  if (blurSigmaPx > 0.0)
    cv::GaussianBlur(renderLight, blurred, cv::Size(0, 0), blurSigmaPx * s);
  else
    blurred = renderLight;
  const int width = view.width / s, height = view.height / s;
  cv::Mat light(height, width, renderLight.type());
  const size_t bytes = renderLight.elemSize();
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x)
      std::memcpy(light.ptr(y, x), blurred.ptr(y * s + s / 2, x * s + s / 2), bytes);
  }
  if (!view.markers.empty()) {
    cv::Mat markers;
    if (blurSigmaPx > 0.0)
      cv::GaussianBlur(view.markers, markers, cv::Size(0, 0), blurSigmaPx);
    else
      markers = view.markers.clone();
    if (light.channels() == 3) cv::cvtColor(markers, markers, cv::COLOR_GRAY2BGR);
    light += markers;
  }
  return light;
}

cv::Mat recordThroughSensor(const cv::Mat& light, const CameraRenderOptions& options,
                            SeededRandom& random) {
  cv::Mat linear = light;
  if (options.blurSigmaPx > 0.0) {
    linear = cv::Mat();  // a new buffer: the caller's light stays as it was
    cv::GaussianBlur(light, linear, cv::Size(0, 0), options.blurSigmaPx);
  }
  return sensorResponse(linear, options, random);
}

cv::Mat sensorResponse(const cv::Mat& linear, const CameraRenderOptions& options,
                       SeededRandom& random) {
  // Response curve, then noise (drawn serially from the seeded stream: deterministic).
  cv::Mat recorded(linear.rows, linear.cols, CV_32F);
  for (int y = 0; y < linear.rows; ++y) {
    const float* in = linear.ptr<float>(y);
    float* out = recorded.ptr<float>(y);
    for (int x = 0; x < linear.cols; ++x) {
      const double v =
          std::pow(std::clamp(static_cast<double>(in[x]), 0.0, 1.0), 1.0 / options.gamma) +
          random.normal(options.noiseSigma);
      out[x] = static_cast<float>(std::clamp(v, 0.0, 1.0));
    }
  }
  return recorded;
}

cv::Mat linearFromRecorded(const cv::Mat& recorded, double gamma) {
  cv::Mat linear(recorded.size(), CV_32F);
  for (int y = 0; y < recorded.rows; ++y) {
    const float* in = recorded.ptr<float>(y);
    float* out = linear.ptr<float>(y);
    for (int x = 0; x < recorded.cols; ++x)
      out[x] = static_cast<float>(std::pow(std::max(in[x], 0.0f), gamma));
  }
  return linear;
}

}  // namespace parallax
