#include "calibration/simulation/colour_picture_renderer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace parallax {
namespace {

cv::Vec3f sampleBilinear(const cv::Mat& image, float u, float v) {
  const float x = u - 0.5f, y = v - 0.5f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  auto at = [&](int xx, int yy) {
    return image.at<cv::Vec3f>(std::clamp(yy, 0, image.rows - 1),
                               std::clamp(xx, 0, image.cols - 1));
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
         fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

}  // namespace

cv::Mat renderColourPicture(const StationView& view, const std::vector<cv::Mat>& moduleLight,
                            const CameraRenderOptions& sensor, double exposure,
                            SeededRandom& random) {
  sensor.validate();
  const bool fine = view.supersampling > 1;  // the markers are then added at the camera's scale
  cv::Mat light(view.height, view.width, CV_32FC3);
  tbb::parallel_for(0, view.height, [&](int y) {
    cv::Vec3f* row = light.ptr<cv::Vec3f>(y);
    for (int x = 0; x < view.width; ++x) {
      const float marker = view.markers.empty() || fine ? 0.0f : view.markers.at<float>(y, x);
      const float grey = static_cast<float>(sensor.ambient) + marker;
      cv::Vec3f value(grey, grey, grey);
      for (const LobeContribution& c : view.at(x, y)) {
        if (c.module < 0) break;
        const cv::Mat& image = moduleLight[static_cast<size_t>(c.module)];
        if (image.empty()) continue;
        value += c.weight * sampleBilinear(image, c.u, c.v);
      }
      row[x] = value * static_cast<float>(exposure);
    }
  });
  if (fine)
    light = cameraPixelLight(light, view, sensor.blurSigmaPx);
  else if (sensor.blurSigmaPx > 0.0)
    cv::GaussianBlur(light, light, cv::Size(0, 0), sensor.blurSigmaPx);
  // Response, noise (serial from the seeded stream: deterministic), saturation, 8 bits.
  cv::Mat recorded(light.size(), CV_32FC3);
  for (int y = 0; y < light.rows; ++y) {
    const cv::Vec3f* in = light.ptr<cv::Vec3f>(y);
    cv::Vec3f* out = recorded.ptr<cv::Vec3f>(y);
    for (int x = 0; x < light.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const double v =
            std::pow(std::clamp(static_cast<double>(in[x][c]), 0.0, 1.0), 1.0 / sensor.gamma) +
            random.normal(sensor.noiseSigma);
        out[x][c] = static_cast<float>(std::round(std::clamp(v, 0.0, 1.0) * 255.0) / 255.0);
      }
    }
  }
  return recorded;
}

}  // namespace parallax
