#pragma once
// Colour science the photometric calibration reports in: CIE xy chromaticity and CIELAB of
// linear RGB with sRGB primaries (D65), and the CIEDE2000 colour difference.

#include <Eigen/Core>

namespace parallax {

// CIE XYZ of linear sRGB-primaries RGB (Y = luminance, white (1, 1, 1) has Y = 1).
Eigen::Vector3d xyzFromLinearSrgb(const Eigen::Vector3d& rgb);
double luminance(const Eigen::Vector3d& rgb);
// CIE 1931 xy; (0, 0) for black.
Eigen::Vector2d chromaticity(const Eigen::Vector3d& rgb);
// CIELAB relative to `white` (linear RGB, its own L* = 100).
Eigen::Vector3d labFromLinearSrgb(const Eigen::Vector3d& rgb, const Eigen::Vector3d& white);
// CIEDE2000 (kL = kC = kH = 1), Sharma, Wu and Dalal's formulation.
double ciede2000(const Eigen::Vector3d& lab1, const Eigen::Vector3d& lab2);

}  // namespace parallax
