#pragma once
// The specular optics of the Whitted integrator, in one place so they can be tested against
// closed forms: mirror reflection, Snell refraction with total internal reflection, and the
// unpolarised Fresnel reflectance of a dielectric interface.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace parallax {

// d: unit incoming direction; n: unit normal (either side).
inline Eigen::Vector3f reflect(const Eigen::Vector3f& d, const Eigen::Vector3f& n) {
  return d - 2.0f * d.dot(n) * n;
}

// d: unit incoming direction; n: unit normal facing the incoming side (d·n < 0); eta = n_i/n_t.
// Returns false on total internal reflection. Otherwise *t is the unit refracted direction and
// *cosT the cosine of the refraction angle.
inline bool refract(const Eigen::Vector3f& d, const Eigen::Vector3f& n, float eta,
                    Eigen::Vector3f* t, float* cosT) {
  const float cosI = std::min(1.0f, -d.dot(n));
  const float sin2T = eta * eta * std::max(0.0f, 1.0f - cosI * cosI);
  if (sin2T >= 1.0f) return false;
  *cosT = std::sqrt(1.0f - sin2T);
  *t = (eta * d + (eta * cosI - *cosT) * n).normalized();
  return true;
}

// Unpolarised Fresnel reflectance for cosines cosI, cosT on each side and eta = n_i/n_t.
inline float fresnelDielectric(float cosI, float cosT, float eta) {
  const float rs = (eta * cosI - cosT) / (eta * cosI + cosT);
  const float rp = (cosI - eta * cosT) / (cosI + eta * cosT);
  return 0.5f * (rs * rs + rp * rp);
}

}  // namespace parallax
