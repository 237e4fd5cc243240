// Patterns and decoding: exact on ideal intensities; and through the simulated camera (lobe,
// ambient, blur, gamma, noise) the decoded module coordinates match where the truth says each
// camera pixel's light comes from.

#include "calibration/capture/structured_light.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/conventions.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/optical_module.h"
#include "calibration/simulation/camera_renderer.h"
#include "calibration/simulation/ground_truth.h"

namespace parallax {
namespace {

TEST(StructuredLight, DecodesEveryPixelCentreExactly) {
  StructuredLightOptions options;
  for (PatternAxis axis : {PatternAxis::kColumns, PatternAxis::kRows}) {
    const int width = 200, height = 70;
    const auto frames = makePatternFrames(width, height, axis, options);
    const int extent = axis == PatternAxis::kColumns ? width : height;
    ASSERT_EQ(static_cast<int>(frames.size()),
              2 + grayBitCount(extent, options.periodPx) + options.phaseSteps);
    for (int i = 0; i < extent; ++i) {
      std::vector<float> intensities;
      for (const cv::Mat& f : frames) {
        // Dimmed and offset, as a camera would see it: the decode must not care.
        const float v = axis == PatternAxis::kColumns ? f.at<float>(3, i) : f.at<float>(i, 3);
        intensities.push_back(0.1f + 0.6f * v);
      }
      const auto u = decodePixel(intensities, extent, options);
      ASSERT_TRUE(u.has_value()) << i;
      EXPECT_NEAR(*u, i + 0.5, 1e-4) << i;
    }
  }
}

TEST(StructuredLight, LowContrastIsNotDecoded) {
  StructuredLightOptions options;
  std::vector<float> flat(2 + grayBitCount(64, options.periodPx) + options.phaseSteps, 0.3f);
  EXPECT_FALSE(decodePixel(flat, 64, options).has_value());
}

// A camera at `centre` aimed at the screen's centre.
CameraPose stationAt(const Eigen::Vector3d& centre) {
  CameraPose pose;
  pose.centre = centre;
  pose.physicalFromCamera = aimCameraAt(pose.centre, Eigen::Vector3d::Zero());
  return pose;
}

// A sensor that records the light as it arrives (the lens blur kept): no ambient light, noise,
// response curve or markers.
CameraRenderOptions linearNoiseless() {
  CameraRenderOptions render;
  render.ambient = 0.0;
  render.noiseSigma = 0.0;
  render.gamma = 1.0;
  render.fiducialRadiusM = 0.0;
  return render;
}

// The simulated camera sees every module whose lobe reaches a pixel, however many there are:
// with a white image on one module of three, a pixel's light is the sum of those modules'
// lobe weights, even where dark modules between them are stronger. (It once kept only the
// four strongest lobes of all modules, which cut the lit modules' stripes on one flank.)
TEST(StructuredLight, TheSimulatedCameraSeesEveryLitModulesLobe) {
  const DisplayModel truth = makeGroundTruth(resolveDisplay("demo"), {});
  const CameraIntrinsics intrinsics = CameraIntrinsics::centred(320, 180, 350.0, -0.05);
  const CameraPose pose = stationAt({-1.6, 0.0, 2.0});  // oblique, where the stripes crowd
  CameraRenderOptions render = linearNoiseless();
  render.blurSigmaPx = 0.0;
  const StationView view = viewFromStation(truth, intrinsics, pose, render);
  std::vector<cv::Mat> images(truth.modules.size());
  for (size_t m = 1; m < truth.modules.size(); m += 3) {
    images[m] = cv::Mat(truth.modules[m].height, truth.modules[m].width, CV_32F, cv::Scalar(0.25f));
  }
  SeededRandom random(1);
  const cv::Mat frame = renderFrame(view, images, render, random);
  const double sigma = diffusionSigma(truth.screen.diffusionDeg);
  const auto camera = packCamera(pose);
  int compared = 0;
  for (int y = 10; y < intrinsics.height; y += 40) {
    for (int x = 0; x < intrinsics.width; ++x) {
      const Eigen::Vector2d n = intrinsics.normalized({x + 0.5, y + 0.5});
      Vec3<double> s;
      if (!screenPointOfCameraRay(truth.screen.curvature, camera.data(), n.x(), n.y(), &s) ||
          !truth.screen.contains(s.x(), s.y()))
        continue;
      double expected = 0.0;
      for (size_t m = 1; m < truth.modules.size(); m += 3) {
        const double a = stripeAngle(truth.screen, s, truth.modules[m].position, pose.centre);
        const double weight = std::exp(-0.5 * (a / sigma) * (a / sigma));
        if (weight < render.minLobeWeight) continue;
        Eigen::Vector2d uv;
        if (!ModuleOptics(truth.modules[m]).project(s - truth.modules[m].position, &uv) ||
            uv.x() < 1.0 || uv.y() < 1.0 || uv.x() > truth.modules[m].width - 1 ||
            uv.y() > truth.modules[m].height - 1) {
          expected = -1.0;  // near a module image's edge: sampling blends in its outside
          break;
        }
        expected += 0.25 * weight;
      }
      if (expected < 0.0) continue;
      EXPECT_NEAR(frame.at<float>(y, x), std::min(expected, 1.0), 1e-4) << x << "," << y;
      ++compared;
    }
  }
  EXPECT_GT(compared, 200);
}

// The light reaching camera pixel (x, y) without the lens, from the geometry alone: each module's
// lobe weight times its image, here a 16-px phase pattern cos(2π u / 16) + 1 (module px).
double unblurredLight(const DisplayModel& truth, const CameraIntrinsics& intrinsics,
                      const CameraPose& pose, double sigmaRad, double x, double y) {
  const Eigen::Vector2d n = intrinsics.normalized({x, y});
  Vec3<double> s;
  const auto camera = packCamera(pose);
  if (!screenPointOfCameraRay(truth.screen.curvature, camera.data(), n.x(), n.y(), &s) ||
      !truth.screen.contains(s.x(), s.y()))
    return 0.0;
  double light = 0.0;
  for (const OpticalModule& m : truth.modules) {
    const double a = stripeAngle(truth.screen, s, m.position, pose.centre);
    Eigen::Vector2d uv;
    if (!ModuleOptics(m).project(s - m.position, &uv) || uv.x() < 0.0 || uv.y() < 0.0 ||
        uv.x() > m.width || uv.y() > m.height)
      continue;
    light += std::exp(-0.5 * (a / sigmaRad) * (a / sigmaRad)) *
             (1.0 + std::cos(2.0 * M_PI * uv.x() / 16.0));
  }
  return light;
}

// From 10 m a camera pixel spans about 4 module pixels: a 16-px phase pattern has 4 samples a
// period. The lens blurs the continuous image before the pixels sample it; the simulated camera
// must too: blurring the samples themselves was 13% of the brightest pixel off here, and put the
// screen curvature fitted from such pictures 2σ off. Each pixel's light is compared with the
// Gaussian-weighted integral of the light around its centre (within 0.5% when rendered finer).
TEST(StructuredLight, TheLensBlursTheContinuousImageBeforeThePixelsSampleIt) {
  const DisplayModel truth = makeGroundTruth(resolveDisplay("demo"), {});
  const CameraIntrinsics intrinsics = CameraIntrinsics::centred(640, 360, 700.0, -0.04);
  const CameraPose pose = stationAt({0.2, 0.0, 10.0});
  CameraRenderOptions render = linearNoiseless();
  render.minLobeWeight = 1e-4;
  const StationView view = viewFromStation(truth, intrinsics, pose, render);
  EXPECT_GE(view.supersampling, 3);
  std::vector<cv::Mat> images;
  for (const OpticalModule& m : truth.modules) {
    cv::Mat image(m.height, m.width, CV_32F);
    for (int u = 0; u < m.width; ++u)
      image.col(u).setTo(0.5 * (1.0 + std::cos(2.0 * M_PI * (u + 0.5) / 16.0)));
    images.push_back(image);
  }
  SeededRandom random(1);
  const cv::Mat frame = renderFrame(view, images, render, random);
  const double sigmaRad = diffusionSigma(truth.screen.diffusionDeg);
  const double blur = render.blurSigmaPx;
  double worst = 0.0, brightest = 0.0;
  int compared = 0;
  const int y = intrinsics.height / 2;
  // The screen's pixels on this row, less 3 at either end (where the blur meets its edge).
  const auto camera = packCamera(pose);
  std::vector<int> onScreen;
  for (int x = 0; x < intrinsics.width; ++x) {
    const Eigen::Vector2d n = intrinsics.normalized({x + 0.5, y + 0.5});
    Vec3<double> s;
    if (screenPointOfCameraRay(truth.screen.curvature, camera.data(), n.x(), n.y(), &s) &&
        truth.screen.contains(s.x(), s.y()))
      onScreen.push_back(x);
  }
  ASSERT_GT(onScreen.size(), 50u);
  for (int x = onScreen.front() + 3; x <= onScreen.back() - 3; ++x) {
    // The light around the pixel's centre, Gaussian-weighted over ±4σ.
    double sum = 0.0, weights = 0.0;
    constexpr int kSteps = 24;
    for (int j = -kSteps; j <= kSteps; ++j) {
      for (int i = -kSteps; i <= kSteps; ++i) {
        const double dx = 4.0 * blur * i / kSteps, dy = 4.0 * blur * j / kSteps;
        const double w = std::exp(-0.5 * (dx * dx + dy * dy) / (blur * blur));
        sum +=
            w * 0.5 * unblurredLight(truth, intrinsics, pose, sigmaRad, x + 0.5 + dx, y + 0.5 + dy);
        weights += w;
      }
    }
    const double expected = std::min(sum / weights, 1.0);
    brightest = std::max(brightest, expected);
    worst = std::max(worst, std::abs(frame.at<float>(y, x) - expected));
    ++compared;
  }
  EXPECT_GT(compared, 40);
  EXPECT_GT(brightest, 0.3);
  EXPECT_LT(worst, 0.01 * brightest) << "of " << brightest;
}

// A view renders every frame of its station: rendering one leaves the view as it was, so a far
// station's second picture of the same images is the first (its markers once blurred in place,
// a little more with every frame).
TEST(StructuredLight, AFarStationsPicturesDoNotChangeFromFrameToFrame) {
  const DisplayModel truth = makeGroundTruth(resolveDisplay("demo"), {});
  const CameraIntrinsics intrinsics = CameraIntrinsics::centred(640, 360, 700.0, -0.04);
  CameraRenderOptions render;
  render.noiseSigma = 0.0;
  const StationView view = viewFromStation(truth, intrinsics, stationAt({0.2, 0.0, 10.0}), render);
  ASSERT_GT(view.supersampling, 1);
  ASSERT_FALSE(view.markers.empty());
  std::vector<cv::Mat> images;
  for (const OpticalModule& m : truth.modules)
    images.emplace_back(m.height, m.width, CV_32F, cv::Scalar(0.5f));
  SeededRandom random(2);
  const cv::Mat first = renderFrame(view, images, render, random);
  const cv::Mat second = renderFrame(view, images, render, random);
  EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0.0);
}

TEST(StructuredLight, ThroughTheSimulatedCameraDecodesWhereTheLightComesFrom) {
  // Demo display, one station at the centre of the observer line, every third module showing
  // its patterns (neighbouring lobes overlap at 1.5× the module pitch; every third one does not).
  const DisplayModel truth = makeGroundTruth(resolveDisplay("demo"), {});
  const CameraIntrinsics intrinsics =
      CameraIntrinsics::centred(480, 270, 525.0, -0.05);  // small: a fast test
  CameraPose pose;
  pose.centre = {0.03, 0.01, 2.0};
  pose.physicalFromCamera = aimCameraAt(pose.centre, Eigen::Vector3d::Zero());
  CameraRenderOptions render;
  const StationView view = viewFromStation(truth, intrinsics, pose, render);
  StructuredLightOptions sl;
  SeededRandom random(4);

  std::vector<int> group;
  for (int m = 0; m < static_cast<int>(truth.modules.size()); m += 3) group.push_back(m);
  const int mw = truth.modules[0].width, mh = truth.modules[0].height;
  std::vector<std::vector<cv::Mat>> recorded(2);  // per axis
  for (int a = 0; a < 2; ++a) {
    const PatternAxis axis = a == 0 ? PatternAxis::kColumns : PatternAxis::kRows;
    for (const cv::Mat& pattern : makePatternFrames(mw, mh, axis, sl)) {
      std::vector<cv::Mat> images(truth.modules.size());
      for (int m : group) images[static_cast<size_t>(m)] = pattern;
      recorded[static_cast<size_t>(a)].push_back(
          linearFromRecorded(renderFrame(view, images, render, random), render.gamma));
    }
  }

  std::vector<double> errors;
  int decoded = 0, dominated = 0;
  for (int y = 2; y < view.height - 2; y += 2) {
    for (int x = 2; x < view.width - 2; x += 2) {
      // The truth: the strongest group module reaching this pixel, if it clearly dominates.
      const LobeContribution* best = nullptr;
      float second = 0.0f;
      for (const LobeContribution& c : view.at(x, y)) {
        if (c.module < 0 || c.module % 3 != 0) continue;
        if (!best)
          best = &c;
        else
          second = std::max(second, c.weight);
      }
      if (!best || best->weight < 0.5f || second > 0.05f * best->weight) continue;
      ++dominated;
      std::optional<double> uv[2];
      for (int a = 0; a < 2; ++a) {
        std::vector<float> intensities;
        for (const cv::Mat& f : recorded[static_cast<size_t>(a)])
          intensities.push_back(f.at<float>(y, x));
        uv[a] = decodePixel(intensities, a == 0 ? mw : mh, sl);
      }
      if (!uv[0] || !uv[1]) continue;
      ++decoded;
      errors.push_back(std::hypot(*uv[0] - best->u, *uv[1] - best->v));
    }
  }
  ASSERT_GT(dominated, 500);
  EXPECT_GT(decoded, 0.9 * dominated) << "most lit pixels decode";
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const double p95 = errors[errors.size() * 95 / 100];
  std::printf(
      "    decoded %d of %d lit pixels; module-pixel error median %.3f px, 95th percentile %.3f "
      "px\n",
      decoded, dominated, median, p95);
  // Blur and the camera's coarser sampling (a camera pixel covers ~1 module pixel here) set
  // the floor; a gross Gray-code error would be ≥ one period (16 px).
  EXPECT_LT(median, 0.3);
  EXPECT_LT(p95, 1.0);
}

}  // namespace
}  // namespace parallax
