#include "daemon/parallaxd/calibration_store.h"

#include <fmt/format.h>

#include <filesystem>

#include "calibration/display/display_model_json.h"
#include "common/input_error.h"

namespace parallax::daemon {

namespace fs = std::filesystem;

void CalibrationStore::requireSameDisplay(const DisplayModel& nominal,
                                          const DisplayModel& candidate, const std::string& file) {
  if (candidate.modules.size() != nominal.modules.size()) {
    throw InputError({file, "modules", 0},
                     fmt::format("has {} modules; this display has {}: not a calibration of it",
                                 candidate.modules.size(), nominal.modules.size()));
  }
  for (size_t i = 0; i < nominal.modules.size(); ++i) {
    const OpticalModule& a = nominal.modules[i];
    const OpticalModule& b = candidate.modules[i];
    if (a.width != b.width || a.height != b.height) {
      throw InputError(
          {file, fmt::format("modules[{}].resolution", i), 0},
          fmt::format("{}x{}, but the module is {}x{}: not a calibration of this display", b.width,
                      b.height, a.width, a.height));
    }
  }
}

std::optional<DisplayModel> CalibrationStore::loadFor(const DisplayModel& nominal) const {
  std::error_code ec;
  if (!fs::exists(path_, ec)) return std::nullopt;
  DisplayModel model = loadDisplayModel(path_);
  requireSameDisplay(nominal, model, path_);
  return model;
}

void CalibrationStore::install(const DisplayModel& model) const {
  std::error_code ec;
  const fs::path parent = fs::path(path_).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  if (fs::exists(path_, ec)) {
    fs::copy_file(path_, previousPath(), fs::copy_options::overwrite_existing, ec);
    if (ec)
      throw InputError({path_, "", 0}, "cannot keep the previous calibration: " + ec.message());
  }
  saveDisplayModel(model, path_);
}

DisplayModel CalibrationStore::rollback(const DisplayModel& nominal) const {
  std::error_code ec;
  if (!fs::exists(previousPath(), ec)) {
    throw InputError({previousPath(), "", 0}, "no previous calibration to roll back to");
  }
  DisplayModel previous = loadDisplayModel(previousPath());
  requireSameDisplay(nominal, previous, previousPath());
  // Swap through a third name so that a crash in between leaves both calibrations on disk.
  const std::string swap = path_ + ".swap";
  if (fs::exists(path_, ec)) fs::rename(path_, swap, ec);
  if (ec)
    throw InputError({path_, "", 0}, "cannot move the current calibration aside: " + ec.message());
  saveDisplayModel(previous, path_);
  if (fs::exists(swap, ec)) fs::rename(swap, previousPath(), ec);
  return previous;
}

}  // namespace parallax::daemon
