#pragma once
// Synthetic calibration data straight from a ground truth: what the decoder would hand the fit
// if the images were perfect up to a given camera noise, without rendering them. The stability
// suite runs on this (fast); the image path (simulated camera + patterns + decoding) produces
// the same CalibrationObservations from pictures.
//
// The physics kept: camera stations stand along the observer line (their true poses off the
// tape measure by up to `tapeErrorM`); each sees a module only where that module's light
// leaves the screen toward it, within half the screen's horizontal diffusion width — a
// vertical stripe; the stripe's centre is where the transfer sends the light exactly to the
// camera. Correspondences are sampled across each stripe, stripe centres once per sampled row.

#include <cstdint>
#include <vector>

#include "calibration/camera/calibration_observations.h"
#include "calibration/display/display_model.h"

namespace parallax {

struct CameraRigOptions {
  int stations = 5;
  double spanM = 1.6;        // first to last station along the observer line
  double tapeErrorM = 0.05;  // largest distance between a true and a tape-measured centre
  double aimErrorDeg = 1.0;  // each station aims at the screen centre within this
  CameraIntrinsics intrinsics;

  void validate() const;
};

struct SyntheticOptions {
  std::uint64_t seed = 1;
  CameraRigOptions rig;
  double noisePx = 0.3;  // camera noise on correspondences and stripe centres (σ, px)
  // Experiment (bench): the correspondences' noise on the module pixel (σ = noisePx module
  // px) and none on the camera pixel — the errors-in-variables comparison.
  bool noiseOnModulePx = false;
  double fiducialNoisePx = 0.1;  // fiducial corners are located more precisely
  double rowStepPx = 16.0;       // module rows sampled every rowStepPx
  int samplesAcrossStripe = 5;   // correspondences across a stripe per sampled row
  bool stripes = true;           // report stripe centres (the stripe-direction data)
  // false: every camera sees every module over the whole screen, as through a wide diffuser
  // (used for the degenerate case: no stripe geometry at all).
  bool lobeVisibility = true;
  double fullScreenStepPx = 24.0;  // module grid spacing when lobeVisibility is false
  double outlierFraction = 0.0;    // correspondences whose module pixel is decoded wrong
  std::vector<int> hiddenModules;  // modules the camera never sees (indices)

  // Throws InputError naming the option.
  void validate() const;
};

struct SyntheticCalibration {
  CalibrationObservations observations;
  std::vector<CameraPose> truePoses;  // for tests and reports only
};

SyntheticCalibration simulateObservations(const DisplayModel& truth,
                                          const SyntheticOptions& options);

// Tape-measured centres of a rig along the observer line (also the fit's starting poses).
std::vector<CameraStation> cameraStations(const DisplayModel& model, const CameraRigOptions& rig);

}  // namespace parallax
