#pragma once
// Finds the fiducial markers (bright discs on the screen frame, calibration_camera.h) in a
// station's black reference picture: with every module dark, the markers are the only bright
// spots. Blobs are found by threshold (above the picture's own noise as well as minPeak) and
// connected components, and only those whose light stands out of their box's noise count (a
// noisy picture is full of specks); each fiducial takes the brightest blob within reach of
// where the nominal screen and the tape-measured station (aimed at the screen centre, as the
// fit starts) predict it, if that blob is nearer to it than to any other fiducial's
// prediction, and not far dimmer than its station's typical sighting; a blob cut by the
// picture's edge is no sighting. The position is the blob's background-subtracted centroid.

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "calibration/camera/calibration_observations.h"
#include "calibration/display/display_model.h"

namespace parallax {

struct FiducialDetectorOptions {
  double minPeak = 0.1;  // linear light above the background, for a blob (at least)
  double searchRadiusFraction =
      0.06;                  // of the focal length: how far a marker may be from its prediction
  int maxBlobPixels = 4000;  // larger bright regions are not markers

  void validate() const;
};

void detectFiducials(const cv::Mat& blackLinear, const Screen& nominalScreen, int station,
                     const FiducialDetectorOptions& options, CalibrationObservations* observations);

// The camera pose from a station's fiducial sightings (cv::solvePnP, iterating from the tape
// mark aimed at the screen centre; the markers on the nominal screen). nullopt with fewer
// than four sightings or when the solution is not in front of the screen.
std::optional<CameraPose> poseFromFiducials(const CalibrationObservations& observations,
                                            const Screen& nominalScreen, int station);

}  // namespace parallax
