#include "calibration/display/display_presets.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "calibration/display/conventions.h"
#include "calibration/display/display_model_json.h"
#include "common/input_error.h"

namespace parallax {
namespace {

constexpr double kScreenWidth = 1.6;
constexpr double kScreenHeight = 0.9;
constexpr double kModuleDistance = 1.0;   // behind the screen
constexpr double kFieldOfViewDeg = 70.0;  // diffusion of a lone module (no pitch to scale)
constexpr double kObserverDistance = 2.0;
constexpr double kDisplayableDepth = 0.5;
constexpr double kCoverMargin = 1.02;
constexpr double kDiffusionPerPitch = 1.5;

// Largest focal length (square pixels, centred principal point) for which every point of the
// screen's outline projects inside the image with the cover margin.
double coveringFocalLength(const OpticalModule& m, const Screen& screen) {
  const Eigen::Matrix3d moduleFromPhysical = m.orientation.toRotationMatrix().transpose();
  double maxX = 0.0, maxY = 0.0;
  constexpr int kSamples = 64;
  for (int i = 0; i <= kSamples; ++i) {
    const double x = (-0.5 + static_cast<double>(i) / kSamples) * screen.width;
    for (double y : {-0.5 * screen.height, 0.5 * screen.height}) {
      const Eigen::Vector3d local = moduleFromPhysical * (screen.pointAt(x, y) - m.position);
      maxX = std::max(maxX, std::abs(local.x() / local.z()));
      maxY = std::max(maxY, std::abs(local.y() / local.z()));
    }
  }
  return std::min(0.5 * m.width / maxX, 0.5 * m.height / maxY) / kCoverMargin;
}

}  // namespace

void NominalDisplayOptions::validate() const {
  if (preset != "default" && preset != "demo") {
    throw InputError({"", "--preset", 0},
                     fmt::format("unknown preset \"{}\" (default, demo)", preset));
  }
  if (modules && (*modules < 1 || *modules > kMaxModules)) {
    throw InputError({"", "--modules", 0}, fmt::format("must be 1..{}", kMaxModules));
  }
  if ((width && (*width < 2 || *width > kMaxModuleSide)) ||
      (height && (*height < 2 || *height > kMaxModuleSide))) {
    throw InputError({"", "--resolution", 0}, fmt::format("sides must be 2..{}", kMaxModuleSide));
  }
  if (curvature &&
      !(std::isfinite(*curvature) && std::abs(*curvature) * 0.5 * kScreenWidth < 0.95)) {
    throw InputError({"", "--curvature", 0},
                     fmt::format("|k|·W/2 must stay below 0.95 for a {} m screen (|k| < {:.4g})",
                                 kScreenWidth, 0.95 / (0.5 * kScreenWidth)));
  }
}

DisplayModel makeNominalDisplay(const NominalDisplayOptions& options) {
  options.validate();
  const bool demo = options.preset == "demo";
  DisplayModel model;
  model.name = options.preset;
  model.screen.width = kScreenWidth;
  model.screen.height = kScreenHeight;
  model.screen.curvature = options.curvature.value_or(0.0);
  model.screen.transfer = options.transfer.value_or(ScreenTransfer::kConical);
  model.observer = {0.0, kObserverDistance};
  model.displayableBox.min = {-0.5 * kScreenWidth, -0.5 * kScreenHeight, -0.5 * kDisplayableDepth};
  model.displayableBox.max = {0.5 * kScreenWidth, 0.5 * kScreenHeight, 0.5 * kDisplayableDepth};

  const int count = options.modules.value_or(demo ? 16 : 72);
  const int width = options.width.value_or(demo ? 512 : 1024);
  const int height = options.height.value_or(demo ? 384 : 768);
  // A variant is not the preset: "default" would claim a layout it does not have.
  if (count != (demo ? 16 : 72)) model.name += fmt::format("-{}-modules", count);
  if (width != (demo ? 512 : 1024) || height != (demo ? 384 : 768))
    model.name += fmt::format("-{}x{}", width, height);
  const double rowHalfWidth = 0.5 * kScreenWidth * (1.0 + kModuleDistance / kObserverDistance);
  for (int i = 0; i < count; ++i) {
    OpticalModule m;
    m.id = i;
    const double x = count == 1 ? 0.0 : rowHalfWidth * (-1.0 + 2.0 * (i + 0.5) / count);
    m.position = {x, 0.0, -kModuleDistance};
    m.orientation = uprightLookingAt(m.position, Eigen::Vector3d::Zero());
    m.width = width;
    m.height = height;
    m.cx = 0.5 * width;
    m.cy = 0.5 * height;
    m.mirror = true;
    m.fx = m.fy = coveringFocalLength(m, model.screen);
    model.modules.push_back(m);
  }
  const double pitch = angularPitchDeg(model);
  model.screen.diffusionDeg = kDiffusionPerPitch * (pitch > 0.0 ? pitch : kFieldOfViewDeg);
  model.validate();
  return model;
}

bool isBuiltInDisplay(const std::string& name) { return name == "default" || name == "demo"; }

DisplayModel resolveDisplay(const std::string& fileOrName) {
  if (isBuiltInDisplay(fileOrName)) {
    NominalDisplayOptions options;
    options.preset = fileOrName;
    return makeNominalDisplay(options);
  }
  return loadDisplayModel(fileOrName);
}

double angularPitchDeg(const DisplayModel& model) {
  if (model.modules.size() < 2) return 0.0;
  std::vector<double> angles;
  for (const OpticalModule& m : model.modules) {
    angles.push_back(std::atan2(m.position.x(), -m.position.z()));
  }
  std::sort(angles.begin(), angles.end());
  return degrees((angles.back() - angles.front()) / static_cast<double>(angles.size() - 1));
}

}  // namespace parallax
