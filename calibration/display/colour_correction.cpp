#include "calibration/display/colour_correction.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "calibration/display/json_fields.h"
#include "calibration/display/json_file.h"
#include "calibration/display/srgb_transfer.h"
#include "common/atomic_file.h"
#include "common/content_checksum.h"
#include "common/input_error.h"

namespace parallax {
namespace {

using jsonfield::fail;
using jsonfield::member;
using nlohmann::json;
constexpr const char* kFormatName = "parallax-photometry";
constexpr int kFormatVersion = 1;
constexpr int kMaxGainNodes = 64;  // per side: a low-resolution map, never an image

json vectorJson(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
json vectorJson(const Eigen::Vector3f& v) { return {v.x(), v.y(), v.z()}; }

Eigen::Vector3d vectorFrom(const json& j, const std::string& field) {
  const std::vector<double> n = jsonfield::numbers(j, field, 3);
  return {n[0], n[1], n[2]};
}

constexpr const char* kChecksumField = "checksum";

// As the calibration files': the document without its own field, in canonical compact form.
std::string checksumOfDocument(json document) {
  document.erase(kChecksumField);
  return contentChecksum(document.dump());
}

json summaryJson(const PhotometricSummary& s) {
  json modules = json::array();
  for (const ModulePhotometricSummary& m : s.modules) {
    modules.push_back({{"excluded", m.excluded},
                       {"reason", m.reason},
                       {"scale", m.scale},
                       {"gain_max", m.gainMax},
                       {"delta_e_mean", m.deltaEMean},
                       {"delta_e_worst", m.deltaEWorst}});
  }
  return {{"delta_e_mean", s.deltaEMean},
          {"delta_e_worst", s.deltaEWorst},
          {"non_uniformity", s.nonUniformity},
          {"modules", modules}};
}

PhotometricSummary summaryFrom(const json& j, size_t moduleCount) {
  PhotometricSummary s;
  s.deltaEMean = jsonfield::number(member(j, "delta_e_mean", "summary"), "summary.delta_e_mean");
  s.deltaEWorst = jsonfield::number(member(j, "delta_e_worst", "summary"), "summary.delta_e_worst");
  s.nonUniformity =
      jsonfield::number(member(j, "non_uniformity", "summary"), "summary.non_uniformity");
  const json& modules =
      jsonfield::array(member(j, "modules", "summary"), "summary.modules", moduleCount);
  for (size_t i = 0; i < modules.size(); ++i) {
    const std::string at = fmt::format("summary.modules[{}]", i);
    const json& mj = modules[i];
    ModulePhotometricSummary m;
    const json& excluded = member(mj, "excluded", at);
    if (!excluded.is_boolean()) fail(at + ".excluded", "must be true or false");
    m.excluded = excluded.get<bool>();
    const json& reason = member(mj, "reason", at);
    if (!reason.is_string()) fail(at + ".reason", "must be a string");
    m.reason = reason.get<std::string>();
    m.scale = jsonfield::number(member(mj, "scale", at), at + ".scale");
    m.gainMax = jsonfield::number(member(mj, "gain_max", at), at + ".gain_max");
    m.deltaEMean = jsonfield::number(member(mj, "delta_e_mean", at), at + ".delta_e_mean");
    m.deltaEWorst = jsonfield::number(member(mj, "delta_e_worst", at), at + ".delta_e_worst");
    s.modules.push_back(std::move(m));
  }
  return s;
}

}  // namespace

ModuleColourCorrection ModuleColourCorrection::srgbIdentity() {
  ModuleColourCorrection c;
  for (auto& channel : c.response) {
    for (int k = 0; k < 256; ++k)
      channel[static_cast<size_t>(k)] = linearFromSrgb(static_cast<float>(k) / 255.0f);
  }
  return c;
}

float ModuleColourCorrection::gainAt(float u, float v, int width, int height) const {
  // Nodes sit evenly from the first pixel's centre to the last's.
  auto node = [](float p, int size, int nodes) {
    if (nodes < 2 || size < 2) return 0.0f;
    const float t = (p - 0.5f) / static_cast<float>(size - 1) * static_cast<float>(nodes - 1);
    return std::clamp(t, 0.0f, static_cast<float>(nodes - 1));
  };
  const float x = node(u, width, gainWidth), y = node(v, height, gainHeight);
  const int x0 = std::min(static_cast<int>(x), std::max(gainWidth - 2, 0));
  const int y0 = std::min(static_cast<int>(y), std::max(gainHeight - 2, 0));
  const int x1 = std::min(x0 + 1, gainWidth - 1), y1 = std::min(y0 + 1, gainHeight - 1);
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  auto at = [&](int i, int j) {
    return gain[static_cast<size_t>(j) * static_cast<size_t>(gainWidth) + static_cast<size_t>(i)];
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) +
         fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1));
}

void ModuleColourCorrection::validate() const {
  if (!driveFromContent.allFinite()) fail("drive_from_content", "must be finite");
  if (!lift.allFinite()) fail("lift", "must be finite");
  if (!blackDrive.allFinite()) fail("black_drive", "must be finite");
  if (gainWidth < 1 || gainHeight < 1 || gainWidth > kMaxGainNodes || gainHeight > kMaxGainNodes) {
    fail("gain_grid", fmt::format("must be 1..{} nodes a side", kMaxGainNodes));
  }
  if (gain.size() != static_cast<size_t>(gainWidth) * static_cast<size_t>(gainHeight)) {
    fail("gain", "must hold gain_grid[0] x gain_grid[1] nodes");
  }
  for (float g : gain) {
    // Below 1 would dim a pixel the fit found bright enough; above 16 is no falloff a module
    // has (a dead corner), and would only push the drive to its clamp.
    if (!(g >= 1.0f && g <= 16.0f)) fail("gain", fmt::format("nodes must be 1..16, got {}", g));
  }
  for (int c = 0; c < 3; ++c) {
    const auto& r = response[static_cast<size_t>(c)];
    const std::string field = fmt::format("response[{}]", c);
    if (r[0] != 0.0f || r[255] != 1.0f) fail(field, "must start at 0 and end at 1");
    for (int k = 1; k < 256; ++k) {
      if (!(r[static_cast<size_t>(k)] >= r[static_cast<size_t>(k) - 1])) {
        fail(field, fmt::format("must never decrease (code {})", k));
      }
    }
  }
}

