#include "hw/camera/camera_name.h"

#include <fmt/format.h>

#include "common/input_error.h"

namespace parallax::hw {

CameraName parseCameraName(const std::string& text, const std::string& field) {
  CameraName name;
  name.text = text;
  if (text == "link") return name;
  if (text.rfind("opencv:", 0) == 0) {
    name.kind = CameraKind::kOpenCv;
    name.argument = text.substr(7);
    if (name.argument.empty()) {
      throw InputError({"", field, 0},
                       "opencv: needs a source: opencv:/dev/video0, opencv:0, opencv:gphoto2, "
                       "a GStreamer pipeline ending in appsink, or a stream URL");
    }
    return name;
  }
  if (text.rfind("folder:", 0) == 0) {
    name.kind = CameraKind::kFolder;
    name.argument = text.substr(7);
    if (name.argument.empty()) {
      throw InputError({"", field, 0},
                       "folder: needs the pictures' folder: folder:/path/to/pictures");
    }
    return name;
  }
  throw InputError(
      {"", field, 0},
      fmt::format("unknown camera \"{}\": give link, opencv:SPEC or folder:DIR", text));
}

bool isCameraName(const std::string& text) {
  return text == "link" || (text.rfind("opencv:", 0) == 0 && text.size() > 7) ||
         (text.rfind("folder:", 0) == 0 && text.size() > 7);
}

std::unique_ptr<Camera> openCamera(const CameraName& name, LinkClient* link,
                                   FolderCameraOptions folder) {
  if (name.kind == CameraKind::kFolder) {
    folder.waitForPictures = link != nullptr;
    return std::make_unique<FolderCamera>(name.argument, std::move(folder));
  }
  if (link == nullptr) {
    throw std::runtime_error(fmt::format(
        "{}: takes its pictures while the modules show the patterns: it needs the link (only a "
        "folder: camera calibrates offline, from pictures already taken)",
        name.text));
  }
  if (name.kind == CameraKind::kLink) return std::make_unique<SimulatedCamera>(*link);
  auto camera = std::make_unique<OpenCvCamera>();
  std::string error;
  if (!camera->open(name.argument, &error)) throw std::runtime_error(error);
  return camera;
}

}  // namespace parallax::hw
