#include "calibration/simulation/checkerboard_renderer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "calibration/display/conventions.h"
#include "common/input_error.h"

namespace parallax {
namespace {

constexpr int kSamplesPerSide = 8;  // supersampling of a pixel that crosses a cell edge

// Does the whole sheet project inside the picture, with a margin, and face the camera?
bool sheetFits(const CheckerboardBoard& board, const CameraIntrinsics& in,
               const Eigen::Isometry3d& cameraFromBoard) {
  const Eigen::Vector4d s = board.sheetBounds();
  const double margin =
      2.0 + 0.01 * std::max(in.width, in.height);  // edges bow slightly under distortion
  for (const Eigen::Vector2d& c : {Eigen::Vector2d(s[0], s[1]), Eigen::Vector2d(s[2], s[1]),
                                   Eigen::Vector2d(s[0], s[3]), Eigen::Vector2d(s[2], s[3])}) {
    Eigen::Vector2d px;
    if (!in.project(cameraFromBoard * Eigen::Vector3d(c.x(), c.y(), 0.0), &px)) return false;
    if (px.x() < margin || px.y() < margin || px.x() > in.width - margin ||
        px.y() > in.height - margin)
      return false;
  }
  // Seen at no more than 70° from its normal: a grazing board's squares are too thin to find.
  const Eigen::Vector3d centre =
      cameraFromBoard * Eigen::Vector3d(0.5 * (s[0] + s[2]), 0.5 * (s[1] + s[3]), 0.0);
  const Eigen::Vector3d normal = cameraFromBoard.linear().col(2);
  return std::abs(normal.dot(centre.normalized())) > std::cos(radians(70.0));
}

}  // namespace

void CheckerboardShotOptions::validate() const {
  auto check = [](bool ok, const char* field, const char* why) {
    if (!ok) throw InputError({"", field, 0}, why);
  };
  check(pictures >= 1 && pictures <= 1000, "pictures", "must be 1..1000");
  check(minFill > 0.05 && minFill <= maxFill && maxFill < 1.0, "fill",
        "must be 0.05 < min_fill <= max_fill < 1");
  check(minTiltDeg >= 0.0 && minTiltDeg <= maxTiltDeg && maxTiltDeg <= 60.0, "tilt_deg",
        "must be 0 <= min <= max <= 60");
  check(maxRollDeg >= 0.0 && maxRollDeg <= 45.0, "roll_deg", "must be 0..45");
  check(blackReflectance >= 0.0 && blackReflectance < whiteReflectance && whiteReflectance <= 1.0,
        "reflectance", "must be 0 <= black < white <= 1");
  check(background >= 0.0 && background <= 1.0, "background", "must be 0..1");
  check(lightFalloff >= 0.0 && lightFalloff < 1.0, "light_falloff", "must be 0..1");
}

std::vector<Eigen::Isometry3d> checkerboardPoses(const CheckerboardBoard& board,
                                                 const CameraIntrinsics& in,
                                                 const CheckerboardShotOptions& options,
                                                 SeededRandom& random) {
  board.validate();
  options.validate();
  const Eigen::Vector4d sheet = board.sheetBounds();
  const Eigen::Vector3d sheetCentre(0.5 * (sheet[0] + sheet[2]), 0.5 * (sheet[1] + sheet[3]), 0.0);
  const double sheetWidth = sheet[2] - sheet[0];
  // 3 × 3 cells of the frame, corners first: distortion and the principal point show most there.
  static constexpr int kCellOrder[9][2] = {{0, 0}, {2, 2}, {2, 0}, {0, 2}, {1, 1},
                                           {0, 1}, {2, 1}, {1, 0}, {1, 2}};
  constexpr int kAttempts = 400;
  std::vector<Eigen::Isometry3d> poses;
  for (int k = 0; k < options.pictures; ++k) {
    const auto& cell = kCellOrder[k % 9];
    bool placed = false;
    for (int attempt = 0; attempt < kAttempts && !placed; ++attempt) {
      // After many misses, pull the board toward the frame's centre and make it smaller.
      const double pull = std::min(1.0, attempt / (0.5 * kAttempts));
      double tx = (cell[0] + random.uniform(0.2, 0.8)) / 3.0 * in.width;
      double ty = (cell[1] + random.uniform(0.2, 0.8)) / 3.0 * in.height;
      tx += pull * (0.5 * in.width - tx);
      ty += pull * (0.5 * in.height - ty);
      const double fill = random.uniform(options.minFill, options.maxFill) * (1.0 - 0.5 * pull);
      const double depth = in.fx * sheetWidth / (fill * in.width);
      const double axisAngle = random.uniform(0.0, 2.0 * std::numbers::pi);
      const double tilt = radians(random.uniform(options.minTiltDeg, options.maxTiltDeg));
      const double roll = radians(random.uniform(-options.maxRollDeg, options.maxRollDeg));
      const Eigen::Matrix3d rotation =
          (Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(axisAngle), std::sin(axisAngle), 0.0)) *
           Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
              .toRotationMatrix();
      const Eigen::Vector2d n = in.normalized({tx, ty});
      const Eigen::Vector3d centre = depth * Eigen::Vector3d(n.x(), n.y(), 1.0);
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.linear() = rotation;
      pose.translation() = centre - rotation * sheetCentre;
      if (sheetFits(board, in, pose)) {
        poses.push_back(pose);
        placed = true;
      }
    }
    if (!placed) {
      throw InputError({"", "pictures", 0},
                       "the checkerboard does not fit the camera's picture in any pose tried");
    }
  }
  return poses;
}

