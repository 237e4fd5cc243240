#pragma once
// The geometry of calibration, templated so Ceres can differentiate it in the fit while the
// decoder and the simulator use it with doubles, and the packing of modules and cameras into
// the fit's parameter blocks. Each function mirrors a double
// version of the foundation (Screen::intersect, ModuleOptics::project, the screen transfers);
// tests/calibration/calibration_geometry_test.cpp holds them to agreement.
//
// Parameter blocks (units chosen so a 1% change of any entry moves a pixel by a similar amount):
//   module (13): [0..3] physicalFromModule quaternion in Eigen's memory order (x, y, z, w),
//                [4..6] position (m), [7..10] fx, fy, cx, cy divided by the module width,
//                [11..12] k1, k2.
//   camera (7):  [0..3] physicalFromCamera quaternion (x, y, z, w), [4..6] centre (m).
//   screen (1):  the curvature k (1/m); k = 0 is an ordinary value.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>

#include "calibration/camera/calibration_camera.h"
#include "calibration/display/optical_module.h"
#include "calibration/display/screen.h"

namespace parallax {

constexpr int kModuleBlockSize = 13;
constexpr int kModuleTangentSize = 12;
constexpr int kCameraBlockSize = 7;
constexpr int kCameraTangentSize = 6;

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

// The value of a double or of a Ceres Jet (whose value member is `a`), without derivatives.
// Generic so that this header needs no Ceres: only the fit instantiates it with Jets.
inline double valueOf(double v) { return v; }
template <typename Jet>
double valueOf(const Jet& v) {
  return v.a;
}

// The camera ray through undistorted normalized coordinates (nx, ny) meets the screen
// k (x² + z²) − 2 z = 0 (Screen::intersect's form, exact at k = 0): a t² + b t + c = 0. The
// screen's branch is the root (−b + √disc) / (2a), the one that tends to the plane's −c/b as
// k → 0: for k > 0 the camera may stand inside the cylinder (one forward root) or outside it
// (the ray crosses the far side first and leaves through the screen: the larger root); for
// k < 0 it is the first crossing. Written as −2c / (b + √disc) when b > 0, so that neither
// form ever subtracts nearly equal numbers.
template <typename T>
bool screenPointOfCameraRay(const T& k, const T* camera, double nx, double ny, Vec3<T>* s) {
  using std::sqrt;
  const Eigen::Map<const Eigen::Quaternion<T>> physicalFromCamera(camera);
  const Vec3<T> c(camera[4], camera[5], camera[6]);
  const Vec3<T> d = physicalFromCamera * Vec3<T>(T(nx), T(ny), T(1));
  const T a = k * (d.x() * d.x() + d.z() * d.z());
  const T b = T(2) * (k * (c.x() * d.x() + c.z() * d.z()) - d.z());
  const T cc = k * (c.x() * c.x() + c.z() * c.z()) - T(2) * c.z();
  const T disc = b * b - T(4) * a * cc;
  if (!(disc >= T(0))) return false;
  T t;
  if (b > T(0)) {
    t = T(-2) * cc / (b + sqrt(disc));
  } else if (a != T(0)) {
    t = (-b + sqrt(disc)) / (T(2) * a);
  } else {
    return false;  // flat screen and a ray running away from it
  }
  if (!(t > T(0))) return false;
  *s = c + t * d;
  // The screen is the branch through the origin (k z < 1), not the far side of the circle.
  if (!(k * s->z() < T(1))) return false;
  return true;
}

// Pixel (u, v) of screen point s in a module (ModuleOptics::project without the fold test: the
// fit never needs the mask, and the polynomial is smooth through it).
template <typename T>
bool projectIntoModule(const T* module, double width, double mirrorSign, const Vec3<T>& s, T* uv) {
  const Eigen::Map<const Eigen::Quaternion<T>> physicalFromModule(module);
  const Vec3<T> p(module[4], module[5], module[6]);
  const Vec3<T> local = physicalFromModule.conjugate() * (s - p);
  if (!(local.z() > T(0))) return false;
  const T x = T(mirrorSign) * local.x() / local.z();
  const T y = local.y() / local.z();
  const T r2 = x * x + y * y;
  const T scale = T(1) + module[11] * r2 + module[12] * r2 * r2;
  uv[0] = T(width) * (module[7] * x * scale + module[9]);
  uv[1] = T(width) * (module[8] * y * scale + module[10]);
  return true;
}

// The screen point that module pixel (u, v) lights: projectIntoModule inverted (the radial
// polynomial by fixed-point iteration — a contraction for projector-lens distortion, |k1| r²
// well below 1/3 — then the module ray) met with the screen k (x² + z²) − 2 z = 0. Of the two
// roots (computed without cancellation) the nearest forward one on the screen's branch
// (k z < 1). The correspondence residual in camera pixels starts here: the camera pixel,
// where the noise is, stays on the measured side.
template <typename T>
bool screenPointOfModulePixel(const T* module, double width, double mirrorSign, const T& k,
                              double u, double v, Vec3<T>* s) {
  using std::sqrt;
  const T xd = (T(u / width) - module[9]) / module[7];
  const T yd = (T(v / width) - module[10]) / module[8];
  // Undistortion as a ratio: (x, y) = ρ (xd, yd) with F(ρ) = ρ (1 + k1 ρ² q + k2 ρ⁴ q²) − 1 = 0,
  // q = xd² + yd² (`q2`) (no square root: smooth at the centre). ρ is iterated on plain values,
  // then one Newton step is taken in T: at the root it carries the exact derivatives (implicit
  // function theorem), where iterating in T would cost ten times the Jet arithmetic (most of
  // the camera-px residual's time).
  const T q2 = xd * xd + yd * yd;
  const double qValue = valueOf(q2), k1Value = valueOf(module[11]), k2Value = valueOf(module[12]);
  double rho = 1.0;
  for (int i = 0; i < 10; ++i) {
    const double r2 = rho * rho * qValue;
    rho = 1.0 / (1.0 + k1Value * r2 + k2Value * r2 * r2);
  }
  const double rho2 = rho * rho;
  const T residual =
      rho * (T(1) + module[11] * (rho2 * q2) + module[12] * (rho2 * rho2 * q2 * q2)) - T(1);
  const T slope =
      T(1) + T(3) * module[11] * (rho2 * q2) + T(5) * module[12] * (rho2 * rho2 * q2 * q2);
  const T ratio = T(rho) - residual / slope;
  const T x = xd * ratio, y = yd * ratio;
  const Eigen::Map<const Eigen::Quaternion<T>> physicalFromModule(module);
  const Vec3<T> p(module[4], module[5], module[6]);
  const Vec3<T> d = physicalFromModule * Vec3<T>(T(mirrorSign) * x, y, T(1));
  const T a = k * (d.x() * d.x() + d.z() * d.z());
  const T b = T(2) * (k * (p.x() * d.x() + p.z() * d.z()) - d.z());
  const T c = k * (p.x() * p.x() + p.z() * p.z()) - T(2) * p.z();
  const T disc = b * b - T(4) * a * c;
  if (!(disc >= T(0))) return false;
  const T q = b < T(0) ? T(-0.5) * (b - sqrt(disc)) : T(-0.5) * (b + sqrt(disc));
  if (q == T(0)) return false;
  T roots[2] = {c / q, a != T(0) ? q / a : T(-1)};
  if (roots[1] < roots[0]) std::swap(roots[0], roots[1]);
  for (const T& t : roots) {
    if (!(t > T(0))) continue;
    const Vec3<T> hit = p + t * d;
    if (k * hit.z() < T(1)) {
      *s = hit;
      return true;
    }
  }
  return false;
}

// Pixel of physical point p in a camera with fixed intrinsics.
template <typename T>
bool projectIntoCamera(const CameraIntrinsics& in, const T* camera, const Vec3<T>& p, T* px) {
  const Eigen::Map<const Eigen::Quaternion<T>> physicalFromCamera(camera);
  const Vec3<T> c(camera[4], camera[5], camera[6]);
  const Vec3<T> q = physicalFromCamera.conjugate() * (p - c);
  if (!(q.z() > T(0))) return false;
  const T x = q.x() / q.z();
  const T y = q.y() / q.z();
  const T r2 = x * x + y * y;
  const T scale = T(1) + T(in.k1) * r2 + T(in.k2) * r2 * r2;
  px[0] = T(in.fx) * x * scale + T(in.cx);
  px[1] = T(in.fy) * y * scale + T(in.cy);
  return true;
}

// How far (m, along the screen) screen point s is from the centre of module p's stripe as
// seen from camera centre c. The screen sends module light arriving along d = (s − p)/|s − p|
// toward e = (c − s)/|c − s| only if the transfer maps one to the other:
//   conical: asin(e·t) = asin(d·t), t the horizontal tangent at s;
//   linear:  the top-view angles atan2(x, z) of e and d agree.
// The angle mismatch θ is turned into a distance on the screen by the lever of a top-view
// pinhole pair, 1 / (1/|c − s| + 1/|s − p|) (horizontal distances): moving s sideways by δ
// turns e and d by δ/|c − s| and δ/|s − p| in opposite senses. This gives the stripe residual
// the units of the correspondences' screen error, so one noise level serves both.
template <typename T>
T stripeMismatch(ScreenTransfer transfer, const T& k, const Vec3<T>& s, const Vec3<T>& p,
                 const Vec3<T>& c) {
  using std::asin;
  using std::atan2;
  using std::sqrt;
  const Vec3<T> toModule = s - p;
  const Vec3<T> toCamera = c - s;
  T theta;
  if (transfer == ScreenTransfer::kConical) {
    const T kx = k * s.x();
    const Vec3<T> t(sqrt(T(1) - kx * kx), T(0), kx);
    theta = asin(toCamera.dot(t) / toCamera.norm()) - asin(toModule.dot(t) / toModule.norm());
  } else {
    theta = atan2(toCamera.x(), toCamera.z()) - atan2(toModule.x(), toModule.z());
  }
  const T camLever = sqrt(toCamera.x() * toCamera.x() + toCamera.z() * toCamera.z());
  const T moduleLever = sqrt(toModule.x() * toModule.x() + toModule.z() * toModule.z());
  return theta / (T(1) / camLever + T(1) / moduleLever);
}

// ---- packing (double) ----

inline std::array<double, kModuleBlockSize> packModule(const OpticalModule& m) {
  const Eigen::Quaterniond q = m.orientation.normalized();
  const double w = m.width;
  return {q.x(),          q.y(),          q.z(),    q.w(),    m.position.x(),
          m.position.y(), m.position.z(), m.fx / w, m.fy / w, m.cx / w,
          m.cy / w,       m.k1,           m.k2};
}

inline void unpackModule(const double* block, OpticalModule* m) {
  m->orientation = Eigen::Quaterniond(block[3], block[0], block[1], block[2]).normalized();
  m->position = {block[4], block[5], block[6]};
  const double w = m->width;
  m->fx = block[7] * w;
  m->fy = block[8] * w;
  m->cx = block[9] * w;
  m->cy = block[10] * w;
  m->k1 = block[11];
  m->k2 = block[12];
}

inline std::array<double, kCameraBlockSize> packCamera(const CameraPose& pose) {
  const Eigen::Quaterniond q = pose.physicalFromCamera.normalized();
  return {q.x(), q.y(), q.z(), q.w(), pose.centre.x(), pose.centre.y(), pose.centre.z()};
}

inline CameraPose unpackCamera(const double* block) {
  CameraPose pose;
  pose.physicalFromCamera = Eigen::Quaterniond(block[3], block[0], block[1], block[2]).normalized();
  pose.centre = {block[4], block[5], block[6]};
  return pose;
}

// Names of the module tangent-space parameters (the order of the Jacobian's columns).
inline const char* moduleParameterName(int index) {
  static const char* kNames[kModuleTangentSize] = {
      "rotation.x", "rotation.y", "rotation.z", "position.x", "position.y", "position.z",
      "fx",         "fy",         "cx",         "cy",         "k1",         "k2"};
  return index >= 0 && index < kModuleTangentSize ? kNames[index] : "?";
}

inline const char* cameraParameterName(int index) {
  static const char* kNames[kCameraTangentSize] = {"rotation.x", "rotation.y", "rotation.z",
                                                   "centre.x",   "centre.y",   "centre.z"};
  return index >= 0 && index < kCameraTangentSize ? kNames[index] : "?";
}

// The angle (rad) between where module light arriving at s along s − p leaves the screen and
// the direction to camera centre c, under the model's transfer (stripeMismatch, before its
// conversion to a distance): where a camera at c sees module p's stripe.
inline double stripeAngle(const Screen& screen, const Eigen::Vector3d& s, const Eigen::Vector3d& p,
                          const Eigen::Vector3d& c) {
  const double distance = stripeMismatch<double>(screen.transfer, screen.curvature, s, p, c);
  const Eigen::Vector3d toCamera = c - s, toModule = s - p;
  const double camLever = std::hypot(toCamera.x(), toCamera.z());
  const double moduleLever = std::hypot(toModule.x(), toModule.z());
  return distance * (1.0 / camLever + 1.0 / moduleLever);
}

}  // namespace parallax
