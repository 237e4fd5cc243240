#include "daemon/parallaxd/calibration_store.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <filesystem>

#include "calibration/display/display_model_json.h"
#include "common/atomic_file.h"
#include "common/input_error.h"
#include "common/regular_file.h"
#include "daemon/parallaxd/ray_texture_cache.h"

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

std::string geometryHashOf(const DisplayModel& model) { return hashHex(displayContentHash(model)); }

void removeIfPresent(const std::string& path) {
  std::error_code ec;
  fs::remove(path, ec);
  if (ec) throw InputError({path, "", 0}, "cannot remove it: " + ec.message());
}

// Whether `path` is a regular file of exactly `bytes`.
bool holdsBytes(const std::string& path, const std::string& bytes) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec) || fs::file_size(path, ec) != bytes.size() || ec) return false;
  return readRegularFile(path, bytes.size()) == bytes;
}

constexpr size_t kMaxPhotometryFileBytes = size_t{64} << 20;

// The bytes of the photometry file at `path` when it loads and belongs to `geometry`; nullopt
// when there is none, or (with the reason in `why`) when it is bad.
std::optional<std::string> verifiedPhotometryBytes(const std::string& path,
                                                   const DisplayModel& geometry, std::string* why) {
  if (!present(path)) return std::nullopt;
  try {
    std::string bytes = readRegularFile(path, kMaxPhotometryFileBytes);
    CalibrationStore::requireMatchingPhotometry(geometry, geometry, loadColourCorrection(path),
                                                path);
    return bytes;
  } catch (const InputError& e) {
    if (why) *why = e.what();
    return std::nullopt;
  }
}

// `bytes` at `path`, or no file there.
void writeOrRemove(const std::string& path, const std::optional<std::string>& bytes) {
  if (bytes) {
    writeFileAtomically(path, *bytes);
  } else {
    removeIfPresent(path);
  }
}

}  // namespace

std::string CalibrationStore::photometryPath() const {
  const fs::path file(path_);
  return (file.parent_path() / (file.stem().string() + ".photometry.json")).string();
}

void CalibrationStore::requireMatchingPhotometry(const DisplayModel& nominal,
                                                 const DisplayModel& geometry,
                                                 const DisplayColourCorrection& photometry,
                                                 const std::string& file) {
  if (photometry.modules.size() != nominal.modules.size()) {
    throw InputError({file, "modules", 0},
                     fmt::format("has {} modules; this display has {}: not a correction of it",
                                 photometry.modules.size(), nominal.modules.size()));
  }
  const std::string hash = geometryHashOf(geometry);
  if (!photometry.geometry.empty() && photometry.geometry != hash) {
    throw InputError({file, "geometry", 0},
                     fmt::format("was fitted with the geometric calibration {}, not the one it is "
                                 "installed with ({})",
                                 photometry.geometry, hash));
  }
}

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

namespace {

// The photometry of the version whose geometry `stored` holds, from `file`: attached when it
// verifies and belongs to it, else left out with the reason.
void attachPhotometry(StoredCalibration* stored, const DisplayModel& nominal,
                      const std::string& file) {
  if (!present(file)) return;
  try {
    DisplayColourCorrection photometry = loadColourCorrection(file);
    CalibrationStore::requireMatchingPhotometry(nominal, stored->model, photometry, file);
    stored->photometry = std::move(photometry);
    stored->photometrySource = file;
  } catch (const InputError& e) {
    stored->photometryRefused = e.what();
    spdlog::warn("photometric correction {} refused ({}); the modules are not corrected", file,
                 e.what());
  }
}

}  // namespace

std::optional<StoredCalibration> CalibrationStore::loadFor(const DisplayModel& nominal) const {
  if (!present(path_)) return std::nullopt;
  StoredCalibration out;
  try {
    DisplayModel model = loadDisplayModel(path_);
    requireSameDisplay(nominal, model, path_);
    out = StoredCalibration{std::move(model), path_, "", {}, {}, {}};
    attachPhotometry(&out, nominal, photometryPath());
    return out;
  } catch (const InputError& current) {
    if (!present(previousPath())) throw;
    try {
      DisplayModel previous = loadDisplayModel(previousPath());
      requireSameDisplay(nominal, previous, previousPath());
      spdlog::warn("calibration {} refused ({}); using the previous one, {}", path_, current.what(),
                   previousPath());
      out = StoredCalibration{std::move(previous), previousPath(), current.what(), {}, {}, {}};
    } catch (const InputError& older) {
      throw InputError(current.location(),
                       fmt::format("{} (and {})", current.reason(), older.what()));
    }
  }
  attachPhotometry(&out, nominal, previousPhotometryPath());
  return out;
}

StoredCalibration CalibrationStore::install(
    const DisplayModel& model, Photometry mode,
    const std::optional<DisplayColourCorrection>& photometry) const {
  const Files before = files();
  try {
    return installOver(model, mode, photometry);
  } catch (const std::exception&) {
    undoAfter(before, std::current_exception());
  }
}

