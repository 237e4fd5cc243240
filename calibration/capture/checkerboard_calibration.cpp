#include "calibration/capture/checkerboard_calibration.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "calibration/display/conventions.h"
#include "common/check.h"
#include "common/input_error.h"

namespace parallax {
namespace {

// Three views: the least for fx, fy, cx, cy and a pose each.
constexpr int kMinViews = 3;

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The intrinsics' covariance at cv::calibrateCamera's answer, correlations included: the
// Gauss-Newton information of every corner over (fx, fy, cx, cy, k1, k2) and each view's pose,
// the poses marginalized view by view (Schur complement), scaled by the residuals' variance
// over the degrees of freedom — how OpenCV finds its σ, which are this matrix's diagonal.
// Zero when the information cannot be inverted (the fit then carries no intrinsics' σ).
IntrinsicsCovariance intrinsicsCovariance(const std::vector<std::vector<cv::Point3f>>& objects,
                                          const std::vector<std::vector<cv::Point2f>>& images,
                                          const std::vector<cv::Mat>& rvecs,
                                          const std::vector<cv::Mat>& tvecs,
                                          const cv::Mat& cameraMatrix, const cv::Mat& distortion) {
  // cv::projectPoints' Jacobian columns: rvec 0-2, tvec 3-5, fx fy 6-7, cx cy 8-9, then the
  // distortion coefficients k1 k2 (10-11) p1 p2 k3 (held at zero by the calibration).
  constexpr int kPose = 6, kFirstIntrinsic = 6;
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  Matrix6 information = Matrix6::Zero();
  double squaredError = 0.0;
  size_t corners = 0;
  for (size_t v = 0; v < objects.size(); ++v) {
    std::vector<cv::Point2f> projected;
    cv::Mat jacobian;
    cv::projectPoints(objects[v], rvecs[v], tvecs[v], cameraMatrix, distortion, projected,
                      jacobian);
    Matrix6 ii = Matrix6::Zero(), pp = Matrix6::Zero(), ip = Matrix6::Zero();
    for (int r = 0; r < jacobian.rows; ++r) {
      Eigen::Matrix<double, 6, 1> pose, intrinsic;
      for (int c = 0; c < kPose; ++c) pose[c] = jacobian.at<double>(r, c);
      for (int c = 0; c < kIntrinsicsParameters; ++c)
        intrinsic[c] = jacobian.at<double>(r, kFirstIntrinsic + c);
      ii.noalias() += intrinsic * intrinsic.transpose();
      pp.noalias() += pose * pose.transpose();
      ip.noalias() += intrinsic * pose.transpose();
    }
    const Eigen::LDLT<Matrix6> poseInformation(pp);
    if (poseInformation.info() != Eigen::Success) return IntrinsicsCovariance::Zero();
    information += ii - ip * poseInformation.solve(ip.transpose());
    for (size_t i = 0; i < projected.size(); ++i) {
      const double du = projected[i].x - images[v][i].x, dv = projected[i].y - images[v][i].y;
      squaredError += du * du + dv * dv;
    }
    corners += projected.size();
  }
  const double dof = 2.0 * static_cast<double>(corners) -
                     static_cast<double>(kIntrinsicsParameters + kPose * objects.size());
  if (!(dof > 0.0)) return IntrinsicsCovariance::Zero();
  const Eigen::LDLT<Matrix6> solver(information);
  if (solver.info() != Eigen::Success || !(solver.rcond() > 1e-14))
    return IntrinsicsCovariance::Zero();
  IntrinsicsCovariance covariance = (squaredError / dof) * solver.solve(Matrix6::Identity());
  covariance = 0.5 * (covariance + covariance.transpose()).eval();
  return covariance.allFinite() ? covariance : IntrinsicsCovariance::Zero();
}

}  // namespace

CheckerboardCalibration calibrateFromCheckerboard(const std::vector<CheckerboardPicture>& pictures,
                                                  const CheckerboardBoard& board, int width,
                                                  int height,
                                                  const CheckerboardCalibrationOptions& options) {
  board.validate();
  if (width < 16 || height < 16)
    throw InputError({"", "intrinsics.width", 0},
                     "the camera's pictures must be at least 16 px a side");
  const auto detectStart = std::chrono::steady_clock::now();
  std::vector<std::string> usedNames, skipped;
  std::vector<BoardView> views;
  for (const CheckerboardPicture& picture : pictures) {
    if (picture.recorded.empty() || picture.recorded.depth() != CV_8U ||
        (picture.recorded.channels() != 1 && picture.recorded.channels() != 3)) {
      throw InputError({picture.name, "", 0},
                       "must be an 8-bit grey or colour picture, as the camera recorded it");
    }
    if (picture.recorded.cols != width || picture.recorded.rows != height) {
      throw InputError({picture.name, "", 0},
                       fmt::format("is {}x{}, the camera's pictures are {}x{}",
                                   picture.recorded.cols, picture.recorded.rows, width, height));
    }
    const auto corners = findCheckerboardCorners(picture.recorded, board);
    if (!corners) {
      skipped.push_back(picture.name);
      continue;
    }
    views.push_back({board.cornerPoints(), *corners});
    usedNames.push_back(picture.name);
  }
  const double detectSeconds = secondsSince(detectStart);
  const int minimum = std::max(options.minPictures, kMinViews);
  if (static_cast<int>(views.size()) < minimum) {
    throw InputError(
        {"", "pictures", 0},
        fmt::format("the board ({}x{} inner corners) was found in {} of {} pictures; "
                    "the camera's intrinsics "
                    "need at least {}",
                    board.innerColumns, board.innerRows, views.size(), pictures.size(), minimum));
  }
  CheckerboardCalibration result = calibrateFromViews(usedNames, views, width, height, options);
  result.skipped = std::move(skipped);
  result.detectSeconds = detectSeconds;
  return result;
}

CheckerboardCalibration calibrateFromViews(const std::vector<std::string>& names,
                                           const std::vector<BoardView>& views, int width,
                                           int height,
                                           const CheckerboardCalibrationOptions& options) {
  PARALLAX_CHECK_OP(names.size(), ==, views.size());
  const int minimum = std::max(options.minPictures, kMinViews);
  if (static_cast<int>(views.size()) < minimum) {
    throw InputError({"", "pictures", 0},
                     fmt::format("{} views of the board; the camera's intrinsics need at least {}",
                                 views.size(), minimum));
  }
  CheckerboardCalibration result;
  std::vector<std::vector<cv::Point3f>> objectPoints;
  std::vector<std::vector<cv::Point2f>> imagePoints;
  for (const BoardView& view : views) {
    PARALLAX_CHECK_OP(view.board.size(), ==, view.pixels.size());
    std::vector<cv::Point3f> object;
    std::vector<cv::Point2f> image;
    for (size_t i = 0; i < view.board.size(); ++i) {
      const Eigen::Vector3d& p = view.board[i];
      object.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                          static_cast<float>(p.z()));
      const Eigen::Vector2d opencv = openCvFromPixel(view.pixels[i]);
      image.emplace_back(static_cast<float>(opencv.x()), static_cast<float>(opencv.y()));
    }
    objectPoints.push_back(std::move(object));
    imagePoints.push_back(std::move(image));
  }

