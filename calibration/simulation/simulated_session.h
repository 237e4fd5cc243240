#pragma once
// A whole calibration session rendered offline from a ground truth: what the camera would
// record at every station while each module group shows the structured-light patterns — the
// same pictures a session over the link records from parallax-simhw, without the link.

#include <cstdint>
#include <functional>

#include "calibration/capture/calibration_captures.h"
#include "calibration/capture/checkerboard_captures.h"
#include "calibration/simulation/camera_truth.h"
#include "calibration/simulation/checkerboard_renderer.h"
#include "calibration/simulation/synthetic_observations.h"

namespace parallax {

struct SimulatedSessionOptions {
  StructuredLightOptions patterns;
  int groupStride = 3;  // every n-th module (or more: groupStrideFor) shows its patterns at once
  // The modules' own response: a pattern value v is shown as v^moduleGamma (projectors driven
  // without linearization; 1: linear, as the patterns assume).
  double moduleGamma = 1.0;
  // Modules that stay dark in every picture (a dead projector, or one no station sees): the
  // picture-path counterpart of SyntheticOptions::hiddenModules.
  std::vector<int> darkModules;
  // Called after every picture (done of total): a session of demo takes a minute or more.
  std::function<void(int done, int total)> onPicture;
};

// Pictures of every station (truth poses) and group, in linear light after the sensor's
// response and 8-bit quantisation (what a camera gives). `camera` is what the session knows
// (tape-measured stations, the intrinsics), stored in the result unchanged.
CalibrationCaptures renderSession(const DisplayModel& truth, const CameraTruth& cameraTruth,
                                  const CameraMetadata& camera,
                                  const SimulatedSessionOptions& options);

// A camera rig for a simulation: the tape-measured metadata and the camera's truth (true
// poses from simulateObservations' rig model, sensor defaults, gamma known to the metadata).
struct SimulatedRig {
  CameraMetadata metadata;
  CameraTruth truth;
};
SimulatedRig makeSimulatedRig(const DisplayModel& truth, const CameraRigOptions& rig,
                              std::uint64_t seed, const CameraRenderOptions& sensor = {});

// The camera's checkerboard pictures (checkerboard_renderer.h): seeded poses in front of the
// true camera, its sensor, noise from a stream of its own (the screen pictures stay the same).
CheckerboardCaptures simulateCheckerboardCaptures(const CameraTruth& camera,
                                                  const CheckerboardBoard& board,
                                                  const CheckerboardShotOptions& options);

// A camera as built: the datasheet's camera with a seeded manufacturing spread (focal length
// ~1%, aspect ~0.1%, principal point ~1% of the picture, k1 ±0.015, a small k2), so that a
// calibration from the checkerboard has something to find.
CameraIntrinsics cameraAsBuilt(const CameraIntrinsics& datasheet, std::uint64_t seed);

// The module pattern frames as a module shows them: 8-bit (quantised) values read back as linear.
std::vector<cv::Mat> quantisedPatternFrames(int width, int height, PatternAxis axis,
                                            const StructuredLightOptions& patterns);

}  // namespace parallax
