#include "calibration/capture/fiducial_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/input_error.h"

namespace parallax {
namespace {

constexpr double kMadToSigma = 1.4826;  // median absolute deviation → σ for Gaussian noise
// Segmenting at 4 σ of the smoothed picture's noise leaves ~3e-5 of the pixels as specks (a
// few a picture), not merged into the markers; the significance a blob's light needs over its
// box's noise.
constexpr double kSegmentBlurPx = 1.0;
constexpr double kSegmentSigmas = 4.0;
constexpr double kMinBlobSignificance = 10.0;
// How far above all its neighbours a pixel is hot: no noise reaches it.
constexpr double kSpikeSigmas = 8.0;
// A sighting's light, at least, against the median sighting of its station.
constexpr double kMinShareOfTypicalLight = 0.25;

}  // namespace

void FiducialDetectorOptions::validate() const {
  if (!(minPeak > 0.0 && minPeak < 1.0)) throw InputError({"", "min_peak", 0}, "must be in (0, 1)");
  if (!(searchRadiusFraction > 0.0 && searchRadiusFraction < 1.0)) {
    throw InputError({"", "search_radius_fraction", 0}, "must be in (0, 1)");
  }
  if (maxBlobPixels < 1) throw InputError({"", "max_blob_pixels", 0}, "must be >= 1");
}

void detectFiducials(const cv::Mat& picture, const Screen& nominalScreen, int station,
                     const FiducialDetectorOptions& options, CalibrationObservations* obs) {
  options.validate();
  PARALLAX_CHECK(picture.type() == CV_32F);
  PARALLAX_CHECK(station >= 0 && station < static_cast<int>(obs->stations.size()));
  // Background: the median of the dark picture (mostly ambient light on a dark screen); its
  // noise: the robust spread about it (the markers are a tiny share of the pixels).
  const auto medianOf = [](cv::Mat values) {
    cv::Mat flat = values.reshape(1, 1).clone();
    const int mid = flat.cols / 2;
    std::nth_element(flat.ptr<float>(), flat.ptr<float>() + mid, flat.ptr<float>() + flat.cols);
    return static_cast<double>(flat.at<float>(0, mid));
  };
  const double pixelNoise = kMadToSigma * medianOf(cv::abs(picture - medianOf(picture)));
  // A camera's hot pixels: one pixel far above all eight of its neighbours, which no marker
  // (several pixels across, blurred) makes. Each takes its neighbourhood's median, so that it
  // neither passes for a marker nor pulls the centroid of one it falls beside.
  cv::Mat blackLinear = picture.clone();
  {
    cv::Mat ring = cv::Mat::ones(3, 3, CV_8U), neighbourMax, median;
    ring.at<std::uint8_t>(1, 1) = 0;
    cv::dilate(picture, neighbourMax, ring);
    cv::medianBlur(picture, median, 3);
    median.copyTo(blackLinear,
                  picture - neighbourMax > std::max(options.minPeak, kSpikeSigmas * pixelNoise));
  }
  const double background = medianOf(blackLinear);
  // Segmented on a copy smoothed over about a pixel: the noise on a marker's own skirt then
  // no longer breaks it into a disc and loose fragments (seed 1008, 2 px: a fragment 4.6 px
  // from its marker's centre was nearer the prediction, and taken for it).
  cv::Mat smooth;
  cv::GaussianBlur(blackLinear, smooth, cv::Size(), kSegmentBlurPx);
  const double noise = kMadToSigma * medianOf(cv::abs(smooth - background));
  // A noisy picture puts pixels above a fixed threshold everywhere (seed 1008 at 2 px camera
  // noise: ~650 specks), and the one nearest a marker's prediction, off by the tape's error,
  // was taken for it (5-38 px wrong at three of five stations): segment above the noise too.
  const double threshold = std::max(options.minPeak, kSegmentSigmas * noise);
  cv::Mat mask = smooth > background + threshold;
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);

