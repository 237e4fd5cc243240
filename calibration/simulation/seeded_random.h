#pragma once
// A seeded random source whose sequence is fixed by the C++ standard alone: std::mt19937_64
// is specified bit for bit, while std::normal_distribution and friends are not (libstdc++ and
// libc++ differ). Every simulation takes a seed and the same seed must give the same bytes, so
// uniform and normal draws are written out here.

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace parallax {

class SeededRandom {
 public:
  explicit SeededRandom(std::uint64_t seed) : engine_(seed) {}

  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

  // Standard normal by Box–Muller; 1 − u keeps the logarithm away from zero.
  double normal() {
    const double u1 = 1.0 - uniform();
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }
  double normal(double sigma) { return sigma * normal(); }
  // Normal, clipped to ±limit: perturbations stay inside the range the issue states.
  double clippedNormal(double sigma, double limit) {
    const double x = normal(sigma);
    return x > limit ? limit : (x < -limit ? -limit : x);
  }

  // Integer in [0, n).
  int index(int n) { return static_cast<int>(uniform() * n) % n; }

  // A fresh, independent stream derived from this one (e.g. per camera), so adding draws in
  // one part of a simulation does not shift every later one.
  SeededRandom split() { return SeededRandom(engine_() ^ 0x9e3779b97f4a7c15ULL); }

 private:
  std::mt19937_64 engine_;
};

}  // namespace parallax
