#include "calibration/capture/checkerboard_captures.h"

#include <fmt/format.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calibration/capture/camera_picture.h"
#include "calibration/display/json_fields.h"
#include "calibration/display/json_file.h"
#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax {
namespace {

using jsonfield::fail;
using jsonfield::member;
using nlohmann::json;

constexpr const char* kFormatName = "parallax-checkerboard";
constexpr int kFormatVersion = 1;
constexpr size_t kMaxPictures = 1000;

// A picture's name: a relative path that stays inside the captures folder.
bool insideFolder(const std::string& name) {
  return !name.empty() && name.front() != '/' && name.find("..") == std::string::npos &&
         name.find('\\') == std::string::npos;
}

}  // namespace

bool hasCheckerboardCaptures(const std::string& directory) {
  std::error_code ec;
  return std::filesystem::exists(directory + "/" + kCheckerboardFileName, ec);
}

void saveCheckerboardCaptures(const CheckerboardCaptures& captures, const std::string& directory) {
  captures.board.validate();
  const std::string folder = directory + "/checkerboard";
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec)
    throw InputError({folder, "", 0}, "cannot create the checkerboard folder: " + ec.message());
  json j;
  j["format"] = kFormatName;
  j["version"] = kFormatVersion;
  j["inner_corners"] = {captures.board.innerColumns, captures.board.innerRows};
  j["square_m"] = captures.board.squareM;
  j["pictures"] = json::array();
  for (size_t i = 0; i < captures.pictures.size(); ++i) {
    const std::string name = fmt::format("checkerboard/board_{:02d}.png", i);
    const std::string path = directory + "/" + name;
    if (!cv::imwrite(path, captures.pictures[i].recorded))
      throw InputError({path, "", 0}, "cannot write the picture");
    j["pictures"].push_back(name);
  }
  writeFileAtomically(directory + "/" + kCheckerboardFileName, j.dump(2) + "\n");
}

CheckerboardCaptures loadCheckerboardCaptures(const std::string& directory, int width, int height) {
  const std::string path = directory + "/" + kCheckerboardFileName;
  CheckerboardCaptures captures;
  try {
    const json j = readJsonFile(path);
    jsonfield::requireFormat(j, kFormatName, kFormatVersion);
    const json& inner = member(j, "inner_corners");
    if (!inner.is_array() || inner.size() != 2)
      fail("inner_corners", "must be [columns, rows], two integers");
    captures.board.innerColumns =
        static_cast<int>(jsonfield::integer(inner[0], "inner_corners", 3, 100));
    captures.board.innerRows =
        static_cast<int>(jsonfield::integer(inner[1], "inner_corners", 3, 100));
    captures.board.squareM = jsonfield::number(member(j, "square_m"), "square_m");
    captures.board.validate();  // names inner_corners / square_m
    const json& pictures = member(j, "pictures");
    if (!pictures.is_array() || pictures.empty() || pictures.size() > kMaxPictures) {
      fail("pictures", fmt::format("must list 1..{} picture files", kMaxPictures));
    }
    for (size_t i = 0; i < pictures.size(); ++i) {
      const std::string field = fmt::format("pictures[{}]", i);
      if (!pictures[i].is_string()) fail(field, "must be a file name");
      const std::string name = pictures[i].get<std::string>();
      if (!insideFolder(name)) fail(field, "must be a relative path inside the captures folder");
      captures.pictures.push_back({directory + "/" + name, cv::Mat()});
    }
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(path) : e;
  }
  // The pictures themselves: their errors name the picture's file.
  for (CheckerboardPicture& p : captures.pictures)
    p.recorded = readCameraPicture(p.name, width, height);
  return captures;
}

}  // namespace parallax
