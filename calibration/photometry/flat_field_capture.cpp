#include "calibration/photometry/flat_field_capture.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/conventions.h"
#include "common/input_error.h"

namespace parallax {
namespace {

// Per camera pixel (every pixelStep-th), the module it sees most and where.
struct PixelView {
  int x = 0, y = 0;
  int module = -1;  // −1: no module's lobe reaches it
  float u = 0, v = 0, weight = 0;
  float totalWeight = 0;  // every module's lobe here: they all show their black at once
};

std::vector<PixelView> viewsFromStation(const DisplayModel& model,
                                        const CameraIntrinsics& intrinsics, const CameraPose& pose,
                                        int step) {
  std::vector<ModuleOptics> optics;
  for (const OpticalModule& m : model.modules) optics.emplace_back(m);
  // FWHM = diffusion width ⇒ σ = FWHM / (2 √(2 ln 2)): the lobe the simulator and the observer
  // view use.
  const double sigma = diffusionSigma(model.screen.diffusionDeg);
  const auto camera = packCamera(pose);
  const int columns = (intrinsics.width + step - 1) / step,
            rows = (intrinsics.height + step - 1) / step;
  std::vector<PixelView> views(static_cast<size_t>(columns) * static_cast<size_t>(rows));
  tbb::parallel_for(0, rows, [&](int row) {
    for (int column = 0; column < columns; ++column) {
      PixelView& out = views[static_cast<size_t>(row) * static_cast<size_t>(columns) +
                             static_cast<size_t>(column)];
      out.x = column * step;
      out.y = row * step;
      const Eigen::Vector2d n = intrinsics.normalized({out.x + 0.5, out.y + 0.5});
      Vec3<double> s;
      if (!screenPointOfCameraRay(model.screen.curvature, camera.data(), n.x(), n.y(), &s))
        continue;
      if (!model.screen.contains(s.x(), s.y())) continue;
      for (size_t m = 0; m < model.modules.size(); ++m) {
        const double angle = stripeAngle(model.screen, s, model.modules[m].position, pose.centre);
        const double weight = std::exp(-0.5 * (angle / sigma) * (angle / sigma));
        if (!(weight > 1e-3)) continue;
        Eigen::Vector2d uv;
        const OpticalModule& mod = model.modules[m];
        if (!optics[m].project(s - mod.position, &uv)) continue;
        if (uv.x() < 0.0 || uv.y() < 0.0 || uv.x() > mod.width || uv.y() > mod.height) continue;
        out.totalWeight += static_cast<float>(weight);
        if (!(weight > out.weight)) continue;
        out.module = static_cast<int>(m);
        out.u = static_cast<float>(uv.x());
        out.v = static_cast<float>(uv.y());
        out.weight = static_cast<float>(weight);
      }
    }
  });
  return views;
}

std::vector<std::vector<int>> groupsOf(int modules, int stride) {
  std::vector<std::vector<int>> groups(static_cast<size_t>(std::min(stride, modules)));
  for (int m = 0; m < modules; ++m) groups[static_cast<size_t>(m % stride)].push_back(m);
  return groups;
}

}  // namespace

void FlatFieldOptions::validate() const {
  auto check = [](bool ok, const char* field, const std::string& why) {
    if (!ok) throw InputError({"", field, 0}, why);
  };
  check(!levels.empty() && levels.size() <= 64, "levels", "must hold 1..64 codes");
  for (size_t i = 0; i < levels.size(); ++i) {
    check(levels[i] >= 1 && levels[i] <= 255 && (i == 0 || levels[i] > levels[i - 1]), "levels",
          "must be increasing codes in 1..255");
  }
  check(levels.back() == 255, "levels", "must end at 255 (full drive)");
  check(groupStride >= 1 && groupStride <= 64, "group_stride", "must be 1..64");
  check(exposure > 0.0 && exposure <= 100.0, "exposure", "must be in (0, 100]");
  check(maxRetakes >= 0 && maxRetakes <= 10, "max_retakes", "must be 0..10");
  check(minLobeWeight > 0.0 && minLobeWeight < 1.0, "min_lobe_weight", "must be in (0, 1)");
  check(pixelStep >= 1 && pixelStep <= 16, "pixel_step", "must be 1..16");
}

FlatFieldCaptures captureFlatFields(const DisplayModel& model, const CameraIntrinsics& intrinsics,
                                    const std::vector<CameraPose>& poses, double responseGamma,
                                    const FlatFieldCamera& camera,
                                    const FlatFieldOptions& options) {
  options.validate();
  model.validate();
  const auto start = std::chrono::steady_clock::now();
  FlatFieldCaptures out;
  out.options = options;
  const int moduleCount = static_cast<int>(model.modules.size());
  out.moduleWidth = model.modules.front().width;
  out.moduleHeight = model.modules.front().height;
  for (const OpticalModule& m : model.modules) {
    if (m.width != out.moduleWidth || m.height != out.moduleHeight) {
      throw InputError({"", "modules", 0}, "photometric capture needs modules of one resolution");
    }
  }
  out.modules.resize(static_cast<size_t>(moduleCount));
  const int shots = out.shotCount();
  for (ModuleFlatFields& m : out.modules) m.light.resize(static_cast<size_t>(shots));

  // The uniform frames, one buffer per shot, shared by every module showing it.
  const size_t frameBytes =
      static_cast<size_t>(out.moduleWidth) * static_cast<size_t>(out.moduleHeight) * 3;
  std::vector<std::vector<std::uint8_t>> shotFrames(static_cast<size_t>(shots));
  for (int shot = 0; shot < shots; ++shot) {
    auto& f = shotFrames[static_cast<size_t>(shot)];
    f.assign(frameBytes, 0);
    if (shot == 0) continue;
    const int c = (shot - 1) / static_cast<int>(options.levels.size());
    const int level = options.levels[static_cast<size_t>((shot - 1) % options.levels.size())];
    for (size_t i = static_cast<size_t>(c); i < frameBytes; i += 3)
      f[i] = static_cast<std::uint8_t>(level);
  }
  const std::vector<std::uint8_t>& black = shotFrames[0];

  for (size_t station = 0; station < poses.size(); ++station) {
    const std::vector<PixelView> views =
        viewsFromStation(model, intrinsics, poses[station], options.pixelStep);
    for (const std::vector<int>& group : groupsOf(moduleCount, options.groupStride)) {
      std::vector<const PixelView*> looked;  // pixels seeing a module of this group well
      for (const PixelView& p : views) {
        if (p.module >= 0 && p.weight >= options.minLobeWeight &&
            std::find(group.begin(), group.end(), p.module) != group.end()) {
          looked.push_back(&p);
        }
      }
      std::vector<const PixelView*> ambientPixels;
      for (const PixelView& p : views)
        if (p.totalWeight == 0.0f) ambientPixels.push_back(&p);
      Eigen::Vector3f ambient = Eigen::Vector3f::Zero();
      for (int shot = 0; shot < shots; ++shot) {
        std::vector<const std::uint8_t*> frames(static_cast<size_t>(moduleCount), black.data());
        for (int m : group)
          frames[static_cast<size_t>(m)] = shotFrames[static_cast<size_t>(shot)].data();
        const std::string what = fmt::format("station {}, modules {{{}}}, frame {}", station,
                                             fmt::join(group, ","), shot);
        double exposure = options.exposure;
        cv::Mat picture;
        for (int attempt = 0;; ++attempt) {
          picture = camera(static_cast<int>(station), frames, exposure);
          ++out.pictures;
          if (picture.empty() || picture.type() != CV_32FC3 || picture.cols != intrinsics.width ||
              picture.rows != intrinsics.height) {
            throw PhotometricCaptureError(fmt::format(
                "photometric capture: the camera gave no picture of the expected size ({}x{}, "
                "RGB) at {}",
                intrinsics.width, intrinsics.height, what));
          }
          double highest = 0.0;
          cv::minMaxLoc(picture.reshape(1), nullptr, &highest);
          if (highest <= 1.0 / 255.0) {
            // Nothing at all, not even ambient light or the black level: no picture was taken.
            if (attempt == 0) {
              ++out.retakes;
              continue;
            }
            throw PhotometricCaptureError(fmt::format(
                "photometric capture: the camera's picture is black at {} (lens covered or the "
                "camera failed); nothing installed",
                what));
          }
          size_t saturated = 0;
          for (const PixelView* p : looked) {
            const cv::Vec3f v = picture.at<cv::Vec3f>(p->y, p->x);
            saturated += std::max({v[0], v[1], v[2]}) >= 254.5f / 255.0f;
          }
          if (saturated * 1000 <= looked.size()) break;
          if (attempt >= options.maxRetakes) {
            throw PhotometricCaptureError(fmt::format(
                "photometric capture: the camera saturates at {} even at exposure {:.3g} ({} "
                "retakes); lower its gain or aperture; nothing installed",
                what, exposure, attempt));
          }
          exposure *= 0.5;
          ++out.retakes;
        }
        const float gamma = static_cast<float>(responseGamma),
                    toLight = static_cast<float>(1.0 / exposure);
        auto linearAt = [&](int x, int y) {
          const cv::Vec3f v = picture.at<cv::Vec3f>(y, x);
          Eigen::Vector3f l;
          for (int c = 0; c < 3; ++c) l[c] = std::pow(v[c], gamma) * toLight;
          return l;
        };
        if (shot == 0 && !ambientPixels.empty()) {
          // Light nobody's module sends: the room's, in every picture of this station.
          std::vector<float> channel[3];
          for (const PixelView* p : ambientPixels) {
            const Eigen::Vector3f l = linearAt(p->x, p->y);
            for (int c = 0; c < 3; ++c) channel[c].push_back(l[c]);
          }
          for (int c = 0; c < 3; ++c) {
            auto mid = channel[c].begin() + static_cast<long>(channel[c].size() / 2);
            std::nth_element(channel[c].begin(), mid, channel[c].end());
            ambient[c] = *mid;
          }
        }
        for (const PixelView* p : looked) {
          ModuleFlatFields& m = out.modules[static_cast<size_t>(p->module)];
          if (shot == 0) m.samples.push_back({p->u, p->v, p->weight});
          const Eigen::Vector3f l = linearAt(p->x, p->y);
          Eigen::Vector3f light;
          for (int c = 0; c < 3; ++c) light[c] = (l[c] - ambient[c]) / p->weight;
          m.light[static_cast<size_t>(shot)].push_back(light);
          // In the black picture every module's lobe brings its black (the group's neighbours
          // are black in every picture, so differences with it are this module's alone).
          if (shot == 0) m.black.push_back(light * (p->weight / p->totalWeight));
        }
      }
    }
  }
  out.captureSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace parallax
