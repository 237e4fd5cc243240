#include "hw/simulator/camera_feed.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

namespace parallax::hw {

CameraFeed::CameraFeed(CameraFeedOptions options, std::unique_ptr<CameraPhysics> physics)
    : options_(std::move(options)), physics_(std::move(physics)) {
  thread_ = std::thread([this] { run(); });
}

CameraFeed::~CameraFeed() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void CameraFeed::shown(std::vector<Image> frames) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frames_ = std::move(frames);
    ++version_;
  }
  changed_.notify_all();
}

int CameraFeed::station() const {
  if (options_.stationFile.empty()) return 0;
  std::ifstream in(options_.stationFile);
  int station = 0;
  if (in >> station && station >= 0 && station < 65536) return station;
  return 0;
}

void CameraFeed::run() {
  uint64_t rendered = 0;
  int renderedStation = -1;
  double exposure = 1.0;
  for (;;) {
    std::vector<Image> frames;
    uint64_t version = 0;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      // The station file is looked at every 20 ms; new frames wake the feed at once.
      changed_.wait_for(lock, std::chrono::milliseconds(20),
                        [&] { return stop_ || version_ != rendered; });
      if (stop_) return;
      frames = frames_;
      version = version_;
    }
    const int now = station();
    if ((version == rendered && now == renderedStation) || frames.empty()) continue;
    std::vector<const Image*> pointers;
    for (const Image& f : frames) pointers.push_back(f.empty() ? nullptr : &f);
    Image picture = physics_->render(pointers, 0, now, CameraSettings{});
    rendered = version;
    renderedStation = now;
    if (picture.empty()) continue;
    if (options_.autoExposure) {
      double sum = 0.0;
      for (uint8_t p : picture.pixels) sum += p;
      const double mean = sum / (255.0 * static_cast<double>(picture.pixels.size()));
      for (uint8_t& p : picture.pixels)
        p = static_cast<uint8_t>(std::min(255.0, std::round(p * exposure)));
      // The next picture's exposure from this one's scene, as an automatic camera does.
      exposure = std::clamp(0.3 / std::max(mean, 1e-3), 0.5, 1.0);
    }
    const std::string temporary = options_.picture + ".writing.png";
    try {
      writePng(picture, temporary);
      std::rename(temporary.c_str(), options_.picture.c_str());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "parallax-simhw: camera feed: %s\n", e.what());
    }
  }
}

}  // namespace parallax::hw
