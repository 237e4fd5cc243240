// The templated geometry of the fit agrees with the foundation's double versions, and its
// autodiff derivatives with numeric ones (including at k = 0, where the sag's square root
// and the intersection's branch choice must stay smooth).

#include "calibration/camera/calibration_geometry.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_function.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/seeded_random.h"
#include "calibration/simulation/synthetic_observations.h"

namespace parallax {
namespace {

CameraPose cameraAt(double x) {
  CameraPose pose;
  pose.centre = {x, 0.02, 2.0};
  pose.physicalFromCamera = aimCameraAt(pose.centre, Eigen::Vector3d(0.05, -0.03, 0.0));
  return pose;
}

class CurvatureSweep : public testing::TestWithParam<double> {};

TEST_P(CurvatureSweep, CameraRayHitsTheScreenWhereScreenIntersectSays) {
  Screen screen;
  screen.curvature = GetParam();
  const CameraIntrinsics intrinsics;
  SeededRandom random(5);
  int compared = 0;
  for (double x : {-1.6, -0.5, 0.0, 0.7, 1.6}) {
    const CameraPose pose = cameraAt(x);
    const auto block = packCamera(pose);
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector2d px(random.uniform(0, intrinsics.width),
                               random.uniform(0, intrinsics.height));
      const Eigen::Vector2d n = intrinsics.normalized(px);
      const Eigen::Vector3d d =
          (pose.physicalFromCamera * Eigen::Vector3d(n.x(), n.y(), 1.0)).normalized();
      double t;
      Eigen::Vector3d expected;
      // Screen::intersect accepts light from behind only; a camera looks from the front, so
      // trace the reversed ray from far behind the screen to the camera.
      const Eigen::Vector3d behind = pose.centre + 10.0 * d;
      const bool hit = screen.intersect(behind, -d, &t, &expected);
      Eigen::Vector3d s;
      const bool ours = screenPointOfCameraRay(screen.curvature, block.data(), n.x(), n.y(), &s);
      if (!hit) continue;  // outside the screen's extent: ours has no extent, nothing to compare
      ASSERT_TRUE(ours);
      EXPECT_LT((s - expected).norm(), 1e-9) << "k " << screen.curvature;
      EXPECT_NEAR(s.z(), screen.sag(s.x()), 1e-9);
      ++compared;
    }
  }
  EXPECT_GT(compared, 300);
}

TEST_P(CurvatureSweep, ModulePixelLightsTheScreenWhereModuleOpticsSays) {
  NominalDisplayOptions options;
  options.curvature = GetParam();
  const DisplayModel nominal = makeNominalDisplay(options);
  GroundTruthOptions gt;
  gt.seed = 9;
  gt.curvature = GetParam();
  const DisplayModel truth = makeGroundTruth(nominal, gt);  // distorted, rotated modules
  SeededRandom random(6);
  int compared = 0;
  for (size_t m = 0; m < truth.modules.size(); m += 7) {
    const OpticalModule& module = truth.modules[m];
    const ModuleOptics optics(module);
    const auto block = packModule(module);
    for (int i = 0; i < 50; ++i) {
      const double u = random.uniform(0, module.width), v = random.uniform(0, module.height);
      Eigen::Vector3d d, expected;
      double t;
      if (!optics.rayDirection(u, v, &d) ||
          !truth.screen.intersect(module.position, d, &t, &expected))
        continue;
      Vec3<double> s;
      ASSERT_TRUE(screenPointOfModulePixel(block.data(), module.width, module.mirror ? -1.0 : 1.0,
                                           truth.screen.curvature, u, v, &s));
      EXPECT_LT((s - expected).norm(), 1e-9) << "k " << truth.screen.curvature << " module " << m;
      ++compared;
    }
  }
  EXPECT_GT(compared, 200);
}

INSTANTIATE_TEST_SUITE_P(FitGeometry, CurvatureSweep,
                         testing::Values(0.0, 1e-4, -0.3, 0.5, 1.0 / 0.96));

TEST(FitGeometry, ModuleProjectionMatchesModuleOptics) {
  const DisplayModel nominal = resolveDisplay("demo");
  GroundTruthOptions gt;
  gt.seed = 3;
  const DisplayModel truth = makeGroundTruth(nominal, gt);
  SeededRandom random(8);
  for (const OpticalModule& m : truth.modules) {
    const ModuleOptics optics(m);
    const auto block = packModule(m);
    for (int i = 0; i < 50; ++i) {
      const Eigen::Vector3d s(random.uniform(-0.8, 0.8), random.uniform(-0.45, 0.45), 0.0);
      Eigen::Vector2d expected;
      ASSERT_TRUE(optics.project(s - m.position, &expected));
      double uv[2];
      ASSERT_TRUE(
          projectIntoModule(block.data(), m.width, m.mirror ? -1.0 : 1.0, Vec3<double>(s), uv));
      EXPECT_NEAR(uv[0], expected.x(), 1e-9);
      EXPECT_NEAR(uv[1], expected.y(), 1e-9);
    }
  }
}

TEST(FitGeometry, PackUnpackRoundTrips) {
  const DisplayModel truth = makeGroundTruth(resolveDisplay("demo"), {});
  for (const OpticalModule& m : truth.modules) {
    OpticalModule back = m;
    back.fx = back.fy = back.cx = back.cy = back.k1 = back.k2 = 0.0;
    unpackModule(packModule(m).data(), &back);
    EXPECT_NEAR(back.fx, m.fx, 1e-9);
    EXPECT_NEAR(back.cy, m.cy, 1e-9);
    EXPECT_NEAR(back.k2, m.k2, 1e-15);
    EXPECT_LT(back.orientation.angularDistance(m.orientation), 1e-12);
  }
}

TEST(FitGeometry, CameraProjectionMatchesIntrinsics) {
  CameraIntrinsics in;
  in.k1 = -0.08;
  in.k2 = 0.01;
  const CameraPose pose = cameraAt(0.4);
  const auto block = packCamera(pose);
  for (double x : {-0.8, 0.0, 0.8}) {
    for (double y : {-0.45, 0.3}) {
      const Eigen::Vector3d p(x, y, 0.01);
      Eigen::Vector2d expected;
      ASSERT_TRUE(projectPhysical(in, pose, p, &expected));
      double px[2];
      ASSERT_TRUE(projectIntoCamera(in, block.data(), Vec3<double>(p), px));
      EXPECT_NEAR(px[0], expected.x(), 1e-9);
      EXPECT_NEAR(px[1], expected.y(), 1e-9);
      // And the undistortion inverts the distortion.
      const Eigen::Vector2d n = in.normalized(expected);
      const Eigen::Vector3d q = pose.cameraFromPhysical(p);
      EXPECT_NEAR(n.x(), q.x() / q.z(), 1e-10);
      EXPECT_NEAR(n.y(), q.y() / q.z(), 1e-10);
    }
  }
}

class TransferSweep : public testing::TestWithParam<std::pair<ScreenTransfer, double>> {};

TEST_P(TransferSweep, StripeMismatchVanishesWhereTheRayFunctionSendsTheLight) {
  // A camera standing exactly at a pixel's observer-line origin o sees that pixel's light at
  // the centre of the stripe: the mismatch must be zero there, and not elsewhere.
  NominalDisplayOptions options;
  options.preset = "demo";
  options.curvature = GetParam().second;
  options.transfer = GetParam().first;
  const DisplayModel model = makeNominalDisplay(options);
  int checked = 0;
  for (int m : {0, 7, 15}) {
    const RayFunction rays(model, m);
    for (int j = 10; j < 384; j += 60) {
      for (int i = 10; i < 512; i += 60) {
        const PixelRay ray = rays.atPixel(i, j);
        if (!ray.valid()) continue;
        const Vec3<double> p = model.modules[static_cast<size_t>(m)].position;
        const double mismatch = stripeMismatch<double>(
            model.screen.transfer, model.screen.curvature, ray.screenPoint, p, ray.origin);
        EXPECT_NEAR(mismatch, 0.0, 1e-9);
        const Vec3<double> aside = ray.origin + Eigen::Vector3d(0.05, 0.0, 0.0);
        EXPECT_GT(std::abs(stripeMismatch<double>(model.screen.transfer, model.screen.curvature,
                                                  ray.screenPoint, p, aside)),
                  1e-3);
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 50);
}

INSTANTIATE_TEST_SUITE_P(FitGeometry, TransferSweep,
                         testing::Values(std::pair{ScreenTransfer::kConical, 0.0},
                                         std::pair{ScreenTransfer::kLinear, 0.0},
                                         std::pair{ScreenTransfer::kConical, 0.8},
                                         std::pair{ScreenTransfer::kLinear, -0.5}));

// A correspondence-like cost built from the templates, for the gradient check.
struct TestCost {
  double nx, ny, width;
  template <typename T>
  bool operator()(const T* module, const T* camera, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfCameraRay(k[0], camera, nx, ny, &s)) return false;
    T uv[2];
    if (!projectIntoModule(module, width, -1.0, s, uv)) return false;
    const Vec3<T> p(module[4], module[5], module[6]);
    const Vec3<T> c(camera[4], camera[5], camera[6]);
    r[0] = uv[0];
    r[1] = uv[1];
    r[2] = T(1000) * stripeMismatch(ScreenTransfer::kConical, k[0], s, p, c);
    return true;
  }
};

// The screen point a module pixel lights (mm), the camera-px residual's first half: its
// undistortion is iterated on plain values and differentiated by one Newton step in Jets.
struct ModulePixelScreenCost {
  double u, v, width, mirrorSign;

  template <typename T>
  bool operator()(const T* module, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfModulePixel(module, width, mirrorSign, k[0], u, v, &s)) return false;
    for (int i = 0; i < 3; ++i) r[i] = T(1000) * s[i];
    return true;
  }
};

TEST(FitGeometry, UndistortionDerivativesMatchNumeric) {
  // Strong barrel and pincushion terms and a pixel near the image corner, where the Newton
  // step's derivatives differ most from a single fixed-point step's.
  const DisplayModel model = makeGroundTruth(resolveDisplay("demo"), {});
  const OpticalModule& optics = model.modules[6];
  auto module0 = packModule(optics);
  module0[11] = -0.12;
  module0[12] = 0.03;
  const ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<9>>
      manifold;
  for (double k0 : {0.0, 0.4}) {
    for (const auto& [u, v] :
         {std::pair{60.0, 40.0}, std::pair{256.0, 192.0}, std::pair{450.0, 340.0}}) {
      ceres::AutoDiffCostFunction<ModulePixelScreenCost, 3, kModuleBlockSize, 1> cost(
          new ModulePixelScreenCost{u, v, static_cast<double>(optics.width),
                                    optics.mirror ? -1.0 : 1.0});
      double k = k0;
      const double* params[] = {module0.data(), &k};
      double r[3];
      Eigen::Matrix<double, 3, kModuleBlockSize, Eigen::RowMajor> jm;
      Eigen::Matrix<double, 3, 1> jk;
      double* jacobians[] = {jm.data(), jk.data()};
      ASSERT_TRUE(cost.Evaluate(params, r, jacobians));
      Eigen::Matrix<double, kModuleBlockSize, kModuleTangentSize, Eigen::RowMajor> pm;
      ASSERT_TRUE(manifold.PlusJacobian(module0.data(), pm.data()));
      Eigen::Matrix<double, 3, kModuleTangentSize + 1> analytic;
      analytic << jm * pm, jk;
      for (int column = 0; column < analytic.cols(); ++column) {
        constexpr double kStep = 1e-6;
        Eigen::Vector3d plus, minus;
        for (double sign : {1.0, -1.0}) {
          auto m = module0;
          double kk = k0;
          if (column < kModuleTangentSize) {
            double delta[kModuleTangentSize] = {};
            delta[column] = sign * kStep;
            manifold.Plus(module0.data(), delta, m.data());
          } else {
            kk += sign * kStep;
          }
          const double* p[] = {m.data(), &kk};
          ASSERT_TRUE(cost.Evaluate(p, (sign > 0 ? plus : minus).data(), nullptr));
        }
        const Eigen::Vector3d numeric = (plus - minus) / (2.0 * kStep);
        const double scale = std::max(1.0, numeric.norm());
        EXPECT_LT((numeric - analytic.col(column)).norm() / scale, 1e-5)
            << "k = " << k0 << ", pixel (" << u << ", " << v << "), tangent column " << column
            << "\nnumeric " << numeric.transpose() << "\nautodiff "
            << analytic.col(column).transpose();
      }
    }
  }
}

TEST(FitGeometry, AutodiffJacobianMatchesNumericIncludingFlatScreen) {
  // Autodiff Jacobian mapped to the tangent spaces (what the solver uses) against central
  // differences taken through the manifolds' Plus, at k = 0 and on a curved screen.
  const DisplayModel model = makeGroundTruth(resolveDisplay("demo"), {});
  const auto module0 = packModule(model.modules[4]);
  const auto camera0 = packCamera(cameraAt(0.3));
  const ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<9>>
      moduleManifold;
  const ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>
      cameraManifold;
  for (double k0 : {0.0, 0.4}) {
    ceres::AutoDiffCostFunction<TestCost, 3, kModuleBlockSize, kCameraBlockSize, 1> cost(
        new TestCost{0.05, -0.02, 512.0});
    auto module = module0;
    auto camera = camera0;
    double k = k0;
    const double* params[] = {module.data(), camera.data(), &k};
    double r[3];
    Eigen::Matrix<double, 3, kModuleBlockSize, Eigen::RowMajor> jm;
    Eigen::Matrix<double, 3, kCameraBlockSize, Eigen::RowMajor> jc;
    Eigen::Matrix<double, 3, 1> jk;
    double* jacobians[] = {jm.data(), jc.data(), jk.data()};
    ASSERT_TRUE(cost.Evaluate(params, r, jacobians));
    Eigen::Matrix<double, kModuleBlockSize, kModuleTangentSize, Eigen::RowMajor> pm;
    Eigen::Matrix<double, kCameraBlockSize, kCameraTangentSize, Eigen::RowMajor> pc;
    ASSERT_TRUE(moduleManifold.PlusJacobian(module.data(), pm.data()));
    ASSERT_TRUE(cameraManifold.PlusJacobian(camera.data(), pc.data()));
    Eigen::Matrix<double, 3, kModuleTangentSize + kCameraTangentSize + 1> analytic;
    analytic << jm * pm, jc * pc, jk;

    auto evaluate = [&](int column, double h, Eigen::Vector3d* out) {
      auto m = module0;
      auto c = camera0;
      double kk = k0;
      if (column < kModuleTangentSize) {
        double delta[kModuleTangentSize] = {};
        delta[column] = h;
        moduleManifold.Plus(module0.data(), delta, m.data());
      } else if (column < kModuleTangentSize + kCameraTangentSize) {
        double delta[kCameraTangentSize] = {};
        delta[column - kModuleTangentSize] = h;
        cameraManifold.Plus(camera0.data(), delta, c.data());
      } else {
        kk += h;
      }
      const double* p[] = {m.data(), c.data(), &kk};
      return cost.Evaluate(p, out->data(), nullptr);
    };
    for (int column = 0; column < analytic.cols(); ++column) {
      constexpr double kStep = 1e-6;
      Eigen::Vector3d plus, minus;
      ASSERT_TRUE(evaluate(column, kStep, &plus));
      ASSERT_TRUE(evaluate(column, -kStep, &minus));
      const Eigen::Vector3d numeric = (plus - minus) / (2.0 * kStep);
      const double scale = std::max(1.0, numeric.norm());
      EXPECT_LT((numeric - analytic.col(column)).norm() / scale, 1e-5)
          << "k = " << k0 << ", tangent column " << column << "\nnumeric " << numeric.transpose()
          << "\nautodiff " << analytic.col(column).transpose();
    }
  }
}

}  // namespace
}  // namespace parallax
