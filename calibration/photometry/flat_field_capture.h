#pragma once
// Photometric capture: flat fields shown by every module, photographed by the calibration
// camera from its stations, reduced to what the fit needs — per module, samples of its light
// at known module pixels.
//
// The modules show uniform frames group by group (every n-th module at once, the others black,
// as the geometric capture does): a black frame, then each channel alone at each level. The
// geometric calibration says, per camera pixel, which module pixel it sees and through how much
// of the screen's diffusion lobe (the strongest lobe weight, kept when ≥ minLobeWeight), so a
// picture minus the black picture, over the lobe weight, is that module pixel's light for that
// channel and level. The camera's response (metadata's gamma) is inverted and its exposure
// divided out, so pictures at different exposures compare.
//
// Pictures the camera cannot give right are retaken: saturated (more than 0.1% of the module
// pixels looked at are at full scale) at half the exposure, up to maxRetakes times; an
// all-black picture (lens covered, camera failed) once. If that does not help, the capture is
// refused (PhotometricCaptureError naming the station, module group and frame).

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "calibration/camera/calibration_camera.h"
#include "calibration/display/display_model.h"

namespace parallax {

struct FlatFieldOptions {
  // Codes of each channel's flat fields (0, the black picture, always comes first); the last
  // must be 255.
  std::vector<int> levels{16, 40, 80, 128, 180, 255};
  int groupStride = 3;
  double exposure = 0.7;       // relative: recorded linear = exposure × light (white = 1)
  int maxRetakes = 3;          // saturated pictures: the exposure halves each time
  double minLobeWeight = 0.6;  // camera pixels nearer a module's lobe peak than this
  int pixelStep = 2;           // every n-th camera pixel each way

  // Throws InputError naming the field.
  void validate() const;
};

// The camera, given what each module shows: frames[i] is module i's RGB8 frame (its
// resolution, row-major); returns the picture as recorded (CV_32FC3, values 0..1, the
// camera's response not undone). An empty Mat: the camera gave no picture.
using FlatFieldCamera = std::function<cv::Mat(
    int station, const std::vector<const std::uint8_t*>& frames, double exposure)>;

struct FlatFieldSample {
  float u = 0, v = 0;  // module pixel position (centres at +0.5)
  float weight = 0;    // lobe weight
};

struct ModuleFlatFields {
  std::vector<FlatFieldSample> samples;
  // light[shot][sample]: the sample's light (picture over exposure, ambient removed, over the
  // lobe weight). Shot 0 is black; shot 1 + c · levels + l is channel c at levels[l].
  std::vector<std::vector<Eigen::Vector3f>> light;
  // black[sample]: the black picture over every module's lobe weight there (they all show
  // black in it): the module's black level.
  std::vector<Eigen::Vector3f> black;
};

struct FlatFieldCaptures {
  FlatFieldOptions options;
  int moduleWidth = 0, moduleHeight = 0;
  std::vector<ModuleFlatFields> modules;
  int pictures = 0, retakes = 0;
  double captureSeconds = 0.0;  // camera time included
  int shotCount() const { return 1 + 3 * static_cast<int>(options.levels.size()); }
};

class PhotometricCaptureError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// `model` is the geometric calibration (installed or just fitted); `poses` the camera's pose at
// every station (the fit's), `intrinsics` the camera's at the resolution of its pictures.
FlatFieldCaptures captureFlatFields(const DisplayModel& model, const CameraIntrinsics& intrinsics,
                                    const std::vector<CameraPose>& poses, double responseGamma,
                                    const FlatFieldCamera& camera, const FlatFieldOptions& options);

}  // namespace parallax
