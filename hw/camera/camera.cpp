#include "hw/camera/camera.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "hw/link/link_client.h"

namespace parallax::hw {
namespace {

uint16_t centi(double value) {
  return static_cast<uint16_t>(std::clamp(std::lround(value * 100.0), 1l, 65535l));
}

}  // namespace

std::string CameraLockResult::describe() const {
  if (ok) return "camera settings locked";
  std::string list;
  for (const std::string& c : unlocked) list += (list.empty() ? "" : ", ") + c;
  return "camera could not lock: " + list;
}

// ---- SimulatedCamera ----

CameraLockResult SimulatedCamera::lock(const CameraSettings& settings) {
  CameraLockResult result;
  if (settings.exposureUs == 0 || !(settings.gain > 0.0) || !(settings.whiteBalanceRed > 0.0) ||
      !(settings.whiteBalanceBlue > 0.0)) {
    result.unlocked = {"settings must be positive"};
    return result;
  }
  settings_ = settings;
  locked_ = true;
  result.ok = true;
  return result;
}

Image SimulatedCamera::capture(std::string* error) {
  CaptureRequest request;
  if (locked_) {  // every capture repeats the locked values: nothing can drift between them
    request.exposureUs = settings_.exposureUs;
    request.gainCenti = centi(settings_.gain);
    request.whiteBalanceRedCenti = centi(settings_.whiteBalanceRed);
    request.whiteBalanceBlueCenti = centi(settings_.whiteBalanceBlue);
  }
  request.station = static_cast<uint16_t>(std::clamp(station_, 0, 65535));
  if (settings_.colour) request.flags = kCaptureColour;
  Image image = link_.capture(viewModule_, request);
  if (image.empty()) {
    *error = fmt::format(
        "the simulated camera returned no image of module {} from station {} (nothing shown "
        "yet, no such station, or no answer)",
        viewModule_, station_);
  }
  return image;
}

// ---- OpenCvCamera ----

struct OpenCvCamera::State {
  cv::VideoCapture capture;
};

OpenCvCamera::OpenCvCamera() : state_(std::make_unique<State>()) {}
OpenCvCamera::~OpenCvCamera() = default;

bool OpenCvCamera::open(const std::string& source, std::string* error) {
  source_ = source;
  const bool isIndex = !source.empty() && std::all_of(source.begin(), source.end(), ::isdigit);
  bool opened = false;
  try {
    opened = isIndex ? state_->capture.open(std::stoi(source)) : state_->capture.open(source);
  } catch (const cv::Exception& e) {
    *error = fmt::format("cannot open camera \"{}\": {}", source, e.what());
    return false;
  }
  if (!opened) {
    *error = fmt::format("cannot open camera \"{}\" (no such device or file)", source);
    return false;
  }
  return true;
}

CameraLockResult OpenCvCamera::lock(const CameraSettings& settings) {
  CameraLockResult result;
  cv::VideoCapture& c = state_->capture;
  // Each control is set, then read back: a backend may accept a value and ignore it.
  auto pin = [&](int property, double value, const char* name) {
    const bool set = c.set(property, value);
    const double back = c.get(property);
    if (!set || std::abs(back - value) > 1e-3 * std::max(1.0, std::abs(value))) {
      result.unlocked.push_back(name);
    }
  };
  // V4L2 through OpenCV: auto exposure 1 = manual, 3 = aperture priority; exposure in 100 µs.
  pin(cv::CAP_PROP_AUTO_EXPOSURE, 1.0, "auto exposure off");
  pin(cv::CAP_PROP_EXPOSURE, settings.exposureUs / 100.0, "exposure");
  pin(cv::CAP_PROP_GAIN, settings.gain, "gain");
  pin(cv::CAP_PROP_AUTO_WB, 0.0, "auto white balance off");
  result.ok = result.unlocked.empty();
  settings_ = settings;
  locked_ = result.ok;
  return result;
}

void OpenCvCamera::unlock() {
  state_->capture.set(cv::CAP_PROP_AUTO_EXPOSURE, 3.0);
  state_->capture.set(cv::CAP_PROP_AUTO_WB, 1.0);
  locked_ = false;
}

Image OpenCvCamera::capture(std::string* error) {
  cv::Mat frame;
  if (!state_->capture.isOpened() || !state_->capture.read(frame) || frame.empty()) {
    *error = fmt::format("camera \"{}\" gave no frame", source_);
    return {};
  }
  cv::Mat rgb;
  if (frame.channels() == 1) {
    cv::cvtColor(frame, rgb, cv::COLOR_GRAY2RGB);
  } else if (frame.channels() == 4) {
    cv::cvtColor(frame, rgb, cv::COLOR_BGRA2RGB);
  } else {
    cv::cvtColor(frame, rgb, cv::COLOR_BGR2RGB);  // OpenCV delivers BGR
  }
  if (rgb.depth() != CV_8U) rgb.convertTo(rgb, CV_8U);
  Image image;
  image.width = rgb.cols;
  image.height = rgb.rows;
  image.format = PixelFormat::kRgb8;
  image.pixels.resize(image.byteSize());
  for (int y = 0; y < rgb.rows; ++y) {
    std::copy_n(rgb.ptr<uint8_t>(y), static_cast<size_t>(rgb.cols) * 3,
                image.pixels.data() + static_cast<size_t>(y) * rgb.cols * 3);
  }
  return image;
}

}  // namespace parallax::hw