  const auto solveStart = std::chrono::steady_clock::now();
  cv::Mat cameraMatrix, distortion = cv::Mat::zeros(5, 1, CV_64F);
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat sigmaIntrinsics, sigmaExtrinsics, perView;
  // Our model has k1, k2 only: tangential terms and k3 held at zero.
  const int flags = cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K3;
  const double rms = cv::calibrateCamera(
      objectPoints, imagePoints, cv::Size(width, height), cameraMatrix, distortion, rvecs, tvecs,
      sigmaIntrinsics, sigmaExtrinsics, perView, flags,
      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
  result.solveSeconds = secondsSince(solveStart);

  CameraIntrinsics& in = result.intrinsics;
  in.width = width;
  in.height = height;
  in.fx = cameraMatrix.at<double>(0, 0);
  in.fy = cameraMatrix.at<double>(1, 1);
  const Eigen::Vector2d principal =
      pixelFromOpenCv({cameraMatrix.at<double>(0, 2), cameraMatrix.at<double>(1, 2)});
  in.cx = principal.x();
  in.cy = principal.y();
  in.k1 = distortion.at<double>(0);
  in.k2 = distortion.at<double>(1);
  result.rmsPx = rms;
  result.covariance =
      intrinsicsCovariance(objectPoints, imagePoints, rvecs, tvecs, cameraMatrix, distortion);
  // The σ are the covariance's. OpenCV's own divide the squared errors (two a corner) by the
  // number of corners less the parameters, which makes them about √2 too wide (over ten seeds
  // the error's squared Mahalanobis distance under OpenCV's was about 2, against the χ² mean of
  // 6 it has under this covariance: checkerboard_test.cpp).
  auto sigma = [&](int i) {
    if (!result.covariance.isZero()) return std::sqrt(result.covariance(i, i));
    return sigmaIntrinsics.total() > static_cast<size_t>(i) ? sigmaIntrinsics.at<double>(i) : 0.0;
  };
  result.sigmaFx = sigma(0);
  result.sigmaFy = sigma(1);
  result.sigmaCx = sigma(2);
  result.sigmaCy = sigma(3);
  result.sigmaK1 = sigma(4);
  result.sigmaK2 = sigma(5);
  for (size_t i = 0; i < names.size(); ++i) {
    result.used.push_back(
        {names[i], perView.total() > i ? perView.at<double>(static_cast<int>(i)) : 0.0});
  }

  const bool finite = std::isfinite(rms) && std::isfinite(in.fx) && std::isfinite(in.fy) &&
                      std::isfinite(in.cx) && std::isfinite(in.cy) && std::isfinite(in.k1) &&
                      std::isfinite(in.k2);
  if (!finite || !(in.fx > 0.0 && in.fy > 0.0)) {
    throw InputError({"", "pictures", 0},
                     "cv::calibrateCamera gave no finite camera from these pictures");
  }
  if (!(rms <= options.maxRmsPx)) {
    throw InputError(
        {"", "pictures", 0},
        fmt::format("the corners fit the camera model to {:.3f} px RMS (at most {:.2f} accepted): "
                    "a wrong board description or blurred pictures",
                    rms, options.maxRmsPx));
  }
  if (std::abs(in.k1) > 1.0 || std::abs(in.k2) > 1.0) {
    throw InputError({"", "pictures", 0},
                     fmt::format("distortion k1 = {:.3f}, k2 = {:.3f} is beyond |k| <= 1 (not a "
                                 "calibration camera's lens)",
                                 in.k1, in.k2));
  }
  return result;
}

std::string formatCheckerboardCalibration(const CheckerboardCalibration& r,
                                          const CameraIntrinsics* truth) {
  const CameraIntrinsics& in = r.intrinsics;
  std::string out = fmt::format(
      "camera intrinsics from the checkerboard: {} pictures used, {} skipped; RMS reprojection "
      "{:.3f} px "
      "(detect {:.2f} s, calibrateCamera {:.2f} s)\n",
      r.used.size(), r.skipped.size(), r.rmsPx, r.detectSeconds, r.solveSeconds);
  struct Row {
    const char* name;
    double value, sigma, trueValue;
  };
  const Row rows[] = {{"fx", in.fx, r.sigmaFx, truth ? truth->fx : 0.0},
                      {"fy", in.fy, r.sigmaFy, truth ? truth->fy : 0.0},
                      {"cx", in.cx, r.sigmaCx, truth ? truth->cx : 0.0},
                      {"cy", in.cy, r.sigmaCy, truth ? truth->cy : 0.0},
                      {"k1", in.k1, r.sigmaK1, truth ? truth->k1 : 0.0},
                      {"k2", in.k2, r.sigmaK2, truth ? truth->k2 : 0.0}};
  for (const Row& row : rows) {
    out += fmt::format("  {} {:>11.5f} ± {:.5f}", row.name, row.value, row.sigma);
    if (truth)
      out +=
          fmt::format("   true {:>11.5f}, error {:+.5f}", row.trueValue, row.value - row.trueValue);
    out += "\n";
  }
  std::vector<PictureError> worst = r.used;
  std::sort(worst.begin(), worst.end(),
            [](const PictureError& a, const PictureError& b) { return a.rmsPx > b.rmsPx; });
  if (worst.size() > 3) worst.resize(3);
  if (!worst.empty()) {
    out += "  worst pictures:";
    for (const PictureError& p : worst) out += fmt::format(" {} {:.3f} px;", p.name, p.rmsPx);
    out += "\n";
  }
  for (const std::string& name : r.skipped)
    out += fmt::format("  skipped {}: the board was not found\n", name);
  return out;
}

}  // namespace parallax