  // Refined centres of the plausible blobs: background-subtracted centroid of the picture
  // itself over the blob's box grown by two pixels (the blur's skirt), not clipped at zero
  // (unbiased under noise). A blob's light over that box must stand out of the box's noise:
  // a marker's does by 10²-10³ σ, a speck of noise by a few.
  struct Blob {
    cv::Rect box;
    double light = 0.0;
    Eigen::Vector2d centre;
  };
  std::vector<Blob> found;
  for (int b = 1; b < count; ++b) {
    if (stats.at<int>(b, cv::CC_STAT_AREA) > options.maxBlobPixels) continue;
    const int x0 = stats.at<int>(b, cv::CC_STAT_LEFT) - 2,
              y0 = stats.at<int>(b, cv::CC_STAT_TOP) - 2;
    const int x1 = stats.at<int>(b, cv::CC_STAT_LEFT) + stats.at<int>(b, cv::CC_STAT_WIDTH) + 1;
    const int y1 = stats.at<int>(b, cv::CC_STAT_TOP) + stats.at<int>(b, cv::CC_STAT_HEIGHT) + 1;
    // A marker cut by the picture's edge has its centroid pulled inward: not a sighting.
    if (x0 < 0 || y0 < 0 || x1 >= blackLinear.cols || y1 >= blackLinear.rows) continue;
    double sw = 0.0, sx = 0.0, sy = 0.0;
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double w = blackLinear.at<float>(y, x) - background;
        sw += w;
        sx += w * (x + 0.5);
        sy += w * (y + 0.5);
      }
    }
    const double boxPixels = static_cast<double>(x1 - x0 + 1) * (y1 - y0 + 1);
    if (!(sw > 0.0) || sw < kMinBlobSignificance * pixelNoise * std::sqrt(boxPixels)) continue;
    found.push_back({cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1), sw, {sx / sw, sy / sw}});
  }
  // Brightest first. What is left of a marker's fragments: a blob whose box meets a brighter
  // one's is part of it.
  std::sort(found.begin(), found.end(),
            [](const Blob& a, const Blob& b) { return a.light > b.light; });
  std::vector<Blob> blobs;
  for (const Blob& blob : found) {
    const bool fragment = std::any_of(blobs.begin(), blobs.end(),
                                      [&](const Blob& k) { return (k.box & blob.box).area() > 0; });
    if (!fragment) blobs.push_back(blob);
  }

  CameraPose pose;  // the decoder's idea of the camera: at the tape mark, aimed at the centre
  pose.centre = obs->stations[static_cast<size_t>(station)].tapeCentre;
  pose.physicalFromCamera = aimCameraAt(pose.centre, Eigen::Vector3d::Zero());
  const double radius = options.searchRadiusFraction * obs->intrinsics.fx;
  std::vector<Eigen::Vector2d> predicted(obs->fiducials.size());
  std::vector<bool> visible(obs->fiducials.size(), false);
  for (size_t f = 0; f < obs->fiducials.size(); ++f) {
    const Eigen::Vector3d point =
        nominalScreen.pointAt(obs->fiducials[f].x(), obs->fiducials[f].y());
    visible[f] = projectPhysical(obs->intrinsics, pose, point, &predicted[f]);
  }
  std::vector<std::pair<int, size_t>> taken;  // (fiducial, blob)
  for (size_t f = 0; f < obs->fiducials.size(); ++f) {
    if (!visible[f]) continue;
    // The brightest blob within reach: a marker outshines a speck or a hot pixel wherever the
    // tape's error puts the prediction.
    int best = -1;
    double bestDistance = radius;
    for (size_t b = 0; b < blobs.size() && best < 0; ++b) {
      const double d = (blobs[b].centre - predicted[f]).norm();
      if (d < radius) {
        bestDistance = d;
        best = static_cast<int>(b);
      }
    }
    if (best < 0) continue;
    // The blob must be nearer to this fiducial's prediction than to any other's.
    bool mine = true;
    for (size_t g = 0; g < obs->fiducials.size(); ++g) {
      if (g != f && visible[g] &&
          (blobs[static_cast<size_t>(best)].centre - predicted[g]).norm() < bestDistance)
        mine = false;
    }
    if (mine) taken.emplace_back(static_cast<int>(f), static_cast<size_t>(best));
  }
  // The markers are alike, so their light is too (within the spread of their distances): a
  // blob far dimmer than the station's typical sighting is something else where a marker fell
  // outside the picture (a hot pixel, a speck).
  std::vector<double> lights;
  for (const auto& [f, b] : taken) lights.push_back(blobs[b].light);
  std::nth_element(lights.begin(), lights.begin() + static_cast<long>(lights.size() / 2),
                   lights.end());
  const double typicalLight = lights.empty() ? 0.0 : lights[lights.size() / 2];
  for (const auto& [f, b] : taken) {
    if (blobs[b].light >= kMinShareOfTypicalLight * typicalLight)
      obs->fiducialSightings.push_back({station, f, blobs[b].centre});
  }
}

std::optional<CameraPose> poseFromFiducials(const CalibrationObservations& obs,
                                            const Screen& nominalScreen, int station) {
  std::vector<cv::Point3d> world;
  std::vector<cv::Point2d> image;
  for (const FiducialSighting& f : obs.fiducialSightings) {
    if (f.camera != station) continue;
    const Eigen::Vector2d& xy = obs.fiducials[static_cast<size_t>(f.fiducial)];
    const Eigen::Vector3d p = nominalScreen.pointAt(xy.x(), xy.y());
    world.emplace_back(p.x(), p.y(), p.z());
    image.emplace_back(f.cameraPx.x(), f.cameraPx.y());  // same origin as cx, cy below
  }
  if (world.size() < 4) return std::nullopt;
  const CameraIntrinsics& in = obs.intrinsics;
  const cv::Matx33d k(in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1);
  const cv::Vec4d distortion(in.k1, in.k2, 0, 0);
  // Start at the tape mark aimed at the screen centre: cameraFromPhysical = (R, t).
  const Eigen::Vector3d tape = obs.stations[static_cast<size_t>(station)].tapeCentre;
  const Eigen::Matrix3d cameraFromPhysical =
      aimCameraAt(tape, Eigen::Vector3d::Zero()).conjugate().toRotationMatrix();
  cv::Mat r, rvec, tvec;
  cv::eigen2cv(cameraFromPhysical, r);
  cv::Rodrigues(r, rvec);
  const Eigen::Vector3d t0 = -cameraFromPhysical * tape;
  tvec = (cv::Mat_<double>(3, 1) << t0.x(), t0.y(), t0.z());
  if (!cv::solvePnP(world, image, k, distortion, rvec, tvec, /*useExtrinsicGuess=*/true,
                    cv::SOLVEPNP_ITERATIVE)) {
    return std::nullopt;
  }
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d rotation;
  cv::cv2eigen(r, rotation);
  const Eigen::Vector3d t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  CameraPose pose;
  pose.physicalFromCamera = Eigen::Quaterniond(rotation.transpose()).normalized();
  pose.centre = -rotation.transpose() * t;
  if (!pose.centre.allFinite() || !(pose.centre.z() > 0.0)) return std::nullopt;
  return pose;
}

}  // namespace parallax
