#pragma once
// The installed calibration of a display and the one before it (for `rollback`): two files,
// <file> and <file>.previous, the same pair `parallax calibrate --out` maintains.
//
// Durability rules (issue 18): every file is written with a checksum, atomically and flushed
// to disk (temporary file, fsync, rename, fsync of the folder), and read back and verified
// before an install is reported done; `.previous` only ever receives a file that verified, so
// a damaged current file never replaces the last good calibration; at start-up a damaged
// current file with a good `.previous` gives the previous one, and says so. A file that does
// not describe this display (module count or resolution differ from the nominal) is refused
// as "not a calibration of it".

#include <optional>
#include <string>

#include "calibration/display/display_model.h"

namespace parallax::daemon {

struct StoredCalibration {
  DisplayModel model;
  std::string source;   // the file it was read from: the current one, or .previous
  std::string refused;  // why the current file was passed over for .previous; empty if it was not
};

class CalibrationStore {
 public:
  explicit CalibrationStore(std::string path) : path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  std::string previousPath() const { return path_ + ".previous"; }

  // The installed calibration when it verifies and fits `nominal`, else .previous when that
  // does (logged, `refused` says why); nullopt when there is no current file. Throws
  // InputError (file, field) when the current file is bad and no good .previous exists.
  std::optional<StoredCalibration> loadFor(const DisplayModel& nominal) const;
  // Makes `model` the installed calibration: the current file (only if it verifies) becomes
  // .previous, then `model` is written durably and read back. Returns once it is on disk;
  // throws InputError naming the file and the system's reason otherwise (a full disk), with
  // the old calibration still installed and no partial .previous.
  void install(const DisplayModel& model) const;
  // Swaps the current and previous calibrations; returns the one now installed. Throws
  // InputError when there is no previous calibration (or it does not verify or fit `nominal`).
  // A current file that does not verify is dropped, not kept as .previous.
  DisplayModel rollback(const DisplayModel& nominal) const;

  // InputError unless `candidate` has the nominal's module count and resolutions.
  static void requireSameDisplay(const DisplayModel& nominal, const DisplayModel& candidate,
                                 const std::string& file);

 private:
  std::string path_;
};

}  // namespace parallax::daemon
