#include "hw/camera/calibration_capture.h"

#include <fmt/format.h>

#include "calibration/simulation/simulated_session.h"
#include "common/input_error.h"

namespace parallax::hw {
namespace {

std::shared_ptr<const Image> moduleFrame(const cv::Mat& linear, PixelFormat format) {
  auto image = std::make_shared<Image>();
  image->width = linear.cols;
  image->height = linear.rows;
  image->format = format;
  image->pixels.resize(image->byteSize());
  const int bpp = bytesPerPixel(format);
  for (int y = 0; y < linear.rows; ++y) {
    const float* in = linear.ptr<float>(y);
    uint8_t* out = image->pixels.data() + static_cast<size_t>(y) *
                                              static_cast<size_t>(linear.cols) *
                                              static_cast<size_t>(bpp);
    for (int x = 0; x < linear.cols; ++x) {
      const auto v = static_cast<uint8_t>(std::lround(255.0f * std::clamp(in[x], 0.0f, 1.0f)));
      for (int c = 0; c < bpp; ++c) out[x * bpp + c] = v;
    }
  }
  return image;
}

// Puts the modules back into playback mode and unlocks the camera however the session ends.
class SessionGuard {
 public:
  SessionGuard(LinkClient& link, Camera& camera) : link_(link), camera_(camera) {}
  ~SessionGuard() {
    try {
      link_.flush();
      link_.takeOutcomes();
      link_.setMode(DisplayMode::kPlayback);
    } catch (...) {  // a dead link: nothing more can be done from here
    }
    camera_.unlock();
  }

