#include "daemon/parallaxd/calibration_pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "calibration/fit/fit_report.h"
#include "calibration/photometry/photometric_residual.h"
#include "common/check.h"
#include "common/input_error.h"
#include "hw/camera/calibration_capture.h"
#include "hw/camera/camera.h"
#include "hw/camera/camera_name.h"
#include "hw/camera/flat_field_session.h"

namespace parallax::daemon {
namespace {

// Runs the station command with "{station}" replaced; a failing command stops the session.
void runStationCommand(const std::string& command, int station) {
  std::string line = command;
  for (size_t at = line.find("{station}"); at != std::string::npos;
       at = line.find("{station}", at)) {
    line.replace(at, 9, std::to_string(station));
  }
  const int status = std::system(line.c_str());
  if (status != 0) {
    throw std::runtime_error(fmt::format(
        "station {}: the station command \"{}\" failed (status {})", station, line, status));
  }
}

}  // namespace

PhotometricMode parsePhotometricMode(const std::string& text, const std::string& field) {
  if (text == "off") return PhotometricMode::kOff;
  if (text == "on") return PhotometricMode::kOn;
  if (text == "only") return PhotometricMode::kOnly;
  throw InputError({"", field, 0},
                   fmt::format("must be off, on (geometry and colours) or only (colours), got "
                               "\"{}\"",
                               text));
}

std::string_view photometricModeName(PhotometricMode mode) {
  switch (mode) {
    case PhotometricMode::kOff:
      return "off";
    case PhotometricMode::kOn:
      return "on";
    case PhotometricMode::kOnly:
      return "only";
  }
  return "off";
}

void CalibrationSettings::validate(const std::string& prefix) const {
  // Flags spell the config's keys with dashes.
  const auto field = [&prefix](std::string key) {
    if (prefix == "--") std::replace(key.begin(), key.end(), '_', '-');
    return prefix + key;
  };
  if (hw::parseCameraName(camera, field("camera")).kind == hw::CameraKind::kFolder &&
      photometric != PhotometricMode::kOff) {
    throw InputError({"", field("photometric"), 0},
                     "a folder: camera takes the pattern pictures only; the flat fields need a "
                     "camera the tool drives (link or opencv:)");
  }
  if (pixelStep < 1 || pixelStep > 64)
    throw InputError({"", field("pixel_step"), 0}, "must be 1..64");
  if (threads < 1 || threads > 256) throw InputError({"", field("threads"), 0}, "must be 1..256");
  for (const auto& [value, name] : {std::pair{gate.worstPx, "max_error_px"},
                                    std::pair{gate.worstObserverMm, "max_observer_mm"}}) {
    if (!(std::isfinite(value) && value > 0.0))
      throw InputError({"", field(name), 0}, fmt::format("must be > 0, got {}", value));
  }
  flatFields.validate();
  photometricFit.validate();
}

CalibrationSettings settingsOf(const CalibrationConfig& config, bool simulatorPhotometric) {
  CalibrationSettings settings;
  settings.photometric =
      config.photometric == "on" || (config.photometric == "auto" && simulatorPhotometric)
          ? PhotometricMode::kOn
          : PhotometricMode::kOff;
  settings.camera = config.cameraName;
  settings.cameraMetadata = config.cameraMetadata;
  if (config.pixelStep) settings.pixelStep = *config.pixelStep;
  settings.allowAutoExposure = config.allowAutoExposure;
  settings.stationCommand = config.stationCommand;
  settings.gate.worstPx = config.maxErrorPx;
  settings.gate.worstObserverMm = config.maxObserverMm;
  settings.gate.allowPartial = config.allowPartial;
  return settings;
}

CalibrationCaptures capturePictures(hw::LinkClient* link, const DisplayModel& nominal,
                                    const CalibrationSettings& settings,
                                    const PipelineProgress& progress,
                                    const std::function<bool()>& cancelled,
                                    hw::PatternScreen* screen) {
  if (settings.cameraMetadata.empty()) {
    throw InputError({"", "calibration.camera_metadata", 0},
                     "calibrating needs the camera's metadata (camera.json)");
  }
  const CameraMetadata metadata = loadCameraMetadata(settings.cameraMetadata);
  requireKnownIntrinsics(metadata, settings.cameraMetadata,
                         link ? "calibrating through the link" : "calibrating from a folder");
  const hw::CameraName name = hw::parseCameraName(settings.camera, "camera");
  // The capture asks a flag between pictures, right after reporting progress: the flag is
  // refreshed from the predicate there, and by a folder: camera while it waits for a picture.
  std::atomic<bool> captureCancelled{cancelled()};
  hw::FolderCameraOptions folder;
  folder.cancelled = [&] { return captureCancelled = cancelled(); };
  folder.onRequest = progress.pictureRequest;
  if (!folder.onRequest && progress.note) {
    folder.onRequest = [&progress](const hw::PictureRequest& r) {
      progress.note(fmt::format("take the picture of {} (on the screen now) and save it as {}",
                                r.shows, r.path));
    };
  }
  std::unique_ptr<hw::Camera> camera = hw::openCamera(name, link, folder);

  hw::CalibrationCaptureOptions capture;
  capture.stations = settings.stations;
  capture.cameraSettings = settings.cameraSettings;
  capture.allowUnlockedCamera = settings.allowAutoExposure;
  capture.onUnlocked = [&](const std::string& what) {
    if (progress.note)
      progress.note(
          fmt::format("warning: {}: {}; going on (allow auto exposure): each "
                      "picture's exposure is measured from what it shows",
                      camera->name(), what));
  };
  const size_t stationCount =
      settings.stations.empty() ? metadata.stations.size() : settings.stations.size();
  // Offline, the pictures were taken already: no camera to move.
  if (name.kind != hw::CameraKind::kLink && link) {
    if (!settings.stationCommand.empty()) {
      capture.beforeStation = [&](int station) {
        runStationCommand(settings.stationCommand, station);
      };
    } else if (progress.moveCamera) {
      capture.beforeStation = progress.moveCamera;
    } else if (stationCount > 1) {
      throw InputError({"", "calibration.station_command", 0},
                       fmt::format("{} is not behind the link and cannot move itself between "
                                   "the {} stations: give a station command (a rig) or one station",
                                   settings.camera, stationCount));
    }
  }
  hw::CaptureSyncStats stats;
  const auto pictures = [&](int done, int total) {
    if (progress.pictures) progress.pictures(done, total);
    captureCancelled = cancelled();
  };
  // The patterns go to every module: through the link, or the cluster's ranks (`screen`).
  std::optional<hw::LinkPatternScreen> linkScreen;
  if (link && !screen) screen = &linkScreen.emplace(*link);
  CalibrationCaptures captures =
      link ? hw::captureCalibration(*screen, *camera, nominal, metadata, capture, pictures,
                                    &captureCancelled, &stats)
           : hw::captureCalibrationOffline(*camera, nominal, metadata, capture, pictures,
                                           &captureCancelled, &stats);
  if (progress.captured) progress.captured(stats);
  return captures;
}

CalibrationObservations decodePictures(const CalibrationCaptures& captures,
                                       const DisplayModel& nominal,
                                       const CalibrationSettings& settings,
                                       const PipelineProgress& progress) {
  CaptureDecoderOptions decoder;
  decoder.patterns = captures.patterns;
  decoder.pixelStep = settings.pixelStep;
  decoder.onPictureSet = progress.decoded;
  if (progress.decoded) progress.decoded(0, static_cast<int>(captures.stations.size()));
  return decodeCaptures(captures, nominal, decoder);
}

FitResult fitObservations(const DisplayModel& start, const CalibrationObservations& observations,
                          const CalibrationSettings& settings, std::optional<int> onlyModule,
                          const PipelineProgress& progress,
                          const std::function<bool()>& cancelled) {
  FitOptions fit;
  fit.threads = settings.threads;
  fit.transfer = settings.transfer;
  fit.gate = settings.gate;
  fit.stopRequested = cancelled;
  if (progress.iteration)
    fit.onIteration = [&](int iteration, double) { progress.iteration(iteration); };
  fit.onStep = progress.fitStep;
  if (settings.photometric == PhotometricMode::kOnly) {
    // Only where the camera stood: every module and the screen stay as installed.
    for (int m = 0; m < static_cast<int>(start.modules.size()); ++m) fit.heldModules.push_back(m);
    fit.fitCurvature = false;
  } else if (onlyModule) {
    // One replaced module: the others and the screen stay as calibrated.
    for (int m = 0; m < static_cast<int>(start.modules.size()); ++m) {
      if (m != *onlyModule) fit.heldModules.push_back(m);
    }
    fit.fitCurvature = false;
  }
  return fitDisplay(start, observations, fit);
}

std::vector<int> photographedStations(const CalibrationObservations& observations) {
  std::vector<int> stations;
  for (const Correspondence& c : observations.correspondences)
    if (std::find(stations.begin(), stations.end(), c.camera) == stations.end())
      stations.push_back(c.camera);
  std::sort(stations.begin(), stations.end());
  return stations;
}

std::vector<CameraPose> fittedPoses(const FitResult& result, const std::vector<int>& stations) {
  std::vector<CameraPose> poses;
  for (int station : stations) {
    const auto fitted = std::find_if(result.cameras.begin(), result.cameras.end(),
                                     [station](const CameraFit& c) { return c.camera == station; });
    if (fitted == result.cameras.end())
      throw std::runtime_error(fmt::format("the fit placed no camera at station {}", station));
    poses.push_back(fitted->pose);
  }
  return poses;
}

PhotometricRun calibratePhotometry(hw::LinkClient& link, const DisplayModel& geometry,
                                   const std::vector<int>& stations,
                                   const std::vector<CameraPose>& poses,
                                   const CalibrationSettings& settings,
                                   const PipelineProgress& progress,
                                   const std::function<bool()>& cancelled) {
  PARALLAX_CHECK_OP(stations.size(), ==, poses.size());
  const CameraMetadata metadata = loadCameraMetadata(settings.cameraMetadata);
  const hw::CameraName name = hw::parseCameraName(settings.camera, "camera");
  std::unique_ptr<hw::Camera> camera = hw::openCamera(name, &link);
  PhotometricRun run;
  FlatFieldCaptures captures;
  {
    // Locks the camera (colour) and puts the modules in pattern mode until it ends.
    hw::FlatFieldSession session(link, *camera, settings.cameraSettings);
    const int total = static_cast<int>(stations.size()) * settings.flatFields.groupStride *
                      (1 + 3 * static_cast<int>(settings.flatFields.levels.size()));
    int taken = 0, standing = -1;
    const FlatFieldCamera take = [&](int index, const std::vector<const std::uint8_t*>& frames,
                                     double exposure) {
      if (cancelled()) throw hw::CalibrationCancelled();
      const int station = stations[static_cast<size_t>(index)];
      if (station != standing && name.kind != hw::CameraKind::kLink) {
        // A camera not behind the link goes back to each station (it was left at the last).
        if (!settings.stationCommand.empty()) {
          runStationCommand(settings.stationCommand, station);
        } else if (progress.moveCamera) {
          progress.moveCamera(station);
        }
      }
      standing = station;
      if (progress.pictures) progress.pictures(++taken, total);
      return session.take(station, frames, exposure);
    };
    captures = captureFlatFields(geometry, metadata.intrinsics, poses, metadata.responseGamma, take,
                                 settings.flatFields);
  }
  if (progress.stage) progress.stage("fitting the modules' colours");
  run.calibration = fitPhotometry(captures, settings.photometricFit);
  run.calibration.correction.summary = measurePhotometricResidual(captures, run.calibration);
  run.pictures = captures.pictures;
  run.retakes = captures.retakes;
  run.seconds = captures.captureSeconds;
  const PhotometricSummary& summary = run.calibration.correction.summary;
  std::string excluded;
  for (const ModulePhotometricFigures& m : run.calibration.modules)
    if (m.excluded) excluded += fmt::format("; module {} excluded: {}", m.module, m.reason);
  run.summary = fmt::format(
      "photometric calibration: {} flat-field pictures ({} retaken) in {:.1f} s; a flat grey "
      "through the correction, on the pictures: CIEDE2000 mean {:.2f}, worst {:.2f}, brightness "
      "non-uniformity {:.1f}%; target white {:.3f} (an ideal module's = 1){}",
      run.pictures, run.retakes, run.seconds, summary.deltaEMean, summary.deltaEWorst,
      100.0 * summary.nonUniformity, run.calibration.targetWhiteLuminance, excluded);
  run.report = run.calibration.describe();
  return run;
}

CalibrationRun calibrateThroughLink(hw::LinkClient& link, const DisplayModel& nominal,
                                    const DisplayModel& start, const CalibrationSettings& settings,
                                    std::optional<int> onlyModule, const PipelineProgress& progress,
                                    const std::function<bool()>& cancelled,
                                    hw::PatternScreen* screen) {
  if (screen && settings.photometric != PhotometricMode::kOff) {
    throw std::runtime_error(
        "the modules' colours (photometric) are calibrated through one link only: calibrate "
        "them with one rank (parallaxd without mpirun), or calibrate the geometry alone "
        "(photometric off)");
  }
  const auto stage = [&](const std::string& what) {
    if (progress.stage) progress.stage(what);
  };
  PipelineProgress pictures = progress;
  pictures.captured = [&](const hw::CaptureSyncStats& stats) {
    if (progress.captured) progress.captured(stats);
    if (progress.note) progress.note(settings.camera + ": " + stats.describe());
  };
  pictures.pictures = [&](int done, int total) {
    if (progress.pictures) progress.pictures(done, total);
    stage(fmt::format("pictures: {} of {}", done, total));
  };
  const CalibrationCaptures captures =
      capturePictures(&link, nominal, settings, pictures, cancelled, screen);
  // Decoding takes seconds and is not interrupted: a `cancel` meanwhile is seen after it.
  const auto stopIfCancelled = [&cancelled] {
    if (cancelled()) throw hw::CalibrationCancelled();
  };
  stopIfCancelled();
  PipelineProgress decoding = progress;
  decoding.decoded = [&](int done, int total) {
    if (progress.decoded) progress.decoded(done, total);
    stage(fmt::format("decoding: picture set {} of {}", done, total));
  };
  const CalibrationObservations observations =
      decodePictures(captures, nominal, settings, decoding);
  stopIfCancelled();
  PipelineProgress fitting = progress;
  fitting.fitStep = [&](const FitStep& step) {
    if (progress.fitStep) progress.fitStep(step);
    stage(fmt::format("fitting: step {} of {}, {}", step.index, step.total, step.what));
  };
  const FitResult result =
      fitObservations(start, observations, settings, onlyModule, fitting, cancelled);
  stopIfCancelled();
  const bool colourOnly = settings.photometric == PhotometricMode::kOnly;
  CalibrationRun run{colourOnly ? start : result.model, formatFitSummary(result),
                     formatFitReport(result), std::nullopt};
  if (!result.passesQualityChecks()) {
    throw std::runtime_error(fmt::format("the {} failed its quality checks, nothing installed: {}",
                                         colourOnly ? "camera's placement" : "fit", run.summary));
  }
  if (settings.photometric == PhotometricMode::kOff) return run;
  // The camera where the fit placed it at every station it photographed from.
  const std::vector<int> stations = photographedStations(observations);
  const std::vector<CameraPose> poses = fittedPoses(result, stations);
  stage("photometric: flat fields");
  PipelineProgress flat = progress;
  flat.pictures = [&](int done, int total) {
    if (progress.pictures) progress.pictures(done, total);
    stage(fmt::format("photometric: flat fields: {} of {}", done, total));
  };
  run.photometry = calibratePhotometry(link, run.model, stations, poses, settings, flat, cancelled);
  if (progress.note) progress.note(run.photometry->summary);
  return run;
}

}  // namespace parallax::daemon
