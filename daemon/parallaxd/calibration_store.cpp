#include "daemon/parallaxd/calibration_store.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <filesystem>

#include "calibration/display/display_model_json.h"
#include "common/atomic_file.h"
#include "common/input_error.h"
#include "common/regular_file.h"

namespace parallax::daemon {

namespace fs = std::filesystem;

namespace {

bool present(const std::string& path) {
  std::error_code ec;
  return fs::exists(fs::symlink_status(path, ec));
}

// A calibration file's bytes when it loads and its checksum verifies; nullopt (with the
// reason in `why`) otherwise.
std::optional<std::string> verifiedBytes(const std::string& path, std::string* why) {
  try {
    std::string bytes = readRegularFile(path, kMaxDisplayFileBytes);
    loadDisplayModel(path);
    return bytes;
  } catch (const InputError& e) {
    if (why) *why = e.what();
    return std::nullopt;
  }
}

}  // namespace

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

std::optional<StoredCalibration> CalibrationStore::loadFor(const DisplayModel& nominal) const {
  if (!present(path_)) return std::nullopt;
  try {
    DisplayModel model = loadDisplayModel(path_);
    requireSameDisplay(nominal, model, path_);
    return StoredCalibration{std::move(model), path_, ""};
  } catch (const InputError& current) {
    if (!present(previousPath())) throw;
    try {
      DisplayModel previous = loadDisplayModel(previousPath());
      requireSameDisplay(nominal, previous, previousPath());
      spdlog::warn("calibration {} refused ({}); using the previous one, {}", path_, current.what(),
                   previousPath());
      return StoredCalibration{std::move(previous), previousPath(), current.what()};
    } catch (const InputError& older) {
      throw InputError(current.location(),
                       fmt::format("{} (and {})", current.reason(), older.what()));
    }
  }
}

void CalibrationStore::install(const DisplayModel& model) const {
  const fs::path parent = fs::path(path_).parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw InputError({path_, "", 0}, "cannot create its folder: " + ec.message());
  }
  if (present(path_)) {
    std::string why;
    if (const std::optional<std::string> good = verifiedBytes(path_, &why)) {
      writeFileAtomically(previousPath(), *good);
    } else {
      spdlog::warn("{} does not verify ({}): not kept as {}", path_, why, previousPath());
    }
  }
  saveDisplayModel(model, path_);
  // Acknowledged only as what is on disk: read back, checksum verified, the same model.
  const DisplayModel written = loadDisplayModel(path_);
  if (displayModelToJson(written) != displayModelToJson(model))
    throw InputError({path_, "", 0}, "read back different from what was written");
}

DisplayModel CalibrationStore::rollback(const DisplayModel& nominal) const {
  if (!present(previousPath())) {
    throw InputError({previousPath(), "", 0}, "no previous calibration to roll back to");
  }
  DisplayModel previous = loadDisplayModel(previousPath());
  requireSameDisplay(nominal, previous, previousPath());
  const std::string previousBytes = readRegularFile(previousPath(), kMaxDisplayFileBytes);
  std::string why;
  const std::optional<std::string> current =
      present(path_) ? verifiedBytes(path_, &why) : std::nullopt;
  if (present(path_) && !current)
    spdlog::warn("{} does not verify ({}): dropped, not kept as {}", path_, why, previousPath());
  // Through a third name, so that a crash at any point leaves both calibrations on disk.
  const std::string swap = path_ + ".swap";
  if (current) writeFileAtomically(swap, *current);
  writeFileAtomically(path_, previousBytes);
  if (current) {
    writeFileAtomically(previousPath(), *current);
    ::unlink(swap.c_str());
  }
  return previous;
}

}  // namespace parallax::daemon
