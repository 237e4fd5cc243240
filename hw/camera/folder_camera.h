#pragma once
// `folder:DIR`: the calibration pictures taken by hand, for an installer whose camera has no
// driver (a DSLR with a card, a phone, a machine-vision camera with only its own viewer).
//
// Live (a display shows the patterns through the link): for each frame the capture session
// shows, the tool names the picture to take — the frame and the file to save it as in DIR —
// and waits for that file to appear, whole (a half-copied PNG or JPEG is waited for), for up
// to `pictureTimeoutS`. The manifest (picture_manifest.h) in DIR records every picture asked
// for, so a stopped session goes on where it stopped: a picture already in DIR is used as it
// is, without waiting. Offline (no display: `waitForPictures` false), every picture must be
// there already; a missing one is named.
//
// The pictures go through the capture session's checks like any camera's (sync code, blur,
// over-exposure: calibration_capture.h), but a file cannot be retaken by asking again, so a
// refused picture ends the session naming the file and why (picturesAreFiles). Nothing on the
// camera can be locked from here: the operator sets exposure, focus and white balance by hand
// (lock() reports them locked); a camera left on automatic exposure is allowed as any camera's
// (CalibrationCaptureOptions::allowUnlockedCamera), each picture's exposure then measured from
// its sync code.

#include <functional>
#include <string>

#include "hw/camera/camera.h"
#include "hw/camera/picture_manifest.h"

namespace parallax::hw {

// A picture the operator is asked to take.
struct PictureRequest {
  std::string shows;  // the frame on the screen now
  std::string path;   // where to save it
  int index = 0;      // its place in the session (0-based)
  int station = 0;
};

struct FolderCameraOptions {
  bool waitForPictures = true;  // false: offline, every picture already in the folder
  double pictureTimeoutS = 600.0;
  double pollS = 0.1;
  // Live: told once per picture that is not in the folder yet, before waiting for it.
  std::function<void(const PictureRequest&)> onRequest;
  // Live: asked while waiting; true stops the wait (the picture not taken, "cancelled").
  std::function<bool()> cancelled;
};

class FolderCamera : public Camera {
 public:
  // Throws InputError when DIR is not a folder or its manifest does not read.
  FolderCamera(std::string directory, FolderCameraOptions options);
  std::string name() const override { return "folder:" + directory_; }
  bool picturesAreFiles() const override { return true; }
  // Nothing to lock: the operator's settings, told in the walk-through. Always ok.
  CameraLockResult lock(const CameraSettings& settings) override;
  void unlock() override { locked_ = false; }
  // Refuses a manifest of another session (InputError naming the field that differs).
  void beginSession(const CaptureSessionKey& key) override;
  void showing(const std::string& what) override;
  std::string lastPicture() const override { return lastPicture_; }
  Image capture(std::string* error) override;

 private:
  std::string manifestPath() const;

  std::string directory_;
  FolderCameraOptions options_;
  PictureManifest manifest_;
  CaptureSessionKey key_;
  std::string showing_;
  std::string lastPicture_;
};

}  // namespace parallax::hw
