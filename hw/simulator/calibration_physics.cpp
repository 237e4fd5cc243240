#include "hw/simulator/calibration_physics.h"

#include <fmt/format.h>

#include "common/input_error.h"

namespace parallax::hw {

CalibrationPhysics::CalibrationPhysics(DisplayModel truth, CameraTruth camera)
    : truth_(std::move(truth)), camera_(std::move(camera)), random_(camera_.seed) {
  truth_.validate();
  camera_.sensor.validate();
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

Image CalibrationPhysics::render(std::span<const Image* const> frames, int /*viewModule*/,
                                 int station, const CameraSettings& /*settings*/) const {
  std::lock_guard lock(mutex_);
  if (station < 0 || station >= static_cast<int>(camera_.poses.size())) return {};
  std::vector<cv::Mat> images(truth_.modules.size());
  for (size_t m = 0; m < images.size() && m < frames.size(); ++m) {
    const Image* f = frames[m];
    if (!f || f->empty()) continue;
    const OpticalModule& module = truth_.modules[m];
    if (f->width != module.width || f->height != module.height)
      continue;  // not a frame this module can show
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
  const cv::Mat recorded = renderFrame(view(station), images, camera_.sensor, random_);
  Image image;
  image.width = recorded.cols;
  image.height = recorded.rows;
  image.format = PixelFormat::kGray8;
  image.pixels.resize(image.byteSize());
  for (int y = 0; y < recorded.rows; ++y) {
    const float* in = recorded.ptr<float>(y);
    for (int x = 0; x < recorded.cols; ++x) {
      image.pixels[static_cast<size_t>(y) * static_cast<size_t>(image.width) +
                   static_cast<size_t>(x)] =
          static_cast<uint8_t>(std::lround(255.0f * std::clamp(in[x], 0.0f, 1.0f)));
    }
  }
  return image;
}

}  // namespace parallax::hw
