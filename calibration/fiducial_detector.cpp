#include "calibration/fiducial_detector.h"

#include <algorithm>
#include <cmath>
#include <limits>

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
  std::nth_element(sorted.ptr<float>(), sorted.ptr<float>() + mid, sorted.ptr<float>() + sorted.cols);
  const float background = sorted.at<float>(0, mid);
  cv::Mat mask = blackLinear > background + static_cast<float>(options.minPeak);
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);

  // Refined centres of the plausible blobs: background-subtracted centroid over the blob's
  // box grown by two pixels (the blur's skirt), not clipped at zero (unbiased under noise).
  std::vector<Eigen::Vector2d> blobs;
  for (int b = 1; b < count; ++b) {
    if (stats.at<int>(b, cv::CC_STAT_AREA) > options.maxBlobPixels) continue;
    const int x0 = stats.at<int>(b, cv::CC_STAT_LEFT) - 2, y0 = stats.at<int>(b, cv::CC_STAT_TOP) - 2;
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
    const Eigen::Vector3d point = nominalScreen.pointAt(obs->fiducials[f].x(), obs->fiducials[f].y());
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
      if (g != f && visible[g] && (blobs[static_cast<size_t>(best)] - predicted[g]).norm() < bestDistance) mine = false;
    }
    if (mine) obs->fiducialSightings.push_back({station, static_cast<int>(f), blobs[static_cast<size_t>(best)]});
  }
}

}  // namespace parallax