cv::Mat checkerboardLight(const CheckerboardBoard& board, const CameraIntrinsics& in,
                          const Eigen::Isometry3d& cameraFromBoard,
                          const CheckerboardShotOptions& options) {
  const int w = in.width, h = in.height;
  const Eigen::Matrix3d rotation = cameraFromBoard.linear();
  const Eigen::Vector3d t = cameraFromBoard.translation();
  const Eigen::Vector3d normal = rotation.col(2);
  const double normalDotT = normal.dot(t);
  // Board points of the pixel corners (i, j), i in 0..w, j in 0..h: exact ray–plane hits.
  const size_t stride = static_cast<size_t>(w) + 1;
  std::vector<Eigen::Vector2d> corner(stride * (static_cast<size_t>(h) + 1));
  std::vector<char> valid(corner.size(), 0);
  tbb::parallel_for(0, h + 1, [&](int j) {
    for (int i = 0; i <= w; ++i) {
      const Eigen::Vector2d n = in.normalized({static_cast<double>(i), static_cast<double>(j)});
      const Eigen::Vector3d d(n.x(), n.y(), 1.0);
      const double denom = normal.dot(d);
      if (!(std::abs(denom) > 1e-12)) continue;
      const double lambda = normalDotT / denom;
      if (!(lambda > 0.0)) continue;
      const Eigen::Vector3d p = rotation.transpose() * (lambda * d - t);
      const size_t at = static_cast<size_t>(j) * stride + static_cast<size_t>(i);
      corner[at] = p.head<2>();
      valid[at] = 1;
    }
  });
  const Eigen::Vector4d sheet = board.sheetBounds();
  auto shade = [&](const Eigen::Vector2d& p) {
    const int c = board.classAt(p.x(), p.y());
    if (c == 2) return options.background;
    const double light = 1.0 - options.lightFalloff * (p.x() - sheet[0]) / (sheet[2] - sheet[0]);
    return light * (c == 0 ? options.blackReflectance : options.whiteReflectance);
  };
  cv::Mat light(h, w, CV_32F);
  tbb::parallel_for(0, h, [&](int j) {
    float* row = light.ptr<float>(j);
    for (int i = 0; i < w; ++i) {
      const size_t a = static_cast<size_t>(j) * stride + static_cast<size_t>(i);
      const size_t idx[4] = {a, a + 1, a + stride, a + stride + 1};  // (0,0) (1,0) (0,1) (1,1)
      if (!valid[idx[0]] || !valid[idx[1]] || !valid[idx[2]] || !valid[idx[3]]) {
        row[i] = static_cast<float>(options.background);  // a ray that misses the board's plane
        continue;
      }
      const Eigen::Vector2d& p00 = corner[idx[0]];
      const Eigen::Vector2d& p10 = corner[idx[1]];
      const Eigen::Vector2d& p01 = corner[idx[2]];
      const Eigen::Vector2d& p11 = corner[idx[3]];
      const Eigen::Vector2i cell = board.cellOf(p00.x(), p00.y());
      if (board.cellOf(p10.x(), p10.y()) == cell && board.cellOf(p01.x(), p01.y()) == cell &&
          board.cellOf(p11.x(), p11.y()) == cell) {
        // Cells are convex: a pixel whose four corners share one lies inside it.
        row[i] = static_cast<float>(shade(0.25 * (p00 + p10 + p01 + p11)));
        continue;
      }
      double sum = 0.0;
      for (int sy = 0; sy < kSamplesPerSide; ++sy) {
        const double b = (sy + 0.5) / kSamplesPerSide;
        for (int sx = 0; sx < kSamplesPerSide; ++sx) {
          const double a2 = (sx + 0.5) / kSamplesPerSide;
          sum += shade((1 - a2) * (1 - b) * p00 + a2 * (1 - b) * p10 + (1 - a2) * b * p01 +
                       a2 * b * p11);
        }
      }
      row[i] = static_cast<float>(sum / (kSamplesPerSide * kSamplesPerSide));
    }
  });
  return light;
}

std::vector<cv::Mat> photographCheckerboard(const CheckerboardBoard& board,
                                            const CameraIntrinsics& intrinsics,
                                            const std::vector<Eigen::Isometry3d>& poses,
                                            const CameraRenderOptions& sensor,
                                            const CheckerboardShotOptions& options,
                                            SeededRandom& random) {
  board.validate();
  options.validate();
  sensor.validate();
  std::vector<cv::Mat> pictures;
  for (const Eigen::Isometry3d& pose : poses) {
    cv::Mat light = checkerboardLight(board, intrinsics, pose, options);
    light += sensor.ambient;  // stray light, as on the screen's pictures
    const cv::Mat recorded = recordThroughSensor(light, sensor, random);
    cv::Mat bytes;
    recorded.convertTo(bytes, CV_8U, 255.0);  // rounds, saturates: what the camera stores
    pictures.push_back(bytes);
  }
  return pictures;
}

}  // namespace parallax