StoredCalibration CalibrationStore::installOver(
    const DisplayModel& model, Photometry mode,
    const std::optional<DisplayColourCorrection>& photometry) const {
  const fs::path parent = fs::path(path_).parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw InputError({path_, "", 0}, "cannot create its folder: " + ec.message());
  }
  // The installed version, as far as it verifies.
  std::string why;
  const std::optional<std::string> currentBytes =
      present(path_) ? verifiedBytes(path_, &why) : std::nullopt;
  if (present(path_) && !currentBytes)
    spdlog::warn("{} does not verify ({}): not kept as {}", path_, why, previousPath());
  std::optional<std::string> currentPhotometry;
  if (currentBytes) {
    std::string photometryWhy;
    currentPhotometry =
        verifiedPhotometryBytes(photometryPath(), loadDisplayModel(path_), &photometryWhy);
    if (!photometryWhy.empty())
      spdlog::warn("{} does not verify ({}): not kept", photometryPath(), photometryWhy);
  }

  // The new version's photometry: the one given, or the installed one carried over.
  std::optional<DisplayColourCorrection> next;
  if (mode == Photometry::kReplace) {
    next = photometry;
  } else if (currentPhotometry) {
    next = loadColourCorrection(photometryPath());
  }
  if (next) {
    next->geometry = geometryHashOf(model);
    requireMatchingPhotometry(model, model, *next, photometryPath());
  }

  if (currentBytes) {
    writeFileAtomically(previousPath(), *currentBytes);
    writeOrRemove(previousPhotometryPath(), currentPhotometry);
  }
  // The photometry first: torn by a crash before the geometry, it names a geometry that is not
  // installed and is left out at the next start.
  if (next) {
    saveColourCorrection(*next, photometryPath());
  } else {
    removeIfPresent(photometryPath());
  }
  saveDisplayModel(model, path_);
  // Acknowledged only as what is on disk: read back, checksums verified, the same content.
  StoredCalibration out{loadDisplayModel(path_), path_, "", {}, {}, {}};
  if (displayModelToJson(out.model) != displayModelToJson(model))
    throw InputError({path_, "", 0}, "read back different from what was written");
  attachPhotometry(&out, model, photometryPath());
  if (next && !out.photometry)
    throw InputError({photometryPath(), "", 0}, "read back refused: " + out.photometryRefused);
  return out;
}

StoredCalibration CalibrationStore::rollback(const DisplayModel& nominal) const {
  const Files before = files();
  try {
    return swapVersions(nominal);
  } catch (const std::exception&) {
    undoAfter(before, std::current_exception());
  }
}

StoredCalibration CalibrationStore::swapVersions(const DisplayModel& nominal) const {
  if (!present(previousPath())) {
    throw InputError({previousPath(), "", 0}, "no previous calibration to roll back to");
  }
  // Everything of the previous version is checked before anything changes.
  DisplayModel previous = loadDisplayModel(previousPath());
  requireSameDisplay(nominal, previous, previousPath());
  const std::string previousBytes = readRegularFile(previousPath(), kMaxDisplayFileBytes);
  std::optional<std::string> previousPhotometry;
  std::optional<DisplayColourCorrection> previousCorrection;
  if (present(previousPhotometryPath())) {
    previousCorrection = loadColourCorrection(previousPhotometryPath());
    requireMatchingPhotometry(nominal, previous, *previousCorrection, previousPhotometryPath());
    previousPhotometry = readRegularFile(previousPhotometryPath(), kMaxPhotometryFileBytes);
  }
  std::string why;
  const std::optional<std::string> current =
      present(path_) ? verifiedBytes(path_, &why) : std::nullopt;
  if (present(path_) && !current)
    spdlog::warn("{} does not verify ({}): dropped, not kept as {}", path_, why, previousPath());
  std::optional<std::string> currentPhotometry;
  if (current) {
    std::string photometryWhy;
    currentPhotometry =
        verifiedPhotometryBytes(photometryPath(), loadDisplayModel(path_), &photometryWhy);
    if (!photometryWhy.empty())
      spdlog::warn("{} does not verify ({}): dropped", photometryPath(), photometryWhy);
  }
  // Through third names, so that a crash at any point leaves both versions on disk.
  const std::string swap = path_ + ".swap", photometrySwap = photometryPath() + ".swap";
  if (current) {
    writeFileAtomically(swap, *current);
    writeOrRemove(photometrySwap, currentPhotometry);
  }
  writeOrRemove(photometryPath(), previousPhotometry);
  writeFileAtomically(path_, previousBytes);
  if (current) {
    writeFileAtomically(previousPath(), *current);
    writeOrRemove(previousPhotometryPath(), currentPhotometry);
    ::unlink(swap.c_str());
    ::unlink(photometrySwap.c_str());
  }
  StoredCalibration out{std::move(previous), path_, "", std::move(previousCorrection), {}, {}};
  if (out.photometry) out.photometrySource = photometryPath();
  return out;
}

CalibrationStore::Files CalibrationStore::files() const {
  // Photometry before geometry, .previous before current: the order `install` writes them in.
  Files out;
  for (const auto& [path, maxBytes] : {std::pair{previousPhotometryPath(), kMaxPhotometryFileBytes},
                                       std::pair{previousPath(), kMaxDisplayFileBytes},
                                       std::pair{photometryPath(), kMaxPhotometryFileBytes},
                                       std::pair{path_, kMaxDisplayFileBytes}}) {
    out.contents.emplace_back(
        path, present(path) ? std::optional(readRegularFile(path, maxBytes)) : std::nullopt);
  }
  return out;
}

void CalibrationStore::restore(const Files& before) const {
  for (const auto& [path, bytes] : before.contents) {
    if (!bytes) {
      removeIfPresent(path);
    } else if (!holdsBytes(path, *bytes)) {
      writeFileAtomically(path, *bytes);
    }
  }
}

void CalibrationStore::undoAfter(const Files& before, const std::exception_ptr& failure) const {
  try {
    restore(before);
  } catch (const std::exception& undo) {
    try {
      std::rethrow_exception(failure);
    } catch (const std::exception& e) {
      throw InputError(
          {path_, "", 0},
          fmt::format("{}; and putting its files back as they were: {}", e.what(), undo.what()));
    }
  }
  std::rethrow_exception(failure);
}

}  // namespace parallax::daemon
