#include "calibration/checkerboard_captures.h"

#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calibration/json_file.h"
#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax {
namespace {

using nlohmann::json;

constexpr const char* kFormatName = "parallax-checkerboard";
constexpr int kFormatVersion = 1;
constexpr size_t kMaxPictures = 1000;

[[noreturn]] void fail(const std::string& field, const std::string& reason) {
  throw InputError(InputLocation{"", field, 0}, reason);
}

const json& member(const json& object, const std::string& key) {
  if (!object.is_object()) fail("", fmt::format("must be an object, got {}", object.type_name()));
  const auto it = object.find(key);
  if (it == object.end()) fail(key, "missing");
  return *it;
}

// A picture's name: a relative path that stays inside the captures folder.
bool insideFolder(const std::string& name) {
  return !name.empty() && name.front() != '/' && name.find("..") == std::string::npos &&
         name.find('\\') == std::string::npos;
}

cv::Mat loadBoardPicture(const std::string& path, int width, int height) {
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw InputError({path, "", 0}, "cannot read the checkerboard picture (missing or not an image)");
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw InputError({path, "", 0}, "must be an 8-bit grey or colour picture, as the camera recorded it");
  }
  if (image.cols != width || image.rows != height) {
    throw InputError({path, "", 0}, fmt::format("is {}x{}, the camera's pictures are {}x{} (camera.json)", image.cols,
                                                image.rows, width, height));
  }
  if (image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  return image;
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
  if (ec) throw InputError({folder, "", 0}, "cannot create the checkerboard folder: " + ec.message());
  json j;
  j["format"] = kFormatName;
  j["version"] = kFormatVersion;
  j["inner_corners"] = {captures.board.innerColumns, captures.board.innerRows};
  j["square_m"] = captures.board.squareM;
  j["pictures"] = json::array();
  for (size_t i = 0; i < captures.pictures.size(); ++i) {
    const std::string name = fmt::format("checkerboard/board_{:02d}.png", i);
    const std::string path = directory + "/" + name;
    if (!cv::imwrite(path, captures.pictures[i].recorded)) throw InputError({path, "", 0}, "cannot write the picture");
    j["pictures"].push_back(name);
  }
  writeFileAtomically(directory + "/" + kCheckerboardFileName, j.dump(2) + "\n");
}

CheckerboardCaptures loadCheckerboardCaptures(const std::string& directory, int width, int height) {
  const std::string path = directory + "/" + kCheckerboardFileName;
  CheckerboardCaptures captures;
  try {
    const json j = readJsonFile(path);
    const json& format = member(j, "format");
    if (!format.is_string() || format.get<std::string>() != kFormatName) {
      fail("format", fmt::format("must be \"{}\", got {}", kFormatName, format.dump()));
    }
    const json& version = member(j, "version");
    if (!version.is_number_integer() || version.get<long long>() != kFormatVersion) {
      fail("version", fmt::format("must be {}, got {}", kFormatVersion, version.dump()));
    }
    const json& inner = member(j, "inner_corners");
    if (!inner.is_array() || inner.size() != 2 || !inner[0].is_number_integer() || !inner[1].is_number_integer()) {
      fail("inner_corners", "must be [columns, rows], two integers");
    }
    const long long columns = inner[0].get<long long>(), rows = inner[1].get<long long>();
    if (columns < 3 || rows < 3 || columns > 100 || rows > 100) fail("inner_corners", "must be 3..100 each way");
    captures.board.innerColumns = static_cast<int>(columns);
    captures.board.innerRows = static_cast<int>(rows);
    const json& square = member(j, "square_m");
    if (!square.is_number()) fail("square_m", fmt::format("must be a number, got {}", square.type_name()));
    captures.board.squareM = square.get<double>();
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
  for (CheckerboardPicture& p : captures.pictures) p.recorded = loadBoardPicture(p.name, width, height);
  return captures;
}

}  // namespace parallax
