#pragma once
// A calibration session through the link: the modules, in pattern mode, show the
// structured-light patterns group by group (calibration/capture/calibration_captures.h's
// moduleGroups: every n-th module at once, the others dark), each frame with its sync code
// (sync_code.h); after every pattern frame has been delivered to every module, the camera
// takes pictures until one shows that frame (late ones are retaken), converted to linear light
// through its response. With a camera whose exposure is not locked, each coded picture is
// scaled by its exposure relative to the white reference, measured from the code's lit cells. At
// the end — completed, cancelled or failed — the modules go back to playback mode and the camera is
// unlocked. Pictures that are files (a folder: camera) cannot be retaken: one the sync code
// refuses, or that is blurred or over-exposed (picture_quality.h), ends the session naming the
// file; their exposure is measured when allowUnlockedCamera says it was automatic.
//
// Never half a session passed off as complete: a frame that cannot be delivered, a picture the
// camera does not give or a wrong picture size throws std::runtime_error naming the module,
// station and frame; `cancel` becoming true throws CalibrationCancelled.

#include <atomic>
#include <functional>
#include <stdexcept>
#include <vector>

#include "calibration/capture/calibration_captures.h"
#include "calibration/capture/sync_code.h"
#include "hw/camera/camera.h"
#include "hw/camera/pattern_screen.h"
#include "hw/link/link_client.h"

namespace parallax::hw {

struct CalibrationCaptureOptions {
  StructuredLightOptions patterns;
  std::vector<int> stations;  // empty: every station of the camera metadata
  int groupStride = 3;  // modules showing patterns at once: every n-th, or more (groupStrideFor)
  CameraSettings cameraSettings;  // locked for the whole session
  // A camera that does not lock a control is refused (naming it) unless this is true; then
  // `onUnlocked` hears what did not lock and the session goes on.
  bool allowUnlockedCamera = false;
  std::function<void(const std::string& what)> onUnlocked;
  // A picture that is not of the frame just shown (its sync code, sync_code.h) is retaken for
  // up to this long before the session stops, naming the frame and what the camera showed.
  double settleTimeoutS = 10.0;
  // Called before the pictures of each station: a real camera is moved there by the operator
  // or a rig (the call returns when it stands there). The simulated camera needs nothing.
  std::function<void(int station)> beforeStation;

  // Throws InputError naming the field.
  void validate(const CameraMetadata& camera) const;
};

// How the camera kept up: every picture is checked against the frame shown (sync_code.h).
struct CaptureSyncStats {
  int pictures = 0;    // accepted
  int retaken = 0;     // pictures of another frame (late, torn), taken again
  int tornWhites = 0;  // pattern sets taken again: their white reference proved torn
  // From the frame's delivery to the modules to its first accepted picture.
  double settleMedianMs = 0.0, settleMaxMs = 0.0;
  double seconds = 0.0;          // the whole session
  std::string describe() const;  // one line
};

class CalibrationCancelled : public std::runtime_error {
 public:
  CalibrationCancelled()
      : std::runtime_error("calibration cancelled; the modules are back in playback mode") {}
};

CalibrationCaptures captureCalibration(
    LinkClient& link, Camera& camera, const DisplayModel& nominal, const CameraMetadata& metadata,
    const CalibrationCaptureOptions& options,
    const std::function<void(int done, int total)>& progress = {},
    const std::atomic<bool>* cancel = nullptr, CaptureSyncStats* stats = nullptr);
// The same session on a screen whose modules are not all behind one link (a cluster's).
CalibrationCaptures captureCalibration(
    PatternScreen& screen, Camera& camera, const DisplayModel& nominal,
    const CameraMetadata& metadata, const CalibrationCaptureOptions& options,
    const std::function<void(int done, int total)>& progress = {},
    const std::atomic<bool>* cancel = nullptr, CaptureSyncStats* stats = nullptr);

// The same session with no display (offline): nothing is shown, the camera's pictures are files
// already taken (Camera::picturesAreFiles, a folder: camera), each checked as above.
// std::runtime_error for any other camera.
CalibrationCaptures captureCalibrationOffline(
    Camera& camera, const DisplayModel& nominal, const CameraMetadata& metadata,
    const CalibrationCaptureOptions& options,
    const std::function<void(int done, int total)>& progress = {},
    const std::atomic<bool>* cancel = nullptr, CaptureSyncStats* stats = nullptr);

// A camera picture (8-bit grey or RGB) as linear light through the camera's response.
cv::Mat linearPicture(const Image& picture, double responseGamma);

}  // namespace parallax::hw
