#pragma once
// Every geometric convention of Parallax, stated once. The JSON format (display_model_json.h)
// and the README refer here.
//
// Physical space: meters, right-handed, origin at the screen centre, x to the viewers' right,
// y up, z toward the viewers. Optical modules sit behind the screen (z < 0), viewers in front.
//
// Screen: a vertical cylinder section with chord W (its x extent) and height H, described by
// its curvature k = 1/R (1/m). The surface is z(x) = k x² / (1 + sqrt(1 − k² x²)), the
// cancellation-free form of R − sqrt(R² − x²). k > 0 brings the edges toward the viewers
// (concave to them); k = 0 is flat and an ordinary value. Valid only while |k|·W/2 < 1.
//
// Module frame (the OpenCV camera frame): x along increasing pixel column u, y along increasing
// row v (down), z the optical axis (forward). Orientation is the unit quaternion
// physicalFromModule, stored as [w, x, y, z] (Hamilton, active: p_phys = q · p_mod · q*).
// A module at the screen's height looking straight at it, upright, has q = [0, 0, 0, 1]
// (a half turn about z): its columns then run toward −x as seen from behind.
//
// Mirror flag: a rear projector is seen from the front mirrored, which no rotation expresses.
// With mirror = true the module-frame ray of a pixel is reflected in the module's y–z plane
// (x → −x) after undistortion, so a mirrored, upright module shows column u increasing toward
// the viewers' right (+x) and row v toward −y: its frames read like what a viewer sees.
//
// Pixels: pixel (i, j) covers [i, i+1) × [j, j+1) and its centre is (i + 0.5, j + 0.5); u is
// the column, v the row, v grows downward. Principal points (cx, cy) use the same continuous
// coordinates. OpenCV puts pixel centres on integers: convert only through the two functions
// below, at the boundary with OpenCV.
//
// Distortion (OpenCV's radial model, applied in the projection direction): a module-frame
// direction (X, Y, Z), Z > 0, gives undistorted normalized coordinates (x, y) = (X/Z, Y/Z),
// r² = x² + y², distorted (x, y)·(1 + k1 r² + k2 r⁴), pixel (fx·xd + cx, fy·yd + cy).
// A pixel → ray inverts that radially. Beyond the radius where r·(1 + k1 r² + k2 r⁴) stops
// increasing the model folds over; pixels there are masked.
//
// Observer line: y = y_obs, z = z_obs (> 0), parallel to x.
// Primary ray of a pixel: origin o on the observer line, through screen point s (ray_function.h).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

namespace parallax {

// Angles are degrees in files, options and reports, radians in the code.
inline constexpr double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }
inline constexpr double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }
// The screen's diffusion_deg is the lobe's full width at half maximum; its Gaussian σ (rad) is
// that over 2·sqrt(2·ln 2).
inline double diffusionSigma(double diffusionDeg) {
  return radians(diffusionDeg) / (2.0 * std::sqrt(2.0 * std::numbers::ln2));
}

// OpenCV pixel coordinates (centres on integers) → ours (centres on half integers).
inline Eigen::Vector2d pixelFromOpenCv(const Eigen::Vector2d& opencv) {
  return opencv + Eigen::Vector2d(0.5, 0.5);
}
inline Eigen::Vector2d openCvFromPixel(const Eigen::Vector2d& pixel) {
  return pixel - Eigen::Vector2d(0.5, 0.5);
}

// physicalFromDevice of an upright module or camera at `from` whose optical axis points at
// `target` (device frame as above: x right, y down, z forward; "upright": its y axis is as close
// to physical −y as the axis allows).
inline Eigen::Quaterniond uprightLookingAt(const Eigen::Vector3d& from,
                                           const Eigen::Vector3d& target) {
  const Eigen::Vector3d forward = (target - from).normalized();
  const Eigen::Vector3d down(0.0, -1.0, 0.0);
  const Eigen::Vector3d downOrtho = (down - down.dot(forward) * forward).normalized();
  const Eigen::Vector3d right = downOrtho.cross(forward);
  Eigen::Matrix3d physicalFromDevice;
  physicalFromDevice << right, downOrtho, forward;
  return Eigen::Quaterniond(physicalFromDevice).normalized();
}

}  // namespace parallax