 private:
  LinkClient& link_;
  Camera& camera_;
};

}  // namespace

void CalibrationCaptureOptions::validate(const CameraMetadata& camera) const {
  patterns.validate();
  if (groupStride < 1 || groupStride > 1024)
    throw InputError({"", "group_stride", 0}, "must be 1..1024");
  for (int s : stations) {
    if (s < 0 || s >= static_cast<int>(camera.stations.size())) {
      throw InputError({"", "stations", 0},
                       fmt::format("station {} is not in the camera metadata (0..{})", s,
                                   static_cast<int>(camera.stations.size()) - 1));
    }
  }
}

cv::Mat linearPicture(const Image& picture, double responseGamma) {
  const int bpp = bytesPerPixel(picture.format);
  cv::Mat grey(picture.height, picture.width, CV_8U);
  for (int y = 0; y < picture.height; ++y) {
    const uint8_t* in = picture.pixels.data() + static_cast<size_t>(y) *
                                                    static_cast<size_t>(picture.width) *
                                                    static_cast<size_t>(bpp);
    uint8_t* out = grey.ptr<uint8_t>(y);
    for (int x = 0; x < picture.width; ++x) {
      int sum = 0;
      for (int c = 0; c < bpp; ++c) sum += in[x * bpp + c];
      out[x] = static_cast<uint8_t>((sum + bpp / 2) / bpp);
    }
  }
  return linearFromRecorded8(grey, responseGamma);
}

CalibrationCaptures captureCalibration(LinkClient& link, Camera& camera,
                                       const DisplayModel& nominal, const CameraMetadata& metadata,
                                       const CalibrationCaptureOptions& options,
                                       const std::function<void(int done, int total)>& progress,
                                       const std::atomic<bool>* cancel) {
  options.validate(metadata);
  const int modules = static_cast<int>(nominal.modules.size());
  const int mw = nominal.modules.front().width, mh = nominal.modules.front().height;
  if (static_cast<int>(link.modules().size()) != modules) {
    throw std::runtime_error(fmt::format("the link has {} modules, the nominal display {}",
                                         link.modules().size(), modules));
  }
  bool grey = true;
  for (const ModuleLinkInfo& m : link.modules()) {
    if (static_cast<int>(m.info.width) != mw || static_cast<int>(m.info.height) != mh) {
      throw std::runtime_error(
          fmt::format("module {} shows {}x{}, the nominal display's modules are {}x{}", m.module,
                      m.info.width, m.info.height, mw, mh));
    }
    grey = grey && (m.info.pixelFormats & (1u << static_cast<int>(PixelFormat::kGray8))) != 0;
  }
  const PixelFormat format = grey ? PixelFormat::kGray8 : PixelFormat::kRgb8;

  CalibrationCaptures captures;
  captures.camera = metadata;
  captures.patterns = options.patterns;
  captures.moduleWidth = mw;
  captures.moduleHeight = mh;
  std::vector<std::shared_ptr<const Image>> columnFrames, rowFrames;
  for (const cv::Mat& f : makePatternFrames(mw, mh, PatternAxis::kColumns, options.patterns))
    columnFrames.push_back(moduleFrame(f, format));
  for (const cv::Mat& f : makePatternFrames(mw, mh, PatternAxis::kRows, options.patterns))
    rowFrames.push_back(moduleFrame(f, format));
  const auto dark = moduleFrame(cv::Mat(mh, mw, CV_32F, cv::Scalar(0)), format);

  std::vector<int> stations = options.stations;
  if (stations.empty()) {
    for (int s = 0; s < static_cast<int>(metadata.stations.size()); ++s) stations.push_back(s);
  }
  const auto groups = moduleGroups(modules, options.groupStride);
  const int total =
      static_cast<int>(stations.size() * groups.size() * (columnFrames.size() + rowFrames.size()));
  int done = 0;

  const CameraLockResult lock = camera.lock(options.cameraSettings);
  if (!lock.ok) throw std::runtime_error(lock.describe());
  SessionGuard guard(link, camera);
  if (!link.setMode(DisplayMode::kPattern))
    throw std::runtime_error("the modules did not switch to pattern mode");
  if (progress) progress(0, total);

  for (int station : stations) {
    if (options.beforeStation) options.beforeStation(station);
    camera.setStation(station);
    for (const std::vector<int>& group : groups) {
      StationCaptures set;
      set.station = station;
      set.group = group;
      for (auto [frames, out, axis] : {std::tuple{&columnFrames, &set.columnFrames, "column"},
                                       std::tuple{&rowFrames, &set.rowFrames, "row"}}) {
        for (size_t f = 0; f < frames->size(); ++f) {
          if (cancel && cancel->load()) throw CalibrationCancelled();
          std::vector<bool> inGroup(static_cast<size_t>(modules), false);
          for (int m : group) inGroup[static_cast<size_t>(m)] = true;
          for (int m = 0; m < modules; ++m)
            link.submit(m, inGroup[static_cast<size_t>(m)] ? (*frames)[f] : dark);
          link.flush();
          for (const FrameOutcome& o : link.takeOutcomes()) {
            if (o.status == FrameStatus::kDelivered || o.status == FrameStatus::kSkippedUnchanged)
              continue;
            throw std::runtime_error(
                fmt::format("station {}, {} pattern {}: module {} did not show it ({}: {})",
                            station, axis, f, o.module, frameStatusName(o.status), o.reason));
          }
          std::string error;
          const Image picture = camera.capture(&error);
          if (picture.empty()) {
            throw std::runtime_error(
                fmt::format("station {}, {} pattern {}: {}", station, axis, f, error));
          }
          if (picture.width != metadata.intrinsics.width ||
              picture.height != metadata.intrinsics.height) {
            throw std::runtime_error(
                fmt::format("station {}: the camera gave a {}x{} picture, its metadata says {}x{}",
                            station, picture.width, picture.height, metadata.intrinsics.width,
                            metadata.intrinsics.height));
          }
          out->push_back(linearPicture(picture, metadata.responseGamma));
          ++done;
          if (progress) progress(done, total);
        }
      }
      captures.stations.push_back(std::move(set));
    }
  }
  return captures;
}

}  // namespace parallax::hw
