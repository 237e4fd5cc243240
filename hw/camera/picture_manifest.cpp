#include "hw/camera/picture_manifest.h"

#include <fmt/format.h>

#include <cctype>
#include <nlohmann/json.hpp>
#include <set>

#include "calibration/display/json_fields.h"
#include "calibration/display/json_file.h"
#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax::hw {
namespace {

using nlohmann::json;

constexpr const char* kFormat = "parallax picture manifest";
constexpr int kVersion = 1;
constexpr size_t kMaxPictures = 100000;  // a session of hundreds of modules has a few thousand

std::string text(const json& j, const std::string& field) {
  if (!j.is_string()) jsonfield::fail(field, "must be a string");
  const std::string s = j.get<std::string>();
  if (s.empty() || s.size() > 1000) jsonfield::fail(field, "must be 1..1000 characters");
  return s;
}

}  // namespace

const ManifestPicture* PictureManifest::find(const std::string& shows) const {
  for (const ManifestPicture& p : pictures)
    if (p.shows == shows) return &p;
  return nullptr;
}

PictureManifest loadPictureManifest(const std::string& path) {
  const json j = readJsonFile(path, size_t{16} << 20);
  try {
    jsonfield::requireFormat(j, kFormat, kVersion);
    PictureManifest manifest;
    const json& session = jsonfield::member(j, "session");
    if (!session.is_object()) jsonfield::fail("session", "must be an object");
    for (const auto& [name, value] : session.items())
      manifest.session.emplace_back(name, text(value, "session." + name));
    const json& pictures =
        jsonfield::array(jsonfield::member(j, "pictures"), "pictures", kMaxPictures);
    std::set<std::string> files, frames;
    for (size_t i = 0; i < pictures.size(); ++i) {
      const std::string at = fmt::format("pictures[{}]", i);
      ManifestPicture p;
      p.file = text(jsonfield::member(pictures[i], "file", at), at + ".file");
      p.shows = text(jsonfield::member(pictures[i], "shows", at), at + ".shows");
      // A name inside the folder, nothing else: a manifest must not make the tool read
      // /etc/passwd or ../other/picture.png.
      if (p.file.find('/') != std::string::npos || p.file.front() == '.' ||
          p.file.find('\0') != std::string::npos)
        jsonfield::fail(at + ".file", fmt::format("\"{}\" is not a plain file name", p.file));
      if (p.file == kPictureManifestName) jsonfield::fail(at + ".file", "is the manifest itself");
      if (!files.insert(p.file).second)
        jsonfield::fail(at + ".file", fmt::format("\"{}\" appears twice", p.file));
      if (!frames.insert(p.shows).second)
        jsonfield::fail(at + ".shows", fmt::format("\"{}\" has two pictures", p.shows));
      manifest.pictures.push_back(std::move(p));
    }
    return manifest;
  } catch (const InputError& e) {
    throw e.inFile(path);
  }
}

void savePictureManifest(const PictureManifest& manifest, const std::string& path) {
  json j{{"format", kFormat},
         {"version", kVersion},
         {"session", json::object()},
         {"pictures", json::array()}};
  for (const auto& [name, value] : manifest.session) j["session"][name] = value;
  for (const ManifestPicture& p : manifest.pictures)
    j["pictures"].push_back({{"file", p.file}, {"shows", p.shows}});
  writeFileAtomically(path, j.dump(2) + "\n");
}

std::string pictureFileName(int index, const std::string& shows) {
  std::string slug;
  for (const char c : shows) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      slug += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!slug.empty() && slug.back() != '_') {
      slug += '_';
    }
  }
  while (!slug.empty() && slug.back() == '_') slug.pop_back();
  return fmt::format("{:04d}_{}.png", index, slug);
}

}  // namespace parallax::hw
