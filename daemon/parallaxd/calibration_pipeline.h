#pragma once
// The one calibration pipeline, run by both `parallax calibrate` and parallaxd's calibrate
// stage: pictures (a camera by name, hw/camera/camera_name.h, while the modules show the
// patterns through the link; or a captures folder) → decode → fit → quality gate. Both take
// their settings from CalibrationSettings — one default here, changed by the command's flags
// or the daemon's [calibration] section — and both install through the one CalibrationStore
// (calibration_store.h). Nothing here installs: the tool installs at once, the daemon after
// the ray textures of the new model are made, so a failure leaves the old calibration in place.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calibration/capture/calibration_captures.h"
#include "calibration/display/display_model.h"
#include "calibration/display/screen_transfer.h"
#include "calibration/fit/display_fit.h"
#include "calibration/photometry/flat_field_capture.h"
#include "calibration/photometry/photometric_fit.h"
#include "daemon/parallaxd/daemon_config.h"
#include "hw/camera/calibration_capture.h"
#include "hw/camera/folder_camera.h"
#include "hw/link/camera_settings.h"
#include "hw/link/link_client.h"

namespace parallax::daemon {

// What a calibration calibrates: the geometry only, the geometry and the modules' colours, or
// the colours only (the installed geometry kept; the pictures of the patterns are still taken,
// to find where the camera stands, with every module held).
enum class PhotometricMode { kOff, kOn, kOnly };
// "off", "on", "only"; InputError naming `field` otherwise.
PhotometricMode parsePhotometricMode(const std::string& text, const std::string& field);
std::string_view photometricModeName(PhotometricMode mode);

struct CalibrationSettings {
  std::string camera = "link";  // camera_name.h
  std::string cameraMetadata;   // camera.json: intrinsics, response, tape-measured stations
  std::vector<int> stations;    // empty: every station of the metadata
  // Every n-th camera pixel decoded each way (and stripe centres on every n-th row). On the
  // simulated demo display (seed 7, 640x360 camera) steps 2, 4 and 6 reach 0.124, 0.120 and
  // 0.117 module px RMS: 4 decodes a quarter of the pixels of 2 for the same rays.
  int pixelStep = 4;
  int threads = 2;  // solver threads
  std::optional<ScreenTransfer> transfer;
  GateLimits gate;
  hw::CameraSettings cameraSettings;
  // A camera whose controls do not lock (or cannot be read back) is used anyway: a warning,
  // and each picture's exposure measured from what it shows.
  bool allowAutoExposure = false;
  // Run before the pictures of each station with a camera that is not behind the link (a rig
  // moving it, or a prompt); "{station}" is replaced by the station number.
  std::string stationCommand;
  PhotometricMode photometric = PhotometricMode::kOff;
  // Flat-field samples only near each lobe's peak, where the fitted geometry's small angle
  // errors change the lobe weight least (its slope is steepest near 0.6).
  FlatFieldOptions flatFields{.minLobeWeight = 0.85};
  PhotometricFitOptions photometricFit;

