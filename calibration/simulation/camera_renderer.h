#pragma once
// The simulated calibration camera's pictures of the screen while the modules show given
// images. Physics kept: the camera (pinhole + radial distortion, a pose) looks at the screen;
// each camera pixel sees one screen point s; every module lights s from its own pixel (u, v)
// = its projection of s, and the screen sends that light toward the camera weighted by the
// HPO diffusion lobe — a Gaussian in the horizontal angle between the transferred ray and the
// direction to the camera (calibration/camera/calibration_geometry.h's stripeAngle) whose full
// width at half maximum is the display's diffusion width; vertically the lobe is wide (taken
// as flat). So from one station each module appears as a vertical stripe. Then ambient
// light, the lens blur, the sensor's gamma and noise.
// The fiducial markers (calibration_camera.h's screenFiducials) are bright discs on the screen
// frame, lit in every picture: an additive constant per pixel, which the structured-light
// decoding cancels (it works on differences and ratios) and the fiducial detector finds in
// the black reference frame.
//
// A StationView caches, per camera pixel, the modules that reach it (the geometry is the same
// for every frame of a station), so rendering a frame is a weighted lookup.

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <span>
#include <vector>

#include "calibration/camera/calibration_camera.h"
#include "calibration/display/display_model.h"
#include "calibration/simulation/seeded_random.h"

namespace parallax {

struct CameraRenderOptions {
  double ambient = 0.02;            // linear light everywhere on the screen (white = 1)
  double gamma = 2.2;               // recorded value = linear^(1/gamma)
  double noiseSigma = 0.004;        // sensor noise in recorded units (full scale 1)
  double blurSigmaPx = 0.6;         // lens blur (Gaussian σ, camera px); 0 = none
  double minLobeWeight = 1e-3;      // contributions below this are dropped
  double fiducialRadiusM = 0.012;   // marker disc radius on the screen frame; 0 = no markers
  double fiducialBrightness = 0.8;  // linear light of a marker

  void validate() const;
};

struct LobeContribution {
  int module = -1;
  float u = 0.0f, v = 0.0f;  // module pixel position (centres at +0.5)
  float weight = 0.0f;
};

// Every module whose lobe reaches a pixel above minLobeWeight, however many: keeping only the
// strongest few once dropped a lit module's light wherever dark neighbours were stronger,
// which cut one flank of the lit modules' stripes and biased their peaks (±0.4 mm at demo's
// oblique stations).
struct StationView {
  int width = 0, height = 0;
  std::vector<uint32_t> first;  // per pixel (row-major), plus one: its range in `contributions`
  std::vector<LobeContribution> contributions;  // per pixel, strongest first
  cv::Mat markers;  // CV_32F: the fiducial markers' light, added to every frame
  std::span<const LobeContribution> at(int x, int y) const {
    const size_t i = static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x);
    return {contributions.data() + first[i], first[i + 1] - first[i]};
  }
};

StationView viewFromStation(const DisplayModel& truth, const CameraIntrinsics& intrinsics,
                            const CameraPose& pose, const CameraRenderOptions& options);

// One recorded frame (CV_32F, values in [0, 1]). moduleImages[i] is module i's image (CV_32F,
// linear, its resolution) or empty for a dark module.
cv::Mat renderFrame(const StationView& view, const std::vector<cv::Mat>& moduleImages,
                    const CameraRenderOptions& options, SeededRandom& random);

// What the sensor makes of the light reaching it (CV_32F, linear): the lens blur, the response
// curve, then the noise drawn from `random`; values in [0, 1]. renderFrame ends with it, and
// so does every other picture the simulated camera takes (checkerboard_renderer.h).
cv::Mat recordThroughSensor(const cv::Mat& linear, const CameraRenderOptions& options,
                            SeededRandom& random);

// The inverse of the sensor response: recorded → linear (decoders work in linear light).
cv::Mat linearFromRecorded(const cv::Mat& recorded, double gamma);

}  // namespace parallax
