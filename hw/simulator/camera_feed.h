#pragma once
// parallax-simhw's camera as a streaming camera sees it: a picture file rewritten (atomically:
// temporary file, rename) whenever what the modules show changes, rendered by the calibration
// physics from the station a station file names (missing: station 0). A GStreamer pipeline
// (multifilesrc loop=true ! pngdec ! videoconvert ! appsink) reading the file is then a real
// cv::VideoCapture source, with the latency of its queues, for `--camera opencv:PIPELINE`
// (README: "Calibrating a real display with a webcam"; tests/hw/calibrate_opencv_test.sh).
//
// With auto exposure the feed behaves like a webcam left on automatic: each picture's exposure
// is set from the brightness of the one before it (aiming at a mean of 0.3), lagging a frame.

#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "hw/link/image.h"
#include "hw/simulator/camera_physics.h"

namespace parallax::hw {

struct CameraFeedOptions {
  std::string picture;      // the file the pictures go to (PNG)
  std::string stationFile;  // holds the station number; empty or missing: 0
  bool autoExposure = false;
};

class CameraFeed {
 public:
  CameraFeed(CameraFeedOptions options, std::unique_ptr<CameraPhysics> physics);
  ~CameraFeed();
  CameraFeed(const CameraFeed&) = delete;
  CameraFeed& operator=(const CameraFeed&) = delete;

  // What every module shows now (from the thread serving the link, after each frame shown).
  void shown(std::vector<Image> frames);

 private:
  void run();
  int station() const;

  CameraFeedOptions options_;
  std::unique_ptr<CameraPhysics> physics_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Image> frames_;
  uint64_t version_ = 0;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace parallax::hw
