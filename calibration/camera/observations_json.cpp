#include "calibration/camera/observations_json.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "calibration/display/json_fields.h"
#include "calibration/display/json_file.h"
#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax {
namespace {

using jsonfield::fail;
using jsonfield::member;
using jsonfield::number;
using jsonfield::numbers;
using nlohmann::json;

int index(const json& j, const std::string& field, int limit) {
  if (!j.is_number_integer()) fail(field, fmt::format("must be an integer, got {}", j.type_name()));
  const long long v = j.get<long long>();
  if (v < 0 || v >= limit) fail(field, fmt::format("must be 0..{}, got {}", limit - 1, v));
  return static_cast<int>(v);
}

const json& rows(const json& object, const std::string& key) {
  return jsonfield::array(member(object, key, ""), key, kMaxObservations);
}

// Module and camera indices are bounded generously here; the fit checks them against the
// nominal model and the stations.
constexpr int kMaxIndex = 1 << 20;

}  // namespace

json cameraMetadataToJson(const CalibrationObservations& o) {
  json j;
  j["format"] = kCameraFormatName;
  j["version"] = kObservationsFormatVersion;
  const CameraIntrinsics& in = o.intrinsics;
  j["intrinsics"] = {{"width", in.width},
                     {"height", in.height},
                     {"focal_px", {in.fx, in.fy}},
                     {"principal_px", {in.cx, in.cy}},
                     {"distortion", {in.k1, in.k2}}};
  if (!o.intrinsicsCovariance.isZero()) {
    json rowsOut = json::array();
    for (int r = 0; r < kIntrinsicsParameters; ++r) {
      json row = json::array();
      for (int c = 0; c < kIntrinsicsParameters; ++c) row.push_back(o.intrinsicsCovariance(r, c));
      rowsOut.push_back(row);
    }
    j["intrinsics"]["covariance"] = rowsOut;
  }
  j["stations"] = json::array();
  for (const CameraStation& s : o.stations) {
    j["stations"].push_back(
        {{"tape_centre", {s.tapeCentre.x(), s.tapeCentre.y(), s.tapeCentre.z()}}});
  }
  j["fiducials"] = json::array();
  for (const Eigen::Vector2d& f : o.fiducials) j["fiducials"].push_back({f.x(), f.y()});
  return j;
}

json decodedToJson(const CalibrationObservations& o) {
  json j;
  j["format"] = kDecodedFormatName;
  j["version"] = kObservationsFormatVersion;
  j["correspondences"] = json::array();
  for (const Correspondence& c : o.correspondences) {
    j["correspondences"].push_back(
        {c.camera, c.module, c.cameraPx.x(), c.cameraPx.y(), c.modulePx.x(), c.modulePx.y()});
  }
  j["stripes"] = json::array();
  for (const StripeCentre& s : o.stripes) {
    j["stripes"].push_back({s.camera, s.module, s.cameraPx.x(), s.cameraPx.y()});
  }
  j["fiducial_sightings"] = json::array();
  for (const FiducialSighting& f : o.fiducialSightings) {
    j["fiducial_sightings"].push_back({f.camera, f.fiducial, f.cameraPx.x(), f.cameraPx.y()});
  }
  return j;
}

namespace {

void intrinsicsFromJson(const json& in, CalibrationObservations* o) {
  const auto focal = numbers(member(in, "focal_px", "intrinsics"), "intrinsics.focal_px", 2);
  const auto principal =
      numbers(member(in, "principal_px", "intrinsics"), "intrinsics.principal_px", 2);
  const auto distortion =
      numbers(member(in, "distortion", "intrinsics"), "intrinsics.distortion", 2);
  if (!(focal[0] > 0.0 && focal[1] > 0.0)) fail("intrinsics.focal_px", "must be positive");
  o->intrinsics.fx = focal[0];
  o->intrinsics.fy = focal[1];
  o->intrinsics.cx = principal[0];
  o->intrinsics.cy = principal[1];
  o->intrinsics.k1 = distortion[0];
  o->intrinsics.k2 = distortion[1];
  if (std::abs(o->intrinsics.k1) > 1.0 || std::abs(o->intrinsics.k2) > 1.0) {
    fail("intrinsics.distortion", "|k1|, |k2| must be <= 1 (a calibration camera, not a fisheye)");
  }
  o->intrinsicsCovariance.setZero();
  if (!in.contains("covariance")) return;
  // Optional: the intrinsics' uncertainty (fx, fy, cx, cy, k1, k2), as the checkerboard gave it.
  const json& rowsIn = jsonfield::array(in["covariance"], "intrinsics.covariance", 6);
  if (rowsIn.size() != kIntrinsicsParameters)
    fail("intrinsics.covariance", "must be 6 rows (fx, fy, cx, cy, k1, k2) of 6 numbers");
  for (int r = 0; r < kIntrinsicsParameters; ++r) {
    const auto row = numbers(rowsIn[static_cast<size_t>(r)],
                             fmt::format("intrinsics.covariance[{}]", r), kIntrinsicsParameters);
    for (int c = 0; c < kIntrinsicsParameters; ++c)
      o->intrinsicsCovariance(r, c) = row[static_cast<size_t>(c)];
  }
  const IntrinsicsCovariance& cov = o->intrinsicsCovariance;
  // A covariance: symmetric, its variances not negative, no correlation beyond ±1.
  for (int r = 0; r < kIntrinsicsParameters; ++r) {
    if (!(cov(r, r) >= 0.0))
      fail(fmt::format("intrinsics.covariance[{}][{}]", r, r), "a variance must be >= 0");
    for (int c = 0; c < r; ++c) {
      const double scale = std::sqrt(cov(r, r) * cov(c, c));
      if (std::abs(cov(r, c) - cov(c, r)) > 1e-9 * std::max(scale, 1e-300) ||
          std::abs(cov(r, c)) > scale * (1.0 + 1e-9)) {
        fail(fmt::format("intrinsics.covariance[{}][{}]", r, c),
             "must be symmetric, each correlation within ±1");
      }
    }
  }
}

void stationsFromJson(const json& j, CalibrationObservations* o) {
  const json& stations = rows(j, "stations");
  if (stations.empty() || stations.size() > 64) fail("stations", "must hold 1..64 stations");
  o->stations.clear();
  for (size_t i = 0; i < stations.size(); ++i) {
    const std::string field = fmt::format("stations[{}].tape_centre", i);
    const auto c =
        numbers(member(stations[i], "tape_centre", fmt::format("stations[{}]", i)), field, 3);
    o->stations.push_back({{c[0], c[1], c[2]}});
  }
  const json& fiducials = rows(j, "fiducials");
  o->fiducials.clear();
  for (size_t i = 0; i < fiducials.size(); ++i) {
    const auto f = numbers(fiducials[i], fmt::format("fiducials[{}]", i), 2);
    o->fiducials.push_back({f[0], f[1]});
  }
}

}  // namespace

