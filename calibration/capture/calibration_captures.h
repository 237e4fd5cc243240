#pragma once
// What a calibration session recorded, as a real installation has it: the camera's metadata
// (intrinsics, its response, the tape-measured stations — never the true poses), the pattern
// sequence, and per station and module group the pictures of every pattern frame in linear
// light. decodeCaptures turns it into CalibrationObservations for the fit, without the link.
//
// A captures folder on disk (written by `parallax simulate` and by a session over the link,
// read by `parallax calibrate --captures DIR`):
//   camera.json     observations_json.h's camera file, plus "response_gamma" (recorded
//                   value = linear^(1/gamma); 1 = linear) and "lens_blur_sigma_px" (optional:
//                   the σ of the lens's point spread in camera px, pixel area included)
//   patterns.json   {"format": "parallax-patterns", "version": 1, period_px, phase_steps,
//                    min_contrast, module_width, module_height,
//                    stations: [{station, group: [modules], columns: [file, ...], rows: [file,
//                    ...]}]}
//   NAME.png        the pictures as the camera recorded them (8-bit, its response curve);
//                   converted to linear light when loaded.
//   checkerboard.json, checkerboard/board_NN.png   (optional) the camera's pictures of a
//                   checkerboard (checkerboard_captures.h). With them camera.json holds only
//                   the picture size, and the intrinsics are calibrated from the board
//                   (calibrateCapturesCamera) before decoding.

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/camera/calibration_observations.h"
#include "calibration/capture/capture_decoder.h"
#include "calibration/capture/checkerboard_captures.h"
#include "calibration/capture/structured_light.h"
#include "calibration/display/display_model.h"

namespace parallax {

struct CameraMetadata {
  CameraIntrinsics intrinsics;  // from the camera's own (checkerboard) calibration
  IntrinsicsCovariance intrinsicsCovariance = IntrinsicsCovariance::Zero();  // zero: exact
  // false: camera.json gave only the picture size (fx, fy, cx, cy NaN); the intrinsics must
  // come from the checkerboard pictures before anything is decoded.
  bool intrinsicsKnown = true;
  double responseGamma = 1.0;  // recorded = linear^(1/gamma)
  // camera.json gave response_gamma (a simulated rig knows its sensor's). When it did not, the
  // decoder uses the response it measures from the phase pictures (camera_response.h).
  bool responseGammaStated = false;
  // The lens's blur (σ of its point spread, camera px), when camera.json states it
  // ("lens_blur_sigma_px"; a simulated rig knows its own): the decoder undoes the shift it gives
  // the phase patterns inside a lobe (capture_decoder.h). Not stated: the correspondences keep
  // that bias, and the fit's report says so.
  std::optional<double> lensBlurSigmaPx;
  std::vector<CameraStation> stations;     // tape-measured centres (cm accuracy)
  std::vector<Eigen::Vector2d> fiducials;  // marker places on the screen frame (x, y)
};

struct StationCaptures {
  int station = 0;
  std::vector<int> group;                        // the modules that showed the patterns
  std::vector<cv::Mat> columnFrames, rowFrames;  // linear light, CV_32F, makePatternFrames' order
};

struct CalibrationCaptures {
  CameraMetadata camera;
  StructuredLightOptions patterns;
  int moduleWidth = 0, moduleHeight = 0;  // the pattern frames' size
  std::vector<StationCaptures> stations;
  std::optional<CheckerboardCaptures> checkerboard;  // the camera's own calibration pictures

  // Throws InputError naming the field (frame counts, sizes, indices).
  void validate(const DisplayModel& nominal) const;
};

// Modules that show their patterns at once: every `stride`-th one, so that from one station
// the stripes of a group's modules lie several diffusion widths apart.
std::vector<std::vector<int>> moduleGroups(int modules, int stride);

// The smallest stride from `least` up (at most one module a group) at which, from every
// station (its tape-measured centre), a group partner whose lobe the screen's edge cuts puts at
// most kGroupLightShare of a module's own light anywhere on its stripe's flanks (on the nominal
// screen's middle row) (a whole lobe is fitted and subtracted from its neighbours' stripes; a cut
// one cannot be, and stripe_peak.h drops the stripes it lights). A display's lobes are a fixed
// share of its module pitch near the screen centre, but an oblique view squeezes far modules'
// angles together: on a 4-module display (42° lobes) module 3's cut lobe lit module 0's stripe from
// the end stations, which left the edge modules with too few stripes to be fitted.
inline constexpr double kGroupLightShare = 0.01;
int groupStrideFor(const DisplayModel& nominal, const std::vector<CameraStation>& stations,
                   int least = 3);

// Correspondences and stripe centres from the pattern pictures, fiducial sightings from the
// black reference picture of each station (fiducial_detector.h). `options.patterns` is
// replaced by the captures' own.
CalibrationObservations decodeCaptures(const CalibrationCaptures& captures,
                                       const DisplayModel& nominal,
                                       const CaptureDecoderOptions& options);

// The camera's intrinsics from the captures' checkerboard pictures (checkerboard_calibration.h)
// into captures->camera (intrinsicsKnown becomes true); the picture size stays camera.json's.
// Throws InputError naming the picture, or the field "pictures" when too few show the board.
CheckerboardCalibration calibrateCapturesCamera(CalibrationCaptures* captures,
                                                const CheckerboardCalibrationOptions& options = {});

// Throws InputError naming `file` and intrinsics.focal_px when the camera's intrinsics are not
// known (`purpose` says what needs them).
void requireKnownIntrinsics(const CameraMetadata& camera, const std::string& file,
                            const std::string& purpose);

// The camera metadata in CalibrationObservations' camera fields (no decoded data yet).
CalibrationObservations observationsFrame(const CameraMetadata& camera);

// A captures folder (see above). save writes the JSON files atomically; load checks every
// field and every image (readable, the camera's size) and names the file that is wrong.
void saveCaptures(const CalibrationCaptures& captures, const std::string& directory);
CalibrationCaptures loadCaptures(const std::string& directory);

// camera.json alone (what `parallax calibrate --link` starts from).
CameraMetadata loadCameraMetadata(const std::string& path);
void saveCameraMetadata(const CameraMetadata& camera, const std::string& path);

// Recorded 8-bit picture ↔ linear light through the camera's response.
cv::Mat linearFromRecorded8(const cv::Mat& recorded8, double gamma);
// The linear value at and above which an 8-bit picture of that response was clipped by the
// sensor: its top code (255), from halfway below it.
double clippedLinear(double gamma);
cv::Mat recorded8FromLinear(const cv::Mat& linear, double gamma);

}  // namespace parallax
