#include "hw/camera/flat_field_session.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace parallax::hw {

FlatFieldSession::FlatFieldSession(LinkClient& link, Camera& camera, CameraSettings settings)
    : link_(link), camera_(camera), settings_(settings) {
  settings_.colour = true;
  const CameraLockResult lock = camera_.lock(settings_);
  if (!lock.ok) throw std::runtime_error(lock.describe());
  if (!link_.setMode(DisplayMode::kPattern)) {
    camera_.unlock();
    throw std::runtime_error("the modules did not switch to pattern mode");
  }
}

FlatFieldSession::~FlatFieldSession() {
  try {
    link_.flush();
    link_.takeOutcomes();
    link_.setMode(DisplayMode::kPlayback);
  } catch (...) {  // a dead link: nothing more can be done from here
  }
  camera_.unlock();
}

cv::Mat FlatFieldSession::take(int station, const std::vector<const std::uint8_t*>& frames,
                               double exposure) {
  const std::vector<ModuleLinkInfo>& modules = link_.modules();
  if (frames.size() != modules.size()) {
    throw std::runtime_error(
        fmt::format("flat field: {} frames for {} modules", frames.size(), modules.size()));
  }
  for (size_t m = 0; m < frames.size(); ++m) {
    auto& image = images_[frames[m]];
    if (!image) {
      auto made = std::make_shared<Image>();
      made->width = static_cast<int>(modules[m].info.width);
      made->height = static_cast<int>(modules[m].info.height);
      made->format = PixelFormat::kRgb8;
      made->pixels.assign(frames[m], frames[m] + made->byteSize());
      image = made;
    }
    link_.submit(static_cast<int>(m), image);
  }
  link_.flush();
  for (const FrameOutcome& o : link_.takeOutcomes()) {
    if (o.status == FrameStatus::kDelivered || o.status == FrameStatus::kSkippedUnchanged) continue;
    throw std::runtime_error(
        fmt::format("flat field at station {}: module {} did not show it ({}: {})", station,
                    o.module, frameStatusName(o.status), o.reason));
  }
  CameraSettings settings = settings_;
  settings.exposureUs =
      static_cast<uint32_t>(std::clamp(std::lround(exposure * 10000.0), 1L, 100000000L));
  if (settings.exposureUs != camera_.settings().exposureUs) {
    const CameraLockResult lock = camera_.lock(settings);
    if (!lock.ok) throw std::runtime_error(lock.describe());
  }
  camera_.setStation(station);
  std::string error;
  const Image picture = camera_.capture(&error);
  if (picture.empty())
    throw std::runtime_error(fmt::format("flat field at station {}: {}", station, error));
  if (picture.format != PixelFormat::kRgb8) {
    throw std::runtime_error(
        fmt::format("flat field at station {}: the camera gave no colour picture", station));
  }
  cv::Mat out(picture.height, picture.width, CV_32FC3);
  for (int y = 0; y < picture.height; ++y) {
    cv::Vec3f* row = out.ptr<cv::Vec3f>(y);
    const uint8_t* in =
        picture.pixels.data() + static_cast<size_t>(y) * static_cast<size_t>(picture.width) * 3;
    for (int x = 0; x < picture.width; ++x)
      for (int c = 0; c < 3; ++c) row[x][c] = in[3 * x + c] / 255.0f;
  }
  return out;
}

}  // namespace parallax::hw
