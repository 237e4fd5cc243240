#pragma once
// The screen transfer: a module ray with unit direction d meets the screen at s; the screen
// spreads it vertically and keeps its horizontal direction, and of the outgoing rays the one
// that reaches the observer line at o = (X, y_obs, z_obs) is the pixel's ray.
//
//  linear  (the paper's words): the top-view slope is kept, X = s.x + d.x/d.z · (z_obs − s.z).
//  conical (a thin vertical diffuser): the cosine along the screen's horizontal tangent t is
//          kept, (o − s)/|o − s| · t = d · t. With ξ = X − s.x, Y = y_obs − s.y, Z = z_obs − s.z,
//          t = (tx, 0, tz) and a = d · t, squaring gives the quadratic in ξ
//            (tx² − a²) ξ² + 2 tx tz Z ξ + (tz² Z² − a² (Y² + Z²)) = 0,
//          whose roots are kept only if tx ξ + tz Z has the sign of a (squaring adds the mirror
//          cone). Of two, the one reached from d by the smaller rotation about t is the ray.
//          Flat screen (t = x̂): ξ = a·r/√(1 − a²), r = √(Y² + Z²).
//
// The two agree exactly when the module ray's side-view slope already leads to the observer
// line's height ((y_obs − s.y)/(z_obs − s.z) = d.y/d.z): then the ray goes straight through.

#include <Eigen/Core>

#include "calibration/display/observer_line.h"
#include "calibration/display/screen.h"

namespace parallax {

// X on the observer line for module ray direction d (unit) arriving at screen point s; false
// when the transfer has no solution (the cone misses the line, or d runs along the tangent).
bool transferToObserverLine(const Screen& screen, const ObserverLine& observer,
                            const Eigen::Vector3d& s, const Eigen::Vector3d& d, double* x);

bool linearTransfer(const Screen& screen, const ObserverLine& observer, const Eigen::Vector3d& s,
                    const Eigen::Vector3d& d, double* x);
bool conicalTransfer(const Screen& screen, const ObserverLine& observer, const Eigen::Vector3d& s,
                     const Eigen::Vector3d& d, double* x);

}  // namespace parallax
