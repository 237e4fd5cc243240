#pragma once
// Roots of a·x² + b·x + c = 0 without catastrophic cancellation (the "citardauq" pairing:
// q = −(b + sign(b)·√disc)/2, roots q/a and c/q). Degrades gracefully to the linear root when
// a vanishes, which is how a flat screen (k = 0) stays an ordinary case.

#include <cmath>
#include <utility>

namespace parallax {

struct QuadraticRoots {
  int count = 0;  // 0, 1 or 2 real roots
  double root[2] = {0.0, 0.0};
};

inline QuadraticRoots solveQuadratic(double a, double b, double c) {
  QuadraticRoots out;
  if (a == 0.0) {
    if (b != 0.0) {
      out.count = 1;
      out.root[0] = -c / b;
    }
    return out;
  }
  const double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) return out;
  const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
  if (q == 0.0) {  // b = 0 and c = 0: the double root 0
    out.count = 1;
    out.root[0] = 0.0;
    return out;
  }
  out.count = 2;
  out.root[0] = q / a;
  out.root[1] = c / q;
  if (out.root[0] > out.root[1]) std::swap(out.root[0], out.root[1]);
  return out;
}

}  // namespace parallax
