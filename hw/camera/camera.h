#pragma once
// The calibration camera. A calibration run locks exposure, gain and white balance before the
// first capture and keeps them until it ends, so that every pattern is seen with the same
// response (auto-exposure between two Gray-code frames would shift the decoding threshold).
//
// Backends: SimulatedCamera (the camera inside parallax-simhw, over the link), OpenCvCamera
// (any cv::VideoCapture source: a V4L2 device, a video file, an image sequence) and FolderCamera
// (folder_camera.h: pictures taken by hand, read from a folder).

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "hw/link/camera_settings.h"
#include "hw/link/image.h"

namespace parallax::hw {

class LinkClient;

struct CameraLockResult {
  bool ok = false;
  std::vector<std::string> unlocked;  // controls the backend could not pin, by name
  std::string describe() const;       // one line
};

// What identifies a capture session (the display, the patterns, the stations, the picture
// size): a camera that keeps its pictures (folder:) refuses the pictures of another session.
struct CaptureSessionKey {
  int pictureWidth = 0, pictureHeight = 0;
  std::vector<std::pair<std::string, std::string>> fields;  // name, value
};

class Camera {
 public:
  virtual ~Camera() = default;
  virtual std::string name() const = 0;
  // Pins the settings (manual exposure, fixed gain, fixed white balance, no autofocus and the
  // focus held) and reads each back. Reports every control the device refused or ignored rather
  // than pretending.
  virtual CameraLockResult lock(const CameraSettings& settings) = 0;
  // True when a picture taken after a frame was delivered is always of that frame (the camera
  // behind the link renders or exposes on request); a streaming camera may deliver late.
  virtual bool picturesFollowTheLink() const { return false; }
  // True when the pictures are files taken beforehand or by hand (folder:): asking again gives
  // the same picture, so one the sync code refuses ends the session (named) instead of being
  // retaken; and the session can run offline, with no display, once every picture is there.
  virtual bool picturesAreFiles() const { return false; }
  // The capture session says what it is before the first picture, and what the modules show
  // before it takes the pictures of each frame (`what`, unique in a session: "station 0,
  // modules 0,3, column pattern 4"). A camera that takes its pictures itself needs neither.
  virtual void beginSession(const CaptureSessionKey& key) { (void)key; }
  virtual void showing(const std::string& what) { (void)what; }
  // The picture last captured, for messages (folder: its file); empty when it has no name.
  virtual std::string lastPicture() const { return {}; }
  virtual void unlock() = 0;
  bool locked() const { return locked_; }
  const CameraSettings& settings() const { return settings_; }
  // One image; empty with `error` set when the camera gives none.
  virtual Image capture(std::string* error) = 0;
  // The calibration station the next pictures are taken from. The simulated camera moves
  // there itself (the station travels in the capture request); a real camera is moved by the
  // operator or a rig (captureCalibration's beforeStation hook), so it only records it.
  void setStation(int station) { station_ = station; }
  int station() const { return station_; }

 protected:
  bool locked_ = false;
  int station_ = 0;
  CameraSettings settings_;
};

// The simulated calibration camera behind the link: with parallax-simhw's calibration physics
// (--truth, --camera) it photographs the screen from its station; otherwise it returns the
// raw pattern of `viewModule`.
class SimulatedCamera : public Camera {
 public:
  explicit SimulatedCamera(LinkClient& link, int viewModule = 0)
      : link_(link), viewModule_(viewModule) {}
  std::string name() const override { return "simulated camera"; }
  bool picturesFollowTheLink() const override { return true; }
  CameraLockResult lock(const CameraSettings& settings) override;
  void unlock() override { locked_ = false; }
  Image capture(std::string* error) override;
  void setViewModule(int module) { viewModule_ = module; }

 private:
  LinkClient& link_;
  int viewModule_;
};

// A cv::VideoCapture source (camera_name.h): a V4L2 index or device, a GStreamer pipeline,
// gphoto2[:INDEX], or a path / URL / image-sequence pattern.
class OpenCvCamera : public Camera {
 public:
  OpenCvCamera();
  ~OpenCvCamera() override;
  // False with a one-line reason when the source does not open.
  bool open(const std::string& source, std::string* error);
  std::string name() const override { return "opencv:" + source_; }
  CameraLockResult lock(const CameraSettings& settings) override;
  void unlock() override;
  Image capture(std::string* error) override;

 private:
  struct State;
  std::unique_ptr<State> state_;
  std::string source_;
};

}  // namespace parallax::hw