void cameraMetadataFromJson(const json& j, CalibrationObservations* o, bool* intrinsicsKnown) {
  jsonfield::requireFormat(j, kCameraFormatName, kObservationsFormatVersion);
  const json& in = member(j, "intrinsics", "");
  const json& width = member(in, "width", "intrinsics");
  const json& height = member(in, "height", "intrinsics");
  o->intrinsics.width = index(width, "intrinsics.width", 65536);
  o->intrinsics.height = index(height, "intrinsics.height", 65536);
  if (o->intrinsics.width < 16 || o->intrinsics.height < 16)
    fail("intrinsics", "the image must be at least 16 px a side");
  // The picture size alone: the intrinsics come from the checkerboard pictures.
  const bool sizeOnly = in.is_object() && !in.contains("focal_px") &&
                        !in.contains("principal_px") && !in.contains("distortion");
  if (intrinsicsKnown) *intrinsicsKnown = !sizeOnly;
  if (sizeOnly && intrinsicsKnown) {
    // Not a camera yet: NaN, never a plausible default (decodeCaptures refuses unknown intrinsics).
    const double unknown = std::numeric_limits<double>::quiet_NaN();
    o->intrinsics = CameraIntrinsics{
        o->intrinsics.width, o->intrinsics.height, unknown, unknown, unknown, unknown, 0.0, 0.0};
  } else {
    intrinsicsFromJson(in, o);
  }
  stationsFromJson(j, o);
}

void decodedFromJson(const json& j, CalibrationObservations* o) {
  jsonfield::requireFormat(j, kDecodedFormatName, kObservationsFormatVersion);
  const json& corr = rows(j, "correspondences");
  o->correspondences.clear();
  o->correspondences.reserve(corr.size());
  for (size_t i = 0; i < corr.size(); ++i) {
    const std::string field = fmt::format("correspondences[{}]", i);
    const json& r = corr[i];
    if (!r.is_array() || r.size() != 6)
      fail(field, "must be [camera, module, camera_u, camera_v, module_u, module_v]");
    Correspondence c;
    c.camera = index(r[0], field + "[0]", kMaxIndex);
    c.module = index(r[1], field + "[1]", kMaxIndex);
    c.cameraPx = {number(r[2], field + "[2]"), number(r[3], field + "[3]")};
    c.modulePx = {number(r[4], field + "[4]"), number(r[5], field + "[5]")};
    o->correspondences.push_back(c);
  }
  const json& stripes = rows(j, "stripes");
  o->stripes.clear();
  for (size_t i = 0; i < stripes.size(); ++i) {
    const std::string field = fmt::format("stripes[{}]", i);
    const json& r = stripes[i];
    if (!r.is_array() || r.size() != 4) fail(field, "must be [camera, module, camera_u, camera_v]");
    o->stripes.push_back({index(r[0], field + "[0]", kMaxIndex),
                          index(r[1], field + "[1]", kMaxIndex),
                          {number(r[2], field + "[2]"), number(r[3], field + "[3]")}});
  }
  const json& sightings = rows(j, "fiducial_sightings");
  o->fiducialSightings.clear();
  for (size_t i = 0; i < sightings.size(); ++i) {
    const std::string field = fmt::format("fiducial_sightings[{}]", i);
    const json& r = sightings[i];
    if (!r.is_array() || r.size() != 4)
      fail(field, "must be [camera, fiducial, camera_u, camera_v]");
    o->fiducialSightings.push_back({index(r[0], field + "[0]", kMaxIndex),
                                    index(r[1], field + "[1]", kMaxIndex),
                                    {number(r[2], field + "[2]"), number(r[3], field + "[3]")}});
  }
}

CalibrationObservations loadObservations(const std::string& directory) {
  CalibrationObservations o;
  const std::string cameraPath = directory + "/camera.json";
  const std::string decodedPath = directory + "/decoded.json";
  try {
    cameraMetadataFromJson(readJsonFile(cameraPath), &o);
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(cameraPath) : e;
  }
  try {
    decodedFromJson(readJsonFile(decodedPath), &o);
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(decodedPath) : e;
  }
  return o;
}

void saveObservations(const CalibrationObservations& o, const std::string& directory) {
  writeFileAtomically(directory + "/camera.json", cameraMetadataToJson(o).dump(2) + "\n");
  writeFileAtomically(directory + "/decoded.json", decodedToJson(o).dump() + "\n");
}

}  // namespace parallax
