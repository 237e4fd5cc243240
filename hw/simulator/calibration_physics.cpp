#include "hw/simulator/calibration_physics.h"

#include <fmt/format.h>

#include <opencv2/core.hpp>

#include "calibration/simulation/colour_picture_renderer.h"
#include "common/input_error.h"
#include "hw/camera/image_from_mat.h"

namespace parallax::hw {

CalibrationPhysics::CalibrationPhysics(DisplayModel truth, CameraTruth camera,
                                       std::optional<PhotometricTruth> photometry)
    : truth_(std::move(truth)),
      camera_(std::move(camera)),
      photometry_(std::move(photometry)),
      random_(camera_.seed) {
  truth_.validate();
  camera_.sensor.validate();
  if (photometry_ && photometry_->modules.size() != truth_.modules.size()) {
    throw InputError({"", "photometric truth", 0},
                     fmt::format("has {} modules, the display {}", photometry_->modules.size(),
                                 truth_.modules.size()));
  }
  views_.resize(camera_.poses.size());
}

const StationView& CalibrationPhysics::view(int station) const {
  auto& slot = views_[static_cast<size_t>(station)];
  if (!slot) {
    slot = std::make_unique<StationView>(viewFromStation(
        truth_, camera_.intrinsics, camera_.poses[static_cast<size_t>(station)], camera_.sensor));
  }
  return *slot;
}

cv::Mat CalibrationPhysics::moduleLight(int m, const Image& frame) const {
  const int bpp = bytesPerPixel(frame.format);
  const size_t pixels = static_cast<size_t>(frame.width) * static_cast<size_t>(frame.height);
  std::vector<std::uint8_t> rgb(pixels * 3);
  for (size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c)
      rgb[3 * i + static_cast<size_t>(c)] =
          frame.pixels[i * static_cast<size_t>(bpp) + static_cast<size_t>(std::min(c, bpp - 1))];
  if (photometry_) return photometry_->emittedLight(m, frame.width, frame.height, rgb.data());
  cv::Mat light(frame.height, frame.width, CV_32FC3);
  auto* out = light.ptr<cv::Vec3f>(0);
  for (size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) out[i][c] = rgb[3 * i + static_cast<size_t>(c)] / 255.0f;
  return light;
}

Image CalibrationPhysics::render(std::span<const Image* const> frames, int /*viewModule*/,
                                 int station, const CameraSettings& settings) const {
  std::lock_guard lock(mutex_);
  if (station < 0 || station >= static_cast<int>(camera_.poses.size())) return {};
  std::vector<cv::Mat> images(truth_.modules.size());
  for (size_t m = 0; m < images.size() && m < frames.size(); ++m) {
    const Image* f = frames[m];
    if (!f || f->empty()) continue;
    const OpticalModule& module = truth_.modules[m];
    if (f->width != module.width || f->height != module.height)
      continue;  // not a frame this module can show
    if (photometry_ || settings.colour) {
      images[m] = moduleLight(static_cast<int>(m), *f);
      continue;
    }
    const int bpp = bytesPerPixel(f->format);
    cv::Mat linear(f->height, f->width, CV_32F);
    for (int y = 0; y < f->height; ++y) {
      const uint8_t* in = f->pixels.data() + static_cast<size_t>(y) *
                                                 static_cast<size_t>(f->width) *
                                                 static_cast<size_t>(bpp);
      float* out = linear.ptr<float>(y);
      for (int x = 0; x < f->width; ++x) {
        // Grey: the value; colour: the mean of the channels.
        int sum = 0;
        for (int c = 0; c < bpp; ++c) sum += in[x * bpp + c];
        out[x] = static_cast<float>(sum) / (255.0f * static_cast<float>(bpp));
      }
    }
    images[m] = linear;
  }
  // The exposure scales the light only where the modules' light is physical (10 ms = 1).
  const double exposure = photometry_ ? settings.exposureUs / 10000.0 : 1.0;
  if (settings.colour) {
    return imageFromMat(
        renderColourPicture(view(station), images, camera_.sensor, exposure, random_));
  }
  if (photometry_) {
    // A grey camera sees the light's luminance.
    for (cv::Mat& light : images) {
      if (light.empty()) continue;
      cv::Mat grey;
      cv::transform(light, grey, cv::Matx13f(0.2126f, 0.7152f, 0.0722f));
      light = grey * exposure;
    }
  }
  return imageFromMat(renderFrame(view(station), images, camera_.sensor, random_));
}

}  // namespace parallax::hw
