#pragma once
// The photometric correction a display applies to every module frame, in the form the encode
// step uses (tracer/module_encoder.h); calibration/photometry fits it from flat-field pictures.
//
// Content is linear RGB in the display's target colour space: (1, 1, 1) is the target white at
// the target brightness, (0, 0, 0) the target black. For module pixel (u, v) the drive of the
// module's three channels (each 0..1, linear in its light before the mixing) is
//
//   drive = clamp((driveFromContent · content + lift) · gain(u, v) − blackDrive, 0, 1)
//
// and the 8-bit code of each channel is the code whose light on the module's response curve is
// nearest that drive. gain(u, v) ≥ 1 undoes the module's spatial falloff (vignetting), bilinear
// between the nodes of a low-resolution grid spread evenly over the image.
//
// JSON (photometry.json, beside the geometric calibration):
//   {"format": "parallax-photometry", "version": 1, "target": {...figures...},
//    "geometry": "<hash of the geometric calibration it was fitted with>",
//    "modules": [{"index": i, "drive_from_content": [9 numbers, row-major], "lift": [3],
//                 "black_drive": [3], "gain_grid": [gw, gh], "gain": [gw·gh numbers, row-major],
//                 "response": [[256 numbers] × 3]}],
//    "summary": {...what the calibration measured, for `status`...},
//    "checksum": "fnv1a64:..."}
// The checksum (as the calibration files', delete it to accept a hand edit) and the geometry
// hash let the calibration store refuse a damaged file, or one that belongs to another
// geometric calibration, instead of applying it.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace parallax {

struct ModuleColourCorrection {
  Eigen::Matrix3f driveFromContent = Eigen::Matrix3f::Identity();
  Eigen::Vector3f lift = Eigen::Vector3f::Zero();
  Eigen::Vector3f blackDrive = Eigen::Vector3f::Zero();
  int gainWidth = 1, gainHeight = 1;  // grid nodes
  std::vector<float> gain{1.0f};      // row-major, gainWidth × gainHeight, each in [1, 16]
  // Per channel, the light (0..1 of that channel's full drive) of each 8-bit code: starts at 0,
  // ends at 1, never decreasing.
  std::array<std::array<float, 256>, 3> response{};

  // A correction that changes nothing but the transfer: the response of an ideal sRGB module
  // (its codes are the sRGB encoding) and identity everything else.
  static ModuleColourCorrection srgbIdentity();

  // Gain at a continuous pixel position (centres at +0.5) of a width × height module image.
  float gainAt(float u, float v, int width, int height) const;

  // Throws InputError naming the field.
  void validate() const;
};

// What the calibration aimed for, kept for the report and for the ideal display the tests
// compare against: the target's primaries and black as light in the reference space (linear
// RGB with sRGB primaries; the light of content c is black + primaries · c).
struct ColourTarget {
  Eigen::Matrix3d primaries = Eigen::Matrix3d::Identity();  // columns: red, green, blue at 1
  Eigen::Vector3d black = Eigen::Vector3d::Zero();
};

// What the photometric calibration found, per module and for the display, kept with the
// correction for `status` and the report. ΔE is CIEDE2000 against the target's colour, the
// non-uniformity (brightest − darkest) / mean luminance; both from the flat-field pictures
// (photometry/photometric_residual.h).
struct ModulePhotometricSummary {
  bool excluded = false;
  std::string reason;       // why it was excluded
  double scale = 1.0;       // the target's white over the module's own (< 1: dimmed to match)
  double gainMax = 1.0;     // the largest node of its gain map (vignetting made up for)
  double deltaEMean = 0.0;  // a flat grey through the correction, over its image
  double deltaEWorst = 0.0;
};

struct PhotometricSummary {
  double deltaEMean = 0.0, deltaEWorst = 0.0;  // over every included module
  double nonUniformity = 0.0;
  std::vector<ModulePhotometricSummary> modules;  // per module index (empty: none recorded)
};

struct DisplayColourCorrection {
  ColourTarget target;
  std::vector<ModuleColourCorrection> modules;  // per module index
  std::string geometry;  // the geometric calibration's content hash ("": not recorded)
  PhotometricSummary summary;
};

void saveColourCorrection(const DisplayColourCorrection& correction, const std::string& path);
// Throws InputError naming the file and the field.
DisplayColourCorrection loadColourCorrection(const std::string& path);

}  // namespace parallax
