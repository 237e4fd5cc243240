#include "calibration/display/colour_difference.h"

#include <cmath>
#include <numbers>

namespace parallax {
namespace {

double labF(double t) {
  constexpr double delta = 6.0 / 29.0;
  return t > delta * delta * delta ? std::cbrt(t) : t / (3.0 * delta * delta) + 4.0 / 29.0;
}

double degreesOf(double rad) { return rad * 180.0 / std::numbers::pi; }
double radiansOf(double deg) { return deg * std::numbers::pi / 180.0; }

}  // namespace

Eigen::Vector3d xyzFromLinearSrgb(const Eigen::Vector3d& rgb) {
  Eigen::Matrix3d m;
  m << 0.4124564, 0.3575761, 0.1804375, 0.2126729, 0.7151522, 0.0721750, 0.0193339, 0.1191920,
      0.9503041;
  return m * rgb;
}

double luminance(const Eigen::Vector3d& rgb) { return xyzFromLinearSrgb(rgb).y(); }

Eigen::Vector2d chromaticity(const Eigen::Vector3d& rgb) {
  const Eigen::Vector3d xyz = xyzFromLinearSrgb(rgb);
  const double sum = xyz.sum();
  if (!(std::abs(sum) > 1e-12)) return Eigen::Vector2d::Zero();
  return {xyz.x() / sum, xyz.y() / sum};
}

Eigen::Vector3d labFromLinearSrgb(const Eigen::Vector3d& rgb, const Eigen::Vector3d& white) {
  const Eigen::Vector3d xyz = xyzFromLinearSrgb(rgb), w = xyzFromLinearSrgb(white);
  const double fx = labF(xyz.x() / w.x()), fy = labF(xyz.y() / w.y()), fz = labF(xyz.z() / w.z());
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

double ciede2000(const Eigen::Vector3d& lab1, const Eigen::Vector3d& lab2) {
  const double L1 = lab1[0], a1 = lab1[1], b1 = lab1[2];
  const double L2 = lab2[0], a2 = lab2[1], b2 = lab2[2];
  const double C1 = std::hypot(a1, b1), C2 = std::hypot(a2, b2);
  const double Cbar = 0.5 * (C1 + C2);
  const double Cbar7 = std::pow(Cbar, 7.0);
  const double G = 0.5 * (1.0 - std::sqrt(Cbar7 / (Cbar7 + std::pow(25.0, 7.0))));
  const double a1p = (1.0 + G) * a1, a2p = (1.0 + G) * a2;
  const double C1p = std::hypot(a1p, b1), C2p = std::hypot(a2p, b2);
  auto hueOf = [](double b, double ap) {
    if (b == 0.0 && ap == 0.0) return 0.0;
    const double h = degreesOf(std::atan2(b, ap));
    return h < 0.0 ? h + 360.0 : h;
  };
  const double h1p = hueOf(b1, a1p), h2p = hueOf(b2, a2p);
  const double dLp = L2 - L1, dCp = C2p - C1p;
  double dhp = 0.0;
  if (C1p * C2p != 0.0) {
    dhp = h2p - h1p;
    if (dhp > 180.0) dhp -= 360.0;
    if (dhp < -180.0) dhp += 360.0;
  }
  const double dHp = 2.0 * std::sqrt(C1p * C2p) * std::sin(radiansOf(dhp / 2.0));
  const double Lbarp = 0.5 * (L1 + L2), Cbarp = 0.5 * (C1p + C2p);
  double hbarp = h1p + h2p;
  if (C1p * C2p != 0.0) {
    if (std::abs(h1p - h2p) <= 180.0) {
      hbarp = 0.5 * (h1p + h2p);
    } else {
      hbarp = h1p + h2p < 360.0 ? 0.5 * (h1p + h2p + 360.0) : 0.5 * (h1p + h2p - 360.0);
    }
  }
  const double T = 1.0 - 0.17 * std::cos(radiansOf(hbarp - 30.0)) +
                   0.24 * std::cos(radiansOf(2.0 * hbarp)) +
                   0.32 * std::cos(radiansOf(3.0 * hbarp + 6.0)) -
                   0.20 * std::cos(radiansOf(4.0 * hbarp - 63.0));
  const double dTheta = 30.0 * std::exp(-((hbarp - 275.0) / 25.0) * ((hbarp - 275.0) / 25.0));
  const double Cbarp7 = std::pow(Cbarp, 7.0);
  const double Rc = 2.0 * std::sqrt(Cbarp7 / (Cbarp7 + std::pow(25.0, 7.0)));
  const double Sl = 1.0 + 0.015 * (Lbarp - 50.0) * (Lbarp - 50.0) /
                              std::sqrt(20.0 + (Lbarp - 50.0) * (Lbarp - 50.0));
  const double Sc = 1.0 + 0.045 * Cbarp, Sh = 1.0 + 0.015 * Cbarp * T;
  const double Rt = -std::sin(radiansOf(2.0 * dTheta)) * Rc;
  const double l = dLp / Sl, c = dCp / Sc, h = dHp / Sh;
  return std::sqrt(l * l + c * c + h * h + Rt * c * h);
}

}  // namespace parallax
