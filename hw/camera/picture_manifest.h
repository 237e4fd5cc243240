#pragma once
// The manifest of a folder of calibration pictures taken by hand (folder_camera.h): which file
// is the picture of which frame, and the session they belong to. Written by the tool into the
// folder (`manifest.json`, atomically, after every picture it asks for), read back to go on
// after a stop or to calibrate offline:
//   {"format": "parallax picture manifest", "version": 1,
//    "session": {"display": "demo: 16 modules of 512x384", "camera": "640x360", ...},
//    "pictures": [{"file": "0000_station_0_modules_0_3_column_pattern_0.png",
//                  "shows": "station 0, modules 0,3, column pattern 0"}, ...]}
// The folder is untrusted: a file name is a plain name inside the folder (no '/', no leading
// '.'), each frame and each file appears once; anything else is an InputError naming the field.

#include <string>
#include <utility>
#include <vector>

namespace parallax::hw {

inline constexpr const char* kPictureManifestName = "manifest.json";

struct ManifestPicture {
  std::string file;   // inside the folder
  std::string shows;  // the frame, as the capture session names it
};

struct PictureManifest {
  std::vector<std::pair<std::string, std::string>> session;  // name, value
  std::vector<ManifestPicture> pictures;

  // The picture of frame `shows`; nullptr when the manifest has none yet.
  const ManifestPicture* find(const std::string& shows) const;
};

// Throws InputError naming the file and field.
PictureManifest loadPictureManifest(const std::string& path);
void savePictureManifest(const PictureManifest& manifest, const std::string& path);

// The file name the tool gives the picture of frame `shows`, the `index`-th it asks for:
// "0012_station_0_modules_0_3_column_pattern_4.png" (sorted by name, they are in order).
std::string pictureFileName(int index, const std::string& shows);

}  // namespace parallax::hw
