#include "calibration/simulation/ground_truth.h"

#include <gtest/gtest.h>

#include <numbers>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "calibration/simulation/seeded_random.h"
#include "calibration/simulation/synthetic_observations.h"
#include "common/input_error.h"

namespace parallax {
namespace {

TEST(GroundTruth, SameSeedSameBytesOtherSeedOtherModel) {
  const DisplayModel nominal = resolveDisplay("demo");
  GroundTruthOptions a;
  a.seed = 42;
  const std::string first = displayModelToJson(makeGroundTruth(nominal, a)).dump();
  const std::string again = displayModelToJson(makeGroundTruth(nominal, a)).dump();
  EXPECT_EQ(first, again);
  GroundTruthOptions b = a;
  b.seed = 43;
  EXPECT_NE(first, displayModelToJson(makeGroundTruth(nominal, b)).dump());
}

TEST(GroundTruth, PerturbationsStayInsideTheStatedRanges) {
  const DisplayModel nominal = resolveDisplay("default");
  GroundTruthOptions options;
  options.seed = 9;
  const DisplayModel truth = makeGroundTruth(nominal, options);
  double maxAngleDeg = 0.0, sumAngle = 0.0;
  for (size_t i = 0; i < truth.modules.size(); ++i) {
    const OpticalModule& t = truth.modules[i];
    const OpticalModule& n = nominal.modules[i];
    EXPECT_LE((t.position - n.position).cwiseAbs().maxCoeff(), options.positionLimitM + 1e-12);
    EXPECT_GT((t.position - n.position).norm(), 1e-4);  // it did move
    const double angle = t.orientation.angularDistance(n.orientation) * 180.0 / std::numbers::pi;
    maxAngleDeg = std::max(maxAngleDeg, angle);
    sumAngle += angle;
    EXPECT_LE(std::abs(t.fx / n.fx - 1.0), 3.0 * options.focalSigmaRel + 1e-12);
    EXPECT_LE(std::abs(t.k1), options.k1Limit);
    EXPECT_LE(std::abs(t.k2), options.k2Limit);
  }
  // Three angles of σ 1.5° clipped at 3°: the total turn stays below √3·3° and averages 1–4°.
  EXPECT_LE(maxAngleDeg, std::sqrt(3.0) * options.angleLimitDeg + 1e-9);
  const double meanAngle = sumAngle / static_cast<double>(truth.modules.size());
  EXPECT_GT(meanAngle, 1.0);
  EXPECT_LT(meanAngle, 4.0);
  EXPECT_NE(truth.screen.curvature, nominal.screen.curvature);
  EXPECT_NO_THROW(truth.validate());
}

TEST(GroundTruth, CurvatureAndTransferOverrides) {
  GroundTruthOptions options;
  options.curvature = 0.0;
  options.transfer = ScreenTransfer::kLinear;
  const DisplayModel truth = makeGroundTruth(resolveDisplay("demo"), options);
  EXPECT_EQ(truth.screen.curvature, 0.0);
  EXPECT_EQ(truth.screen.transfer, ScreenTransfer::kLinear);
}

TEST(GroundTruth, RejectsNonsenseOptions) {
  GroundTruthOptions options;
  options.angleSigmaDeg = -1.0;
  EXPECT_THROW(makeGroundTruth(resolveDisplay("demo"), options), InputError);
  options = {};
  options.positionSigmaM = std::nan("");
  EXPECT_THROW(makeGroundTruth(resolveDisplay("demo"), options), InputError);
}

TEST(SyntheticObservations, StripesAreNarrowAndDeterministic) {
  const DisplayModel truth = makeGroundTruth(resolveDisplay("default"), {});
  SyntheticOptions options;
  options.rig.stations = 3;
  const SyntheticCalibration a = simulateObservations(truth, options);
  const SyntheticCalibration b = simulateObservations(truth, options);
  ASSERT_EQ(a.observations.correspondences.size(), b.observations.correspondences.size());
  EXPECT_EQ(a.observations.correspondences.back().cameraPx,
            b.observations.correspondences.back().cameraPx);
  // From one station a module is seen only within half the diffusion width of its stripe:
  // its correspondences span a narrow range of module columns in any one row band.
  for (const Correspondence& c : a.observations.correspondences) {
    const OpticalModule& m = truth.modules[static_cast<size_t>(c.module)];
    ModuleOptics optics(m);
    Eigen::Vector3d d;
    ASSERT_TRUE(optics.rayDirection(c.modulePx.x(), c.modulePx.y(), &d));
    double t;
    Eigen::Vector3d s;
    ASSERT_TRUE(truth.screen.intersect(m.position, d, &t, &s));
    const double angle =
        stripeAngle(truth.screen, s, m.position, a.truePoses[static_cast<size_t>(c.camera)].centre);
    EXPECT_LE(std::abs(angle), 0.5 * truth.screen.diffusionDeg * std::numbers::pi / 180.0 + 1e-9);
  }
  // The tape is off from the truth by no more than its stated accuracy.
  for (size_t c = 0; c < a.truePoses.size(); ++c) {
    EXPECT_LE((a.truePoses[c].centre - a.observations.stations[c].tapeCentre).norm(),
              options.rig.tapeErrorM + 1e-12);
  }
}

TEST(SeededRandom, NormalHasUnitVarianceAndSplitsAreIndependent) {
  SeededRandom r(1);
  double sum = 0.0, sumSq = 0.0;
  constexpr int kN = 20000;
  for (int i = 0; i < kN; ++i) {
    const double x = r.normal();
    sum += x;
    sumSq += x * x;
  }
  EXPECT_NEAR(sum / kN, 0.0, 0.03);
  EXPECT_NEAR(sumSq / kN, 1.0, 0.04);
  SeededRandom a(7), b(7);
  SeededRandom sa = a.split(), sb = b.split();
  EXPECT_EQ(sa.uniform(), sb.uniform());
  EXPECT_NE(a.uniform(), sa.uniform());
}

}  // namespace
}  // namespace parallax
