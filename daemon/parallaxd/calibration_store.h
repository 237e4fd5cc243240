#pragma once
// The installed calibration of a display and the one before it (for `rollback`): two files,
// <file> and <file>.previous, the same pair `parallax calibrate --out` maintains. Installing
// writes atomically and keeps the old one; a file that does not describe this display (module
// count or resolution differ from the nominal) is refused as "not a calibration of it".

#include <optional>
#include <string>

#include "calibration/display/display_model.h"

namespace parallax::daemon {

class CalibrationStore {
 public:
  explicit CalibrationStore(std::string path) : path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  std::string previousPath() const { return path_ + ".previous"; }

  // The installed calibration when it exists and fits `nominal`; nullopt when there is none.
  // Throws InputError (file, field) when the file exists but is bad or for another display.
  std::optional<DisplayModel> loadFor(const DisplayModel& nominal) const;
  // Keeps the current file as .previous, then writes `model` atomically.
  void install(const DisplayModel& model) const;
  // Swaps the current and previous calibrations; returns the one now installed. Throws
  // InputError when there is no previous calibration (or it does not fit `nominal`).
  DisplayModel rollback(const DisplayModel& nominal) const;

  // InputError unless `candidate` has the nominal's module count and resolutions.
  static void requireSameDisplay(const DisplayModel& nominal, const DisplayModel& candidate,
                                 const std::string& file);

 private:
  std::string path_;
};

}  // namespace parallax::daemon
