#pragma once
// The photometric capture's camera through the link (calibration/photometry/
// flat_field_capture.h's FlatFieldCamera): the modules, in pattern mode, show the frames they
// are given; the camera, locked, takes a colour picture at the asked exposure (relative: 1 is
// 10 ms, what the simulated camera's light is scaled by). Kept apart from the geometric session
// (calibration_capture.h) and small, so that a shared capture pipeline can take it over.
//
// Never half a picture: a frame a module does not show, or a camera that gives no picture,
// throws std::runtime_error naming the module or the station. The destructor puts the modules
// back in playback mode and unlocks the camera.

#include <map>
#include <memory>
#include <opencv2/core.hpp>

#include "calibration/photometry/flat_field_capture.h"
#include "hw/camera/camera.h"
#include "hw/link/link_client.h"

namespace parallax::hw {

class FlatFieldSession {
 public:
  // Throws std::runtime_error when the camera cannot be locked or the modules refuse pattern
  // mode.
  FlatFieldSession(LinkClient& link, Camera& camera, CameraSettings settings);
  ~FlatFieldSession();
  FlatFieldSession(const FlatFieldSession&) = delete;
  FlatFieldSession& operator=(const FlatFieldSession&) = delete;

  // The picture as recorded (CV_32FC3, 0..1) while module i shows frames[i].
  cv::Mat take(int station, const std::vector<const std::uint8_t*>& frames, double exposure);
  FlatFieldCamera camera() {
    return [this](int station, const std::vector<const std::uint8_t*>& frames, double exposure) {
      return take(station, frames, exposure);
    };
  }

 private:
  LinkClient& link_;
  Camera& camera_;
  CameraSettings settings_;
  // The frames already made into link images (the capture's frame buffers live as long as it).
  std::map<const std::uint8_t*, std::shared_ptr<const Image>> images_;
};

}  // namespace parallax::hw
