#pragma once
// The calibrate stage through the link: patterns out to the modules, captures in through the
// camera, decoded and fitted (calibration/fit/display_fit.h), then the quality gate. It returns a
// fit that passed, or throws with the reason; it never installs anything itself (the conductor
// does, after regenerating the textures, so a failure leaves the old calibration in place).

#include <functional>
#include <optional>
#include <string>

#include "calibration/display/display_model.h"
#include "daemon/parallaxd/daemon_config.h"
#include "hw/link/link_client.h"

namespace parallax::daemon {

struct CalibrationRun {
  DisplayModel model;   // the fitted display
  std::string summary;  // formatFitSummary
  std::string report;   // formatFitReport (per module)
};

// `start` is the model the fit starts from (the nominal, or the current calibration for a
// refit of one module: `onlyModule`, every other module held). Throws std::runtime_error
// (or InputError for bad camera metadata) with a one-line reason, and hw::CalibrationCancelled
// once `cancelled()` is true (asked between pictures, between stages and at every solver
// iteration; from the calibrating thread).
CalibrationRun calibrateThroughLink(hw::LinkClient& link, const DisplayModel& nominal,
                                    const DisplayModel& start, const CalibrationConfig& config,
                                    std::optional<int> onlyModule,
                                    const std::function<void(const std::string&)>& progress,
                                    const std::function<bool()>& cancelled);

}  // namespace parallax::daemon
