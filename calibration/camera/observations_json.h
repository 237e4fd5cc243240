#pragma once
// Files of a calibration capture folder (written by `parallax simulate`, read by
// `parallax calibrate`):
//
//   camera.json   {"format": "parallax-camera", "version": 1,
//                  intrinsics: {width, height, focal_px: [fx, fy], principal_px: [cx, cy],
//                               distortion: [k1, k2],        (conventions.h, centres at +0.5)
//                               covariance: 6 rows of 6}     (optional: the uncertainty of fx,
//                                 fy, cx, cy, k1, k2 as the checkerboard gave it; the fit
//                                 carries it into its σ)
//                                 (in a captures folder with checkerboard pictures, only
//                                  {width, height}: the camera is calibrated from them,
//                                  checkerboard_captures.h)
//                  stations: [{tape_centre: [x, y, z]}]      (m, physical; tape accuracy ~5 cm)
//                  fiducials: [[x, y], ...]}                 (on the screen surface, z = sag(x))
//   decoded.json  {"format": "parallax-decoded", "version": 1,
//                  correspondences: [[camera, module, camera_u, camera_v, module_u, module_v]],
//                  stripes: [[camera, module, camera_u, camera_v]],
//                  fiducial_sightings: [[camera, fiducial, camera_u, camera_v]]}
//
// Both are hostile input: every entry is checked for type, finiteness and range, and errors
// name the file, the field (e.g. "correspondences[12][3]") and, for syntax errors, the line.

#include <nlohmann/json.hpp>
#include <string>

#include "calibration/camera/calibration_observations.h"

namespace parallax {

constexpr const char* kCameraFormatName = "parallax-camera";
constexpr const char* kDecodedFormatName = "parallax-decoded";
constexpr int kObservationsFormatVersion = 1;
constexpr size_t kMaxObservations = 20'000'000;

nlohmann::json cameraMetadataToJson(const CalibrationObservations& observations);
nlohmann::json decodedToJson(const CalibrationObservations& observations);
// Fill the camera part / the decoded part of `observations`. With `intrinsicsKnown` given, an
// intrinsics block of only {width, height} is accepted (*intrinsicsKnown = false; fx, fy, cx,
// cy are then NaN until the checkerboard calibration fills them); without it, focal_px,
// principal_px and distortion are required.
void cameraMetadataFromJson(const nlohmann::json& json, CalibrationObservations* observations,
                            bool* intrinsicsKnown = nullptr);
void decodedFromJson(const nlohmann::json& json, CalibrationObservations* observations);

// Reads DIR/camera.json and DIR/decoded.json.
CalibrationObservations loadObservations(const std::string& directory);
// Writes both atomically (temporary file, then rename).
void saveObservations(const CalibrationObservations& observations, const std::string& directory);

}  // namespace parallax
