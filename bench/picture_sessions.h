#pragma once
// Picture-path calibration sessions for the benchmark (issue 17): a ground truth, its camera
// rig rendered to pictures through the simulated sensor, the checkerboard's intrinsics (or the
// true ones) and the decoder's observations; and the picture half of the seed sweep over the
// setups of the synthetic one (tests/calibration/calibration_sweep_test.cpp).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "calibration/camera/calibration_observations.h"
#include "calibration/capture/checkerboard_calibration.h"
#include "calibration/display/display_model.h"
#include "calibration/simulation/camera_truth.h"

namespace parallax {

// What a session varies. The defaults are the bench's original picture setup (five stations
// over 4 m, the sensor's default noise).
struct PictureSessionOptions {
  int stations = 5;
  double spanM = 4.0;
  std::optional<double> sensorNoise;  // CameraRenderOptions::noiseSigma; default: the sensor's
  std::optional<double> blurSigmaPx;  // CameraRenderOptions::blurSigmaPx; default: the sensor's
  std::optional<ScreenTransfer> truthTransfer;  // default: the nominal's
  std::vector<int> darkModules;                 // modules that show nothing (never seen)
  bool trueIntrinsics = false;                  // else from simulated checkerboard pictures
  bool lensBlurStated = true;  // camera.json states the lens blur (else the decoder keeps its bias)
};

struct PictureSession {
  DisplayModel truth;
  CameraTruth camera;
  CameraIntrinsics intrinsicsUsed;
  std::optional<CheckerboardCalibration> checkerboard;  // unless the true intrinsics were used
  CalibrationObservations obs;
};

PictureSession renderPictureSession(const DisplayModel& nominal, std::uint64_t seed,
                                    const PictureSessionOptions& options);

// One of the sweep's setups by name: its nominal and the session's options (the checkerboard's
// intrinsics unless `trueIntrinsics`); false for an unknown name.
bool pictureSetupByName(const std::string& name, DisplayModel* nominal,
                        PictureSessionOptions* options);

struct PictureSweepOptions {
  std::string setup = "all";  // a setup's name, or "all"
  int seeds = 20;             // per setup, consecutive from 1000 as the synthetic sweep
  int firstSeed = 1000;
  int threads = 2;       // the fit's solver threads
  bool verbose = false;  // a line per run
  // GateLimits::allowPartial: the modules that pass are installed, the others held nominal.
  bool allowPartial = false;
};

// Prints the table (markdown) and the overall line; returns the number of installed modules
// beyond the gate's limits (0 when the gate held), or -1 for an unknown setup name.
int pictureSetupSweep(const PictureSweepOptions& options);

// The mapping of the synthetic sweep's camera noise (px) to the picture sensor's noise: the
// fit's re-estimated correspondence σ (module px) of both paths at a few levels, one seed.
void pictureNoiseMap(int threads);

}  // namespace parallax
