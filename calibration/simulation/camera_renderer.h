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
// A StationView caches, per render pixel, the modules that reach it (the geometry is the same
// for every frame of a station), so rendering a frame is a weighted lookup.
// A real lens blurs the continuous image before the pixels sample it; blurring the rendered
// samples instead is the same only while the patterns have many samples a period. From far
// away a camera pixel spans several module pixels (4.3 on demo from 10 m with a 640×360
// camera: four samples a 16-px phase period), and the blurred samples then shift each decoded
// position by less than the continuous blur does (the decoder's correction, capture_decoder's
// blurShift, assumes the latter): a bias every decode shares, which put the fitted screen
// curvature 0.8–3.8σ off at 10 m. So
// a station that far is rendered finer (`supersampling` render pixels a camera pixel's side,
// odd, so that one sits at each camera pixel's centre), blurred there, and sampled at the
// camera pixels' centres.

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
  int width = 0, height = 0;  // the render grid: the camera's × supersampling
  int supersampling = 1;
  std::vector<uint32_t> first;  // per pixel (row-major), plus one: its range in `contributions`
  std::vector<LobeContribution> contributions;  // per pixel, strongest first
  cv::Mat markers;  // CV_32F, camera pixels: the fiducial markers' light, added to every frame
  std::span<const LobeContribution> at(int x, int y) const {
    const size_t i = static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x);
    return {contributions.data() + first[i], first[i + 1] - first[i]};
  }
};

StationView viewFromStation(const DisplayModel& truth, const CameraIntrinsics& intrinsics,
                            const CameraPose& pose, const CameraRenderOptions& options);

// Render pixels a camera pixel's side must be drawn with so that one spans at most 2 module
// pixels near the screen's centre (odd, at most 7).
int supersamplingFor(const DisplayModel& truth, const CameraIntrinsics& intrinsics,
                     const CameraPose& pose);

// The light of a supersampled view's render grid (CV_32F or CV_32FC3, markers not in it) as the
// camera pixels receive it: the lens blur at the render grid's scale, each camera pixel's centre
// sample, and the markers (blurred at the camera's scale) added.
cv::Mat cameraPixelLight(const cv::Mat& renderLight, const StationView& view, double blurSigmaPx);

// What the sensor makes of light already blurred by the lens: the response curve, then the
// noise drawn from `random`; values in [0, 1].
cv::Mat sensorResponse(const cv::Mat& linear, const CameraRenderOptions& options,
                       SeededRandom& random);

// One recorded frame (CV_32F, values in [0, 1]) at the camera's resolution. moduleImages[i] is
// module i's image (CV_32F, linear, its resolution) or empty for a dark module.
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
