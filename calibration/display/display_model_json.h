#pragma once
// The DisplayModel's JSON form: {"format": "parallax-display", "version": 1, ...}.
//
//   screen:   {width, height (m), curvature (1/m), transfer: "conical"|"linear", diffusion_deg}
//   observer: {y, z (m)}
//   displayable_box: {min: [x,y,z], max: [x,y,z]} (m, physical)
//   modules:  [{id, position: [x,y,z] (m), orientation: [w,x,y,z] (physicalFromModule),
//               focal_px: [fx,fy], principal_px: [cx,cy] (pixel centres at +0.5),
//               distortion: [k1,k2] (OpenCV radial, projection direction),
//               resolution: [width,height], mirror: bool}]
// Conventions: calibration/display/conventions.h. Doubles are written shortest-round-trip, so
// save → load is exact.

#include <nlohmann/json.hpp>
#include <string>

#include "calibration/display/display_model.h"

namespace parallax {

constexpr const char* kDisplayFormatName = "parallax-display";
constexpr int kDisplayFormatVersion = 1;

nlohmann::json displayModelToJson(const DisplayModel& model);
// Throws InputError naming the field (and validates the model).
DisplayModel displayModelFromJson(const nlohmann::json& json);

// Throws InputError naming the file, and the line for syntax errors.
DisplayModel loadDisplayModel(const std::string& path);
// Writes atomically: a temporary file beside the target, then rename.
void saveDisplayModel(const DisplayModel& model, const std::string& path);

}  // namespace parallax
