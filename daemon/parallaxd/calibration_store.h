#pragma once
// The installed calibration of a display and the one before it (for `rollback`): the geometric
// calibration <file> and its photometric correction <stem>.photometry.json beside it
// (calibration/display/colour_correction.h), each with its .previous — the same files
// `parallax calibrate --out` maintains. The two are one version: installed together, rolled
// back together; a photometry file names the geometric calibration it belongs to (its content
// hash), so a pair torn apart (a crash between the two writes, a file copied by hand) is seen
// and its photometry left out, with the reason.
//
// Durability rules (issue 18): every file is written with a checksum, atomically and flushed
// to disk (temporary file, fsync, rename, fsync of the folder), and read back and verified
// before an install is reported done; `.previous` only ever receives a file that verified, so
// a damaged current file never replaces the last good calibration; at start-up a damaged
// current file with a good `.previous` gives the previous one, and says so. A file that does
// not describe this display (module count or resolution differ from the nominal) is refused
// as "not a calibration of it".

#include <exception>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calibration/display/colour_correction.h"
#include "calibration/display/display_model.h"

namespace parallax::daemon {

struct StoredCalibration {
  DisplayModel model;
  std::string source;   // the file it was read from: the current one, or .previous
  std::string refused;  // why the current file was passed over for .previous; empty if it was not
  // The photometric correction of the same version, when there is one that verifies and
  // belongs to `model`; else `photometryRefused` says why a file that was there is not used.
  std::optional<DisplayColourCorrection> photometry;
  std::string photometrySource;
  std::string photometryRefused;
};

class CalibrationStore {
 public:
  explicit CalibrationStore(std::string path) : path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  std::string previousPath() const { return path_ + ".previous"; }
  // <folder>/<stem>.photometry.json: calibration.json → calibration.photometry.json.
  std::string photometryPath() const;
  std::string previousPhotometryPath() const { return photometryPath() + ".previous"; }

  // The installed calibration when it verifies and fits `nominal`, else .previous when that
  // does (logged, `refused` says why); nullopt when there is no current file. Throws
  // InputError (file, field) when the current file is bad and no good .previous exists. The
  // photometry is that of the same version; a bad one is left out (photometryRefused), never
  // applied, and the geometry still loads.
  std::optional<StoredCalibration> loadFor(const DisplayModel& nominal) const;

  enum class Photometry { kKeep, kReplace };
  // Makes `model` (and, with kReplace, `photometry`: a correction, or none) the installed
  // version: the current files (only those that verify) become .previous, then the new ones
  // are written durably and read back. kKeep carries the current photometric correction over
  // to the new geometry (a geometric recalibration does not change the modules' colours).
  // Returns what is now installed once it is on disk; throws InputError naming the file and
  // the reason otherwise (a full disk), with every file (.previous too) as it was before.
  StoredCalibration install(const DisplayModel& model, Photometry mode = Photometry::kKeep,
                            const std::optional<DisplayColourCorrection>& photometry = {}) const;
  // Swaps the current and previous versions, geometry and photometry together; returns the one
  // now installed. Throws InputError when there is no previous calibration, or when it (or
  // its photometry) does not verify or fit `nominal`, or a write fails — with every file as it
  // was. A current file that does not verify is dropped, not kept as .previous.
  StoredCalibration rollback(const DisplayModel& nominal) const;

  // Every file of the store (current and previous, geometry and photometry) byte for byte, or
  // its absence: what `restore` puts back. An install or rollback that is undone (it failed
  // part way; in a cluster, another rank could not take it) must leave .previous as it was
  // too, else a later `rollback` would go to the very calibration that was undone.
  struct Files {
    std::vector<std::pair<std::string, std::optional<std::string>>> contents;  // path, bytes
  };
  // Throws InputError naming a file that is there but cannot be read (a folder, too large):
  // what cannot be put back is not replaced.
  Files files() const;
  // Makes the store's files exactly `before` again (files already so are not rewritten).
  void restore(const Files& before) const;

  // InputError unless `candidate` has the nominal's module count and resolutions.
  static void requireSameDisplay(const DisplayModel& nominal, const DisplayModel& candidate,
                                 const std::string& file);
  // InputError naming `file` and the field unless `photometry` has a module for each of the
  // nominal's and was fitted with `geometry` (when it records one).
  static void requireMatchingPhotometry(const DisplayModel& nominal, const DisplayModel& geometry,
                                        const DisplayColourCorrection& photometry,
                                        const std::string& file);

 private:
  // Rethrows `failure` once the files are `before` again; when they cannot be put back, an
  // InputError saying both.
  [[noreturn]] void undoAfter(const Files& before, const std::exception_ptr& failure) const;
  // install and rollback themselves, undone by the callers above when they throw.
  StoredCalibration installOver(const DisplayModel& model, Photometry mode,
                                const std::optional<DisplayColourCorrection>& photometry) const;
  StoredCalibration swapVersions(const DisplayModel& nominal) const;

  std::string path_;
};

}  // namespace parallax::daemon
