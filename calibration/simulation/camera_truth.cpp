#include "calibration/simulation/camera_truth.h"

#include <fmt/format.h>

#include <cmath>

#include "calibration/camera/observations_json.h"
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
constexpr const char* kFormatName = "parallax-camera-truth";
constexpr int kFormatVersion = 1;

}  // namespace

void saveCameraTruth(const CameraTruth& truth, const std::string& path) {
  CalibrationObservations frame;
  frame.intrinsics = truth.intrinsics;
  json j;
  j["format"] = kFormatName;
  j["version"] = kFormatVersion;
  j["seed"] = truth.seed;
  j["intrinsics"] = cameraMetadataToJson(frame)["intrinsics"];
  j["poses"] = json::array();
  for (const CameraPose& p : truth.poses) {
    const Eigen::Quaterniond& q = p.physicalFromCamera;
    j["poses"].push_back({{"centre", {p.centre.x(), p.centre.y(), p.centre.z()}},
                          {"physical_from_camera", {q.w(), q.x(), q.y(), q.z()}}});
  }
  const CameraRenderOptions& s = truth.sensor;
  j["sensor"] = {{"ambient", s.ambient},
                 {"gamma", s.gamma},
                 {"noise_sigma", s.noiseSigma},
                 {"blur_sigma_px", s.blurSigmaPx},
                 {"fiducial_radius_m", s.fiducialRadiusM},
                 {"fiducial_brightness", s.fiducialBrightness}};
  writeFileAtomically(path, j.dump(2) + "\n");
}

CameraTruth loadCameraTruth(const std::string& path) {
  try {
    const json j = readJsonFile(path);
    jsonfield::requireFormat(j, kFormatName, kFormatVersion);
    CameraTruth truth;
    const json& seed = member(j, "seed", "");
    if (!seed.is_number_unsigned()) fail("seed", "must be a non-negative integer");
    truth.seed = seed.get<std::uint64_t>();
    // The intrinsics block is camera.json's: reuse its checks.
    json camera{{"format", kCameraFormatName},
                {"version", kObservationsFormatVersion},
                {"intrinsics", member(j, "intrinsics", "")},
                {"stations", json::array({{{"tape_centre", {0, 0, 0}}}})},
                {"fiducials", json::array()}};
    CalibrationObservations frame;
    cameraMetadataFromJson(camera, &frame);
    truth.intrinsics = frame.intrinsics;
    const json& poses = member(j, "poses", "");
    if (!poses.is_array() || poses.empty() || poses.size() > 64)
      fail("poses", "must hold 1..64 poses");
    for (size_t i = 0; i < poses.size(); ++i) {
      const std::string field = fmt::format("poses[{}]", i);
      const auto c = numbers(member(poses[i], "centre", field), field + ".centre", 3);
      const auto q = numbers(member(poses[i], "physical_from_camera", field),
                             field + ".physical_from_camera", 4);
      const Eigen::Quaterniond rotation(q[0], q[1], q[2], q[3]);
      if (!(std::abs(rotation.norm() - 1.0) < 1e-6))
        fail(field + ".physical_from_camera", "must be a unit quaternion [w, x, y, z]");
      CameraPose pose;
      pose.centre = {c[0], c[1], c[2]};
      pose.physicalFromCamera = rotation.normalized();
      truth.poses.push_back(pose);
    }
    const json& sensor = member(j, "sensor", "");
    CameraRenderOptions& s = truth.sensor;
    s.ambient = number(member(sensor, "ambient", "sensor"), "sensor.ambient");
    s.gamma = number(member(sensor, "gamma", "sensor"), "sensor.gamma");
    s.noiseSigma = number(member(sensor, "noise_sigma", "sensor"), "sensor.noise_sigma");
    s.blurSigmaPx = number(member(sensor, "blur_sigma_px", "sensor"), "sensor.blur_sigma_px");
    s.fiducialRadiusM =
        number(member(sensor, "fiducial_radius_m", "sensor"), "sensor.fiducial_radius_m");
    s.fiducialBrightness =
        number(member(sensor, "fiducial_brightness", "sensor"), "sensor.fiducial_brightness");
    try {
      s.validate();
    } catch (const InputError& e) {
      fail("sensor." + e.location().field, e.reason());
    }
    return truth;
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(path) : e;
  }
}

}  // namespace parallax
