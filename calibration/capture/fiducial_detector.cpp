#include "calibration/capture/fiducial_detector.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/input_error.h"

namespace parallax {

void FiducialDetectorOptions::validate() const {
  if (!(minPeak > 0.0 && minPeak < 1.0)) throw InputError({"", "min_peak", 0}, "must be in (0, 1)");
  if (!(searchRadiusFraction > 0.0 && searchRadiusFraction < 1.0)) {
    throw InputError({"", "search_radius_fraction", 0}, "must be in (0, 1)");
  }
  if (maxBlobPixels < 1) throw InputError({"", "max_blob_pixels", 0}, "must be >= 1");
}

void detectFiducials(const cv::Mat& blackLinear, const Screen& nominalScreen, int station,
                     const FiducialDetectorOptions& options, CalibrationObservations* obs) {
  options.validate();
  PARALLAX_CHECK(blackLinear.type() == CV_32F);
  PARALLAX_CHECK(station >= 0 && station < static_cast<int>(obs->stations.size()));
  // Background: the median of the dark picture (mostly ambient light on a dark screen).
  cv::Mat sorted = blackLinear.reshape(1, 1).clone();
  const int mid = sorted.cols / 2;
  std::nth_element(sorted.ptr<float>(), sorted.ptr<float>() + mid,
                   sorted.ptr<float>() + sorted.cols);
  const float background = sorted.at<float>(0, mid);
  cv::Mat mask = blackLinear > background + static_cast<float>(options.minPeak);
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);

  // Refined centres of the plausible blobs: background-subtracted centroid over the blob's
  // box grown by two pixels (the blur's skirt), not clipped at zero (unbiased under noise).
  std::vector<Eigen::Vector2d> blobs;
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
    if (!(sw > 0.0)) continue;
    blobs.emplace_back(sx / sw, sy / sw);
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
  for (size_t f = 0; f < obs->fiducials.size(); ++f) {
    if (!visible[f]) continue;
    int best = -1;
    double bestDistance = radius;
    for (size_t b = 0; b < blobs.size(); ++b) {
      const double d = (blobs[b] - predicted[f]).norm();
      if (d < bestDistance) {
        bestDistance = d;
        best = static_cast<int>(b);
      }
    }
    if (best < 0) continue;
    // The blob must be nearer to this fiducial's prediction than to any other's.
    bool mine = true;
    for (size_t g = 0; g < obs->fiducials.size(); ++g) {
      if (g != f && visible[g] &&
          (blobs[static_cast<size_t>(best)] - predicted[g]).norm() < bestDistance)
        mine = false;
    }
    if (mine)
      obs->fiducialSightings.push_back(
          {station, static_cast<int>(f), blobs[static_cast<size_t>(best)]});
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
