#include "daemon/parallaxd/calibration_stage.h"

#include <fmt/format.h>

#include <atomic>
#include <stdexcept>

#include "calibration/capture/calibration_captures.h"
#include "calibration/fit/display_fit.h"
#include "calibration/fit/fit_report.h"
#include "hw/camera/calibration_capture.h"
#include "hw/camera/camera.h"

namespace parallax::daemon {

CalibrationRun calibrateThroughLink(hw::LinkClient& link, const DisplayModel& nominal,
                                    const DisplayModel& start, const CalibrationConfig& config,
                                    std::optional<int> onlyModule,
                                    const std::function<void(const std::string&)>& progress,
                                    const std::function<bool()>& cancelled) {
  if (config.camera.empty()) {
    throw InputError({"", "calibration.camera", 0},
                     "calibrating needs the camera's metadata (camera.json)");
  }
  const CameraMetadata camera = loadCameraMetadata(config.camera);
  requireKnownIntrinsics(camera, config.camera, "calibrating through the link");
  // The camera behind the link: parallax-simhw's, or a real one answering capture requests.
  hw::SimulatedCamera device(link);
  hw::CalibrationCaptureOptions capture;
  // The capture asks a flag between pictures, right after reporting progress: the flag is
  // refreshed from the predicate there.
  std::atomic<bool> captureCancelled{cancelled()};
  const CalibrationCaptures captures = hw::captureCalibration(
      link, device, nominal, camera, capture,
      [&](int done, int total) {
        progress(fmt::format("pictures: {} of {}", done, total));
        captureCancelled = cancelled();
      },
      &captureCancelled);
  // Decoding takes seconds and is not interrupted: a `cancel` meanwhile is seen after it.
  const auto stopIfCancelled = [&cancelled] {
    if (cancelled()) throw hw::CalibrationCancelled();
  };
  stopIfCancelled();
  progress("decoding the pictures");
  CaptureDecoderOptions decoder;
  decoder.patterns = capture.patterns;
  decoder.pixelStep =
      6;  // every 6th camera pixel each way: plenty of correspondences, seconds not minutes
  const CalibrationObservations observations = decodeCaptures(captures, nominal, decoder);
  progress(fmt::format("fitting ({} correspondences)", observations.correspondences.size()));
  FitOptions fit;
  fit.threads = 2;
  fit.stopRequested = cancelled;
  if (onlyModule) {
    // One replaced module: the others and the screen stay as calibrated.
    for (int m = 0; m < static_cast<int>(start.modules.size()); ++m) {
      if (m != *onlyModule) fit.heldModules.push_back(m);
    }
    fit.fitCurvature = false;
  }
  stopIfCancelled();
  const FitResult result = fitDisplay(start, observations, fit);
  stopIfCancelled();
  CalibrationRun run{result.model, formatFitSummary(result), formatFitReport(result)};
  if (!result.passesQualityChecks()) {
    throw std::runtime_error("the fit failed its quality checks, nothing installed: " +
                             run.summary);
  }
  return run;
}

}  // namespace parallax::daemon
