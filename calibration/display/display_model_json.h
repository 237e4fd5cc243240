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
//   checksum: "fnv1a64:..." (written by saveDisplayModel, verified by loadDisplayModel when
//             present: a damaged calibration is refused, never used; hand-written files omit it)
// Conventions: calibration/display/conventions.h. Doubles are written shortest-round-trip, so
// save → load is exact.

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>

#include "calibration/display/display_model.h"

namespace parallax {

constexpr const char* kDisplayFormatName = "parallax-display";
constexpr int kDisplayFormatVersion = 1;
constexpr const char* kDisplayChecksumField = "checksum";
// A display of kMaxModules modules is well under 1 MiB of JSON.
constexpr size_t kMaxDisplayFileBytes = size_t{16} << 20;

nlohmann::json displayModelToJson(const DisplayModel& model);
// Throws InputError naming the field (and validates the model).
DisplayModel displayModelFromJson(const nlohmann::json& json);

// Throws InputError naming the file, and the line for syntax errors; a file that is not a
// regular file (a folder, a FIFO, /dev/zero) or is over kMaxDisplayFileBytes is refused
// before it is read.
DisplayModel loadDisplayModel(const std::string& path);
// Writes with its checksum, atomically and durably (common/atomic_file.h); throws InputError
// when the file cannot be written (a full disk), leaving the old file as it was.
void saveDisplayModel(const DisplayModel& model, const std::string& path);

}  // namespace parallax