void saveColourCorrection(const DisplayColourCorrection& correction, const std::string& path) {
  json j;
  j["format"] = kFormatName;
  j["version"] = kFormatVersion;
  const ColourTarget& t = correction.target;
  j["target"] = {{"red", vectorJson(Eigen::Vector3d(t.primaries.col(0)))},
                 {"green", vectorJson(Eigen::Vector3d(t.primaries.col(1)))},
                 {"blue", vectorJson(Eigen::Vector3d(t.primaries.col(2)))},
                 {"black", vectorJson(t.black)}};
  j["modules"] = json::array();
  for (size_t i = 0; i < correction.modules.size(); ++i) {
    const ModuleColourCorrection& m = correction.modules[i];
    json drive = json::array();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) drive.push_back(m.driveFromContent(r, c));
    json response = json::array();
    for (const auto& channel : m.response) response.push_back(channel);
    j["modules"].push_back({{"index", i},
                            {"drive_from_content", drive},
                            {"lift", vectorJson(m.lift)},
                            {"black_drive", vectorJson(m.blackDrive)},
                            {"gain_grid", {m.gainWidth, m.gainHeight}},
                            {"gain", m.gain},
                            {"response", response}});
  }
  j["geometry"] = correction.geometry;
  j["summary"] = summaryJson(correction.summary);
  j[kChecksumField] = checksumOfDocument(j);
  writeFileAtomically(path, j.dump() + "\n");
}

DisplayColourCorrection loadColourCorrection(const std::string& path) {
  try {
    json j = readJsonFile(path);
    jsonfield::requireFormat(j, kFormatName, kFormatVersion);
    if (j.contains(kChecksumField)) {
      const json& stored = j[kChecksumField];
      if (!stored.is_string() || stored.get<std::string>() != checksumOfDocument(j)) {
        fail(kChecksumField,
             "does not match the content: the file is damaged or was edited (remove the checksum "
             "field to accept a hand edit)");
      }
    }
    DisplayColourCorrection out;
    if (j.contains("geometry")) {
      if (!j["geometry"].is_string()) fail("geometry", "must be a string (a calibration's hash)");
      out.geometry = j["geometry"].get<std::string>();
    }
    const json& target = member(j, "target");
    out.target.primaries.col(0) = vectorFrom(member(target, "red", "target"), "target.red");
    out.target.primaries.col(1) = vectorFrom(member(target, "green", "target"), "target.green");
    out.target.primaries.col(2) = vectorFrom(member(target, "blue", "target"), "target.blue");
    out.target.black = vectorFrom(member(target, "black", "target"), "target.black");
    const json& modules = jsonfield::array(member(j, "modules"), "modules", 4096);
    for (size_t i = 0; i < modules.size(); ++i) {
      const std::string at = fmt::format("modules[{}]", i);
      const json& mj = modules[i];
      if (jsonfield::integer(member(mj, "index", at), at + ".index", 0, 4095) !=
          static_cast<long long>(i)) {
        fail(at + ".index", fmt::format("must be {} (modules in order)", i));
      }
      ModuleColourCorrection m;
      const std::vector<double> drive =
          jsonfield::numbers(member(mj, "drive_from_content", at), at + ".drive_from_content", 9);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          m.driveFromContent(r, c) = static_cast<float>(drive[static_cast<size_t>(3 * r + c)]);
      m.lift = vectorFrom(member(mj, "lift", at), at + ".lift").cast<float>();
      m.blackDrive = vectorFrom(member(mj, "black_drive", at), at + ".black_drive").cast<float>();
      const json& grid = member(mj, "gain_grid", at);
      if (!grid.is_array() || grid.size() != 2) fail(at + ".gain_grid", "must be [width, height]");
      m.gainWidth =
          static_cast<int>(jsonfield::integer(grid[0], at + ".gain_grid[0]", 1, kMaxGainNodes));
      m.gainHeight =
          static_cast<int>(jsonfield::integer(grid[1], at + ".gain_grid[1]", 1, kMaxGainNodes));
      const std::vector<double> gain =
          jsonfield::numbers(member(mj, "gain", at), at + ".gain",
                             static_cast<size_t>(m.gainWidth) * static_cast<size_t>(m.gainHeight));
      m.gain.assign(gain.begin(), gain.end());
      const json& response = member(mj, "response", at);
      if (!response.is_array() || response.size() != 3)
        fail(at + ".response", "must hold 3 channels");
      for (size_t c = 0; c < 3; ++c) {
        const std::vector<double> r =
            jsonfield::numbers(response[c], fmt::format("{}.response[{}]", at, c), 256);
        for (size_t k = 0; k < 256; ++k) m.response[c][k] = static_cast<float>(r[k]);
      }
      try {
        m.validate();
      } catch (const InputError& e) {
        fail(at + "." + e.location().field, e.reason());
      }
      out.modules.push_back(std::move(m));
    }
    if (j.contains("summary")) out.summary = summaryFrom(j["summary"], out.modules.size());
    return out;
  } catch (const InputError& e) {
    throw e.inFile(path);
  }
}

}  // namespace parallax
