#include "hw/camera/folder_camera.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "calibration/capture/camera_picture.h"
#include "common/input_error.h"
#include "hw/camera/image_from_mat.h"

namespace parallax::hw {
namespace fs = std::filesystem;

FolderCamera::FolderCamera(std::string directory, FolderCameraOptions options)
    : directory_(std::move(directory)), options_(std::move(options)) {
  std::error_code ec;
  if (!fs::is_directory(directory_, ec)) {
    if (!options_.waitForPictures || fs::exists(directory_, ec))
      throw InputError({directory_, "", 0}, "folder: the pictures' folder does not exist");
    // Live, a new folder: made here, the operator's pictures go into it.
    fs::create_directories(directory_, ec);
    if (ec)
      throw InputError({directory_, "", 0}, "folder: cannot make the folder: " + ec.message());
  }
  if (fs::exists(manifestPath(), ec)) manifest_ = loadPictureManifest(manifestPath());
}

std::string FolderCamera::manifestPath() const {
  return (fs::path(directory_) / kPictureManifestName).string();
}

CameraLockResult FolderCamera::lock(const CameraSettings& settings) {
  settings_ = settings;
  locked_ = true;
  return {true, {}};
}

void FolderCamera::beginSession(const CaptureSessionKey& key) {
  key_ = key;
  std::vector<std::pair<std::string, std::string>> session = key.fields;
  session.emplace_back("picture_size", fmt::format("{}x{}", key.pictureWidth, key.pictureHeight));
  if (manifest_.pictures.empty()) {
    manifest_.session = session;
    return;
  }
  // Pictures already taken: of this session, or refused before any is read.
  for (const auto& [name, value] : session) {
    std::string found;
    for (const auto& [n, v] : manifest_.session)
      if (n == name) found = v;
    if (found != value) {
      throw InputError(
          {manifestPath(), "session." + name, 0},
          fmt::format("the pictures here were taken for {} \"{}\", this calibration is for \"{}\": "
                      "use another folder",
                      name, found.empty() ? "(not recorded)" : found, value));
    }
  }
}

void FolderCamera::showing(const std::string& what) { showing_ = what; }

Image FolderCamera::capture(std::string* error) {
  lastPicture_.clear();
  if (showing_.empty()) {
    *error = fmt::format("{}: takes the pictures of the calibration patterns only", name());
    return {};
  }
  const ManifestPicture* entry = manifest_.find(showing_);
  if (entry == nullptr) {
    if (!options_.waitForPictures) {
      std::error_code ec;
      *error = fs::exists(manifestPath(), ec)
                   ? fmt::format(
                         "{}: no picture of \"{}\" in {} ({} pictures listed): the "
                         "pictures were taken for other stations or stopped before this one",
                         name(), showing_, manifestPath(), manifest_.pictures.size())
                   : fmt::format(
                         "{}: no picture of \"{}\": the folder has no {} (its pictures "
                         "are taken live first, with --link)",
                         name(), showing_, kPictureManifestName);
      return {};
    }
    const int index = static_cast<int>(manifest_.pictures.size());
    manifest_.pictures.push_back({pictureFileName(index, showing_), showing_});
    savePictureManifest(manifest_, manifestPath());
    entry = &manifest_.pictures.back();
  }
  const std::string path = (fs::path(directory_) / entry->file).string();
  lastPicture_ = path;
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    if (!options_.waitForPictures) {
      *error = fmt::format("picture {} (of {}) is missing", path, showing_);
      return {};
    }
    if (options_.onRequest) {
      options_.onRequest(
          {showing_, path, static_cast<int>(entry - manifest_.pictures.data()), station()});
    }
  }
  // Live, the file may be missing or half written (a copy in progress): waited for, whole.
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  std::string lastProblem = "it is not there";
  for (;;) {
    if (fs::exists(path, ec)) {
      try {
        return imageFromMat(readCameraPicture(path, key_.pictureWidth, key_.pictureHeight));
      } catch (const InputError& e) {
        if (!options_.waitForPictures) {
          *error = e.what();
          return {};
        }
        lastProblem = e.reason();
      }
    }
    if (options_.cancelled && options_.cancelled()) {
      *error = fmt::format("cancelled while waiting for picture {}", path);
      return {};
    }
    if (std::chrono::duration<double>(Clock::now() - start).count() > options_.pictureTimeoutS) {
      *error = fmt::format(
          "picture {} (of {}) not taken within {:g} s ({}); the pictures in {} are kept: run "
          "the same command again to go on from this one",
          path, showing_, options_.pictureTimeoutS, lastProblem, directory_);
      return {};
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(options_.pollS));
  }
}

}  // namespace parallax::hw