  // Throws InputError naming the field (`prefix` + name: "--" for flags, "calibration." for
  // the config).
  void validate(const std::string& prefix) const;
};

// The pipeline's settings with the config's changes; `simulatorPhotometric`: the display is a
// simulator parallaxd started with photometric variation (what "auto" turns on for).
CalibrationSettings settingsOf(const CalibrationConfig& config, bool simulatorPhotometric = false);

// What the pipeline reports as it goes, in its order: the pictures (capture), the picture sets
// decoded (decode), the fit's steps and their solver iterations (fit). Every member optional.
struct PipelineProgress {
  // calibrateThroughLink: one line for a status, at each of the counts below ("pictures: 3 of
  // 96", "decoding: picture set 2 of 4", "fitting: step 3 of 9, conical: final solve").
  std::function<void(const std::string& stage)> stage;
  std::function<void(int done, int total)> pictures;          // during the capture
  std::function<void(int done, int total)> decoded;           // picture sets, during the decode
  std::function<void(const FitStep& step)> fitStep;           // as each fit step starts
  std::function<void(int iteration)> iteration;               // during each fit step's solve
  std::function<void(const std::string& line)> note;          // warnings and facts for the log
  std::function<void(const hw::CaptureSyncStats&)> captured;  // how the camera kept up
  // Asks the operator to move a camera that is not behind the link to `station` and returns
  // once it stands there (the tool's prompt); unset, and without a station command, only one
  // station can be photographed.
  std::function<void(int station)> moveCamera;
  // A folder: camera asks for a picture (the frame on the screen, the file to save it as).
  std::function<void(const hw::PictureRequest&)> pictureRequest;
};

// The pictures through the link: the modules show the patterns, `settings.camera` takes them
// (opened and locked here; refused, naming the control, when it does not lock and
// allowAutoExposure is off). Without a link (nullptr), offline: only a folder: camera, from
// the pictures already in its folder. Throws InputError for bad metadata or camera names,
// std::runtime_error with one line otherwise, hw::CalibrationCancelled once `cancelled()`.
// `screen`: where the patterns are shown when not every module is behind `link` (a cluster's
// ranks); the camera is still `link`'s.
CalibrationCaptures capturePictures(hw::LinkClient* link, const DisplayModel& nominal,
                                    const CalibrationSettings& settings,
                                    const PipelineProgress& progress,
                                    const std::function<bool()>& cancelled,
                                    hw::PatternScreen* screen = nullptr);

// Decoding with the settings' pixel step; progress.decoded after each picture set.
CalibrationObservations decodePictures(const CalibrationCaptures& captures,
                                       const DisplayModel& nominal,
                                       const CalibrationSettings& settings,
                                       const PipelineProgress& progress);

// The fit from `start` (the nominal, or the current calibration when refitting `onlyModule`
// with every other module and the curvature held) with the settings' solver and gate.
// Returns the result whether or not it passes the gate (FitResult::passesQualityChecks), and
// with `stopped` set when `cancelled()` became true.
FitResult fitObservations(const DisplayModel& start, const CalibrationObservations& observations,
                          const CalibrationSettings& settings, std::optional<int> onlyModule,
                          const PipelineProgress& progress, const std::function<bool()>& cancelled);

struct PhotometricRun {
  // The correction (its summary filled in: photometric_residual.h), the per-module figures and
  // exclusions.
  PhotometricCalibration calibration;
  int pictures = 0, retakes = 0;
  double seconds = 0.0;
  std::string summary;  // one paragraph: pictures, exclusions, ΔE, non-uniformity
  std::string report;   // PhotometricCalibration::describe
};

// The photometric stage through the link, on the geometric calibration `geometry`: flat fields
// from `stations` (station numbers) with the camera at `poses` (the fit's, one a station).
// Throws PhotometricCaptureError for a camera that saturates or gives black pictures or when no
// module can be calibrated, std::runtime_error for a camera that does not lock, InputError for
// bad metadata, hw::CalibrationCancelled once `cancelled()`. Modules that cannot join (dead,
// unseen, a gamut far outside) are excluded and named in the result, not refused.
PhotometricRun calibratePhotometry(hw::LinkClient& link, const DisplayModel& geometry,
                                   const std::vector<int>& stations,
                                   const std::vector<CameraPose>& poses,
                                   const CalibrationSettings& settings,
                                   const PipelineProgress& progress,
                                   const std::function<bool()>& cancelled);

// The stations a session photographed from (those with correspondences), and the camera's
// pose the fit found at each; std::runtime_error when the fit placed none at one of them.
std::vector<int> photographedStations(const CalibrationObservations& observations);
std::vector<CameraPose> fittedPoses(const FitResult& result, const std::vector<int>& stations);

struct CalibrationRun {
  DisplayModel model;   // the fitted display (kOnly: the installed one, unchanged)
  std::string summary;  // formatFitSummary
  std::string report;   // formatFitReport (per module)
  std::optional<PhotometricRun> photometry;  // with the photometric stage
};

// The whole pipeline through the link, as the daemon runs it: capturePictures, decodePictures,
// fitObservations, and the gate, then (settings.photometric) calibratePhotometry — whose
// failure fails the whole run: nothing is half installed. Returns a fit that passed, or throws with
// the reason (hw::CalibrationCancelled when cancelled: asked between pictures, between stages and
// at every solver iteration). With a `screen` (a cluster: the patterns on every rank's modules,
// the camera behind `link`), the geometry only: photometric is refused, naming why.
CalibrationRun calibrateThroughLink(hw::LinkClient& link, const DisplayModel& nominal,
                                    const DisplayModel& start, const CalibrationSettings& settings,
                                    std::optional<int> onlyModule, const PipelineProgress& progress,
                                    const std::function<bool()>& cancelled,
                                    hw::PatternScreen* screen = nullptr);

}  // namespace parallax::daemon
