#include "calibration/display/display_model.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "common/input_error.h"

namespace parallax {
namespace {

[[noreturn]] void fail(const std::string& field, const std::string& reason) {
  throw InputError(InputLocation{"", field, 0}, reason);
}

void requireFinite(const std::string& field, double value) {
  if (!std::isfinite(value)) fail(field, fmt::format("must be a finite number, got {}", value));
}

void requirePositive(const std::string& field, double value) {
  requireFinite(field, value);
  if (!(value > 0.0)) fail(field, fmt::format("must be positive, got {}", value));
}

// Finite and |value| <= limit.
void requireWithin(const std::string& field, double value, double limit, const char* unit) {
  requireFinite(field, value);
  if (!(std::abs(value) <= limit))
    fail(field, fmt::format("{} is outside the physical range ±{}{}", value, limit, unit));
}

void requireWithin(const std::string& field, const Eigen::Vector3d& v, double limit,
                   const char* unit) {
  for (int i = 0; i < 3; ++i) requireWithin(fmt::format("{}[{}]", field, i), v[i], limit, unit);
}

void validateModule(const DisplayModel& model, size_t index) {
  const OpticalModule& m = model.modules[index];
  const std::string base = fmt::format("modules[{}]", index);
  requireWithin(base + ".position", m.position, kMaxDisplayExtentM, " m");
  const Eigen::Vector4d q = m.orientation.coeffs();
  for (int i = 0; i < 4; ++i) requireFinite(base + ".orientation", q[i]);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 1e-6) {
    fail(base + ".orientation",
         fmt::format("quaternion must be unit length, its norm is {}", norm));
  }
  requireFinite(base + ".focal_px[0]", m.fx);
  requireFinite(base + ".focal_px[1]", m.fy);
  if (m.fx == 0.0 || m.fy == 0.0) {
    fail(base + ".focal_px",
         fmt::format("focal length must be non-zero, got [{}, {}]", m.fx, m.fy));
  }
  requirePositive(base + ".focal_px[0]", m.fx);
  requirePositive(base + ".focal_px[1]", m.fy);
  requireWithin(base + ".focal_px[0]", m.fx, kMaxFocalPx, " px");
  requireWithin(base + ".focal_px[1]", m.fy, kMaxFocalPx, " px");
  requireWithin(base + ".distortion[0]", m.k1, kMaxDistortion, "");
  requireWithin(base + ".distortion[1]", m.k2, kMaxDistortion, "");
  if (m.width <= 0 || m.height <= 0 || m.width > kMaxModuleSide || m.height > kMaxModuleSide) {
    fail(base + ".resolution", fmt::format("must be between 1 and {} pixels a side, got {}x{}",
                                           kMaxModuleSide, m.width, m.height));
  }
  // The principal point may sit off the panel (lens shift), but not absurdly far.
  requireFinite(base + ".principal_px[0]", m.cx);
  requireFinite(base + ".principal_px[1]", m.cy);
  if (!(std::abs(m.cx - 0.5 * m.width) <= kMaxPrincipalOffsetSides * m.width))
    fail(base + ".principal_px[0]", fmt::format("{} is more than {} module widths from the centre",
                                                m.cx, kMaxPrincipalOffsetSides));
  if (!(std::abs(m.cy - 0.5 * m.height) <= kMaxPrincipalOffsetSides * m.height))
    fail(base + ".principal_px[1]", fmt::format("{} is more than {} module heights from the centre",
                                                m.cy, kMaxPrincipalOffsetSides));
  // "Behind the screen": below the screen surface at the module's x (clamped to the chord).
  const Screen& screen = model.screen;
  const double half = 0.5 * screen.width;
  const double xs = std::clamp(m.position.x(), -half, half);
  const double surface = screen.sag(xs);
  if (!(m.position.z() < surface)) {
    fail(base + ".position",
         fmt::format("module must be behind the screen (z < {:.6g} m at x = {:.6g}), got z = {}",
                     surface, m.position.x(), m.position.z()));
  }
}

}  // namespace

void DisplayModel::validate() const {
  requirePositive("screen.width", screen.width);
  requirePositive("screen.height", screen.height);
  requireWithin("screen.width", screen.width, kMaxDisplayExtentM, " m");
  requireWithin("screen.height", screen.height, kMaxDisplayExtentM, " m");
  requireWithin("screen.curvature", screen.curvature, kMaxScreenCurvature, " 1/m");
  if (!(std::abs(screen.curvature) * 0.5 * screen.width < 1.0)) {
    fail("screen.curvature",
         fmt::format("|k|·W/2 = {} must be below 1, or the screen would fold over "
                     "(k = {} 1/m, W = {} m)",
                     std::abs(screen.curvature) * 0.5 * screen.width, screen.curvature,
                     screen.width));
  }
  requirePositive("screen.diffusion_deg", screen.diffusionDeg);
  if (screen.diffusionDeg >= 180.0) fail("screen.diffusion_deg", "must be below 180 degrees");

  requireWithin("observer.y", observer.y, kMaxDisplayExtentM, " m");
  requireWithin("observer.z", observer.z, kMaxDisplayExtentM, " m");
  const double nearestScreenZ = std::max(screen.sag(0.5 * screen.width), 0.0);
  if (!(observer.z > nearestScreenZ)) {
    fail("observer.z", fmt::format("observer line must be in front of the screen (z > {}), got {}",
                                   nearestScreenZ, observer.z));
  }

  requireWithin("displayable_box.min", displayableBox.min, kMaxDisplayExtentM, " m");
  requireWithin("displayable_box.max", displayableBox.max, kMaxDisplayExtentM, " m");
  for (int i = 0; i < 3; ++i) {
    if (!(displayableBox.max[i] > displayableBox.min[i])) {
      fail("displayable_box", fmt::format("max must exceed min on every axis (axis {}: {} vs {})",
                                          i, displayableBox.min[i], displayableBox.max[i]));
    }
  }

  if (modules.empty()) fail("modules", "a display needs at least one module");
  if (modules.size() > static_cast<size_t>(kMaxModules)) {
    fail("modules", fmt::format("at most {} modules, got {}", kMaxModules, modules.size()));
  }
  std::set<int> ids;
  for (size_t i = 0; i < modules.size(); ++i) {
    validateModule(*this, i);
    if (!ids.insert(modules[i].id).second) {
      fail(fmt::format("modules[{}].id", i), fmt::format("id {} is used twice", modules[i].id));
    }
  }
}

long DisplayModel::pixelCount() const {
  long total = 0;
  for (const OpticalModule& m : modules) total += m.pixelCount();
  return total;
}

}  // namespace parallax
