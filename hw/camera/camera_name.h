#pragma once
// Calibration cameras by name, as `parallax calibrate --camera NAME` and parallaxd's
// `[calibration] camera` give them:
//   link            the camera behind the hardware link (parallax-simhw's, or a real one that
//                   answers the link's capture requests)
//   opencv:SPEC     anything cv::VideoCapture opens: a V4L2 device (/dev/video0, or an index
//                   such as 0), a GStreamer pipeline ending in appsink (SPEC has a '!'), a
//                   stream URL (rtsp://, http://), or a tethered DSLR through gPhoto2
//                   (gphoto2 or gphoto2:INDEX)
//   folder:DIR      pictures taken by hand into DIR, named by the tool (folder_camera.h); live
//                   while a display shows the patterns, offline from a folder already filled
// A name that is none of these is refused in one line naming the field.

#include <memory>
#include <string>

#include "hw/camera/camera.h"
#include "hw/camera/folder_camera.h"

namespace parallax::hw {

enum class CameraKind { kLink, kOpenCv, kFolder };

struct CameraName {
  CameraKind kind = CameraKind::kLink;
  std::string argument;  // opencv: the SPEC; folder: DIR
  std::string text;      // as given, for messages
};

// Throws InputError naming `field` (e.g. "--camera" or "calibration.camera").
CameraName parseCameraName(const std::string& text, const std::string& field);

// True for the names parseCameraName accepts.
bool isCameraName(const std::string& text);

// Opens the camera; `link` is the camera behind it for `link`, and shows the patterns: a
// folder: camera waits for its pictures when there is a link, and reads them offline (every
// one already taken) without (`folder` gives the rest of its options). Throws
// std::runtime_error with one line naming the camera when it does not open (no such device, a
// pipeline that does not parse, a URL that does not answer, a camera that needs the link and
// has none), InputError for a folder that does not exist or a manifest that does not read.
std::unique_ptr<Camera> openCamera(const CameraName& name, LinkClient* link,
                                   FolderCameraOptions folder = {});

}  // namespace parallax::hw
