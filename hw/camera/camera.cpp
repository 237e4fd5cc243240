#include "hw/camera/camera.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>

#include "hw/camera/image_from_mat.h"
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

namespace {

// OpenCV's own warnings (a GStreamer element missing, a property a backend does not handle)
// would print several lines per call; our one-line reasons say what they mean.
class QuietOpenCv {
 public:
  QuietOpenCv() : previous_(cv::utils::logging::getLogLevel()) {
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  }
  ~QuietOpenCv() { cv::utils::logging::setLogLevel(previous_); }

 private:
  cv::utils::logging::LogLevel previous_;
};

// GLib's warnings from inside OpenCV's GStreamer backend ("GStreamer-CRITICAL **: ...", a
// blank line before each) go to stderr through g_log, where QuietOpenCv cannot reach: a
// pipeline that does not parse would print a dozen lines around our one. They are held while
// the pipeline opens; if it fails, GLib's lines are dropped (ours says what they mean, and
// gst-launch-1.0 shows GStreamer's own words) and anything else written meanwhile (another
// thread's log) is passed on; if it opens, everything is passed on.
class HeldStderr {
 public:
  HeldStderr() {
    std::fflush(stderr);
    file_ = std::tmpfile();
    saved_ = file_ ? ::dup(STDERR_FILENO) : -1;
    if (saved_ >= 0) ::dup2(::fileno(file_), STDERR_FILENO);
  }
  ~HeldStderr() { release(true); }
  HeldStderr(const HeldStderr&) = delete;
  HeldStderr& operator=(const HeldStderr&) = delete;

  void release(bool all) {
    if (saved_ < 0) return;
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
    saved_ = -1;
    std::rewind(file_);
    char line[4096];
    while (std::fgets(line, sizeof line, file_) != nullptr) {
      const bool glib =
          line[0] == '\n' || (line[0] == '(' && std::strstr(line, " **: ") != nullptr);
      if (all || !glib) std::fputs(line, stderr);
    }
    std::fclose(file_);
    file_ = nullptr;
  }

 private:
  std::FILE* file_ = nullptr;
  int saved_ = -1;
};

bool allDigits(const std::string& s) {
  return !s.empty() && s.size() < 6 && std::all_of(s.begin(), s.end(), ::isdigit);
}

}  // namespace

bool OpenCvCamera::open(const std::string& source, std::string* error) {
  source_ = source;
  const std::string named = "opencv:" + source;
  const QuietOpenCv quiet;
  const bool pipeline = source.find('!') != std::string::npos;
  bool opened = false;
  try {
    if (allDigits(source)) {
      opened = state_->capture.open(std::stoi(source), cv::CAP_V4L2);
      if (!opened) {
        *error = fmt::format("{}: no V4L2 camera with index {} (/dev/video{} does not open)", named,
                             source, source);
        return false;
      }
    } else if (source.rfind("/dev/", 0) == 0) {
      std::error_code ec;
      if (!std::filesystem::exists(source, ec)) {
        *error = fmt::format("{}: no such device", named);
        return false;
      }
      opened = state_->capture.open(source, cv::CAP_V4L2);
      if (!opened) {
        *error = fmt::format("{}: the device exists but is not a V4L2 capture device (or is busy)",
                             named);
        return false;
      }
    } else if (source == "gphoto2" || source.rfind("gphoto2:", 0) == 0) {
      const std::string index = source.size() > 8 ? source.substr(8) : "0";
      if (!allDigits(index)) {
        *error = fmt::format("{}: gphoto2 takes a camera index (gphoto2:0)", named);
        return false;
      }
      opened = state_->capture.open(std::stoi(index), cv::CAP_GPHOTO2);
      if (!opened) {
        *error = fmt::format("{}: no tethered camera {} through gPhoto2", named, index);
        return false;
      }
    } else if (pipeline) {
      if (!cv::videoio_registry::hasBackend(cv::CAP_GSTREAMER)) {
        *error = fmt::format("{}: this OpenCV has no GStreamer backend", named);
        return false;
      }
      HeldStderr held;
      opened = state_->capture.open(source, cv::CAP_GSTREAMER);
      held.release(opened);
      if (!opened) {
        *error = fmt::format(
            "{}: GStreamer could not start the pipeline (an element that does not exist or "
            "does not link, a syntax error, a source that fails, or no appsink at its end; "
            "try it with gst-launch-1.0)",
            named);
        return false;
      }
    } else {
      opened = state_->capture.open(source);
      if (!opened) {
        *error = fmt::format("{}: cannot open camera \"{}\" (no such device, file or stream)",
                             named, source);
        return false;
      }
    }
  } catch (const cv::Exception& e) {
    *error = fmt::format("{}: cannot open camera: {}", named, e.what());
    return false;
  }
  return true;
}

CameraLockResult OpenCvCamera::lock(const CameraSettings& settings) {
  CameraLockResult result;
  cv::VideoCapture& c = state_->capture;
  const QuietOpenCv quiet;
  // Each control is set, then read back: a backend may accept a value and ignore it.
  auto pin = [&](int property, double value, const char* name) {
    const bool set = c.set(property, value);
    const double back = c.get(property);
    if (!set || std::abs(back - value) > 1e-3 * std::max(1.0, std::abs(value))) {
      result.unlocked.push_back(
          set ? fmt::format("{} (set {:g}, reads back {:g})", name, value, back)
              : fmt::format("{} (the backend refuses the property)", name));
    }
  };
  // V4L2 through OpenCV: auto exposure 1 = manual, 3 = aperture priority; exposure in 100 µs.
  pin(cv::CAP_PROP_AUTO_EXPOSURE, 1.0, "auto exposure off");
  pin(cv::CAP_PROP_EXPOSURE, settings.exposureUs / 100.0, "exposure");
  pin(cv::CAP_PROP_GAIN, settings.gain, "gain");
  pin(cv::CAP_PROP_AUTO_WB, 0.0, "auto white balance off");
  // White balance and focus have no value of ours: each is held where the camera has it once
  // its automatic control is off (the operator focuses first), then read back like the rest.
  // A backend without the property reads back 0 or -1 and refuses the set.
  const auto hold = [&](int property, const char* name) {
    const double now = c.get(property);
    if (c.set(property, now) && std::abs(c.get(property) - now) <= 1e-3 * std::max(1.0, now) &&
        now >= 0.0) {
      return;
    }
    result.unlocked.push_back(fmt::format("{} (the backend refuses the property)", name));
  };
  hold(cv::CAP_PROP_WB_TEMPERATURE, "white balance temperature");
  pin(cv::CAP_PROP_AUTOFOCUS, 0.0, "autofocus off");
  hold(cv::CAP_PROP_FOCUS, "focus");
  result.ok = result.unlocked.empty();
  settings_ = settings;
  locked_ = result.ok;
  return result;
}

void OpenCvCamera::unlock() {
  const QuietOpenCv quiet;
  state_->capture.set(cv::CAP_PROP_AUTO_EXPOSURE, 3.0);
  state_->capture.set(cv::CAP_PROP_AUTO_WB, 1.0);
  locked_ = false;
}

Image OpenCvCamera::capture(std::string* error) {
  cv::Mat frame;
  if (!state_->capture.isOpened() || !state_->capture.read(frame) || frame.empty()) {
    *error = fmt::format("opencv:{} gave no frame", source_);
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
  return imageFromMat(rgb);
}

}  // namespace parallax::hw
