// The calibration stability suite (issue 6): fits on synthetic correspondences from a seeded
// ground truth, one case per stress the issue names, each with its tolerance stated. Every
// case prints one line of the stability table ("STABILITY | case | ...") for the closing note.
//
// Ray errors are compared with the ground truth over each module's whole image, including
// the parts no camera saw (the fit extrapolates there), so they are larger than the residuals.

#include "calibration/fit/display_fit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/fit_problem.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/seeded_random.h"
#include "calibration/simulation/synthetic_observations.h"
#include "common/input_error.h"

namespace parallax {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct Case {
  DisplayModel nominal;
  DisplayModel truth;
  SyntheticOptions sim;
  FitOptions fit;
};

struct Outcome {
  FitResult fit;
  RayErrorStats rays;  // all observed modules
  std::vector<RayErrorStats> perModule;
  RayErrorStats nominalRays;  // the nominal model's error, for scale
  SyntheticCalibration data;
};

DisplayModel demoNominal(std::optional<double> curvature = std::nullopt) {
  NominalDisplayOptions options;
  options.preset = "demo";
  options.curvature = curvature;
  return makeNominalDisplay(options);
}

Case demoCase(std::uint64_t seed, std::optional<double> truthCurvature = std::nullopt) {
  Case c;
  c.nominal = demoNominal();
  GroundTruthOptions gt;
  gt.seed = seed;
  gt.curvature = truthCurvature;
  c.truth = makeGroundTruth(c.nominal, gt);
  c.sim.seed = seed + 100;
  c.sim.rig.spanM = 3.2;  // stations from −1.6 m to +1.6 m: stripes spread over the screen
  c.fit.threads = 2;
  return c;
}

bool finite(const RayErrorStats& s) {
  return std::isfinite(s.rmsPx) && std::isfinite(s.maxPx) && std::isfinite(s.rmsScreenMm) &&
         std::isfinite(s.maxScreenMm) && std::isfinite(s.rmsObserverMm) &&
         std::isfinite(s.maxObserverMm);
}

Outcome run(const std::string& name, const Case& c) {
  Outcome o;
  o.data = simulateObservations(c.truth, c.sim);
  o.fit = fitDisplay(c.nominal, o.data.observations, c.fit);
  o.perModule = compareRays(c.truth, o.fit.model);
  for (size_t m = 0; m < o.perModule.size(); ++m) {
    if (o.fit.modules[m].observed) o.rays.merge(o.perModule[m]);
  }
  o.nominalRays = totalRayError(compareRays(c.truth, c.nominal));
  std::printf(
      "STABILITY | %-28s | ray px rms %.4f max %.3f | screen mm rms %.3f max %.3f | observer mm "
      "rms "
      "%.2f max %.2f | k %.5f (true %.5f) | %.2f s, %d it | %s\n",
      name.c_str(), o.rays.rmsPx, o.rays.maxPx, o.rays.rmsScreenMm, o.rays.maxScreenMm,
      o.rays.rmsObserverMm, o.rays.maxObserverMm, o.fit.model.screen.curvature,
      c.truth.screen.curvature, o.fit.solveSeconds, o.fit.iterations,
      o.fit.passesQualityChecks() ? "passes" : "REFUSED");
  for (const Deficiency& d : o.fit.deficiencies) std::printf("    %s\n", d.describe().c_str());
  for (const std::string& n : o.fit.notes) std::printf("    note: %s\n", n.c_str());
  for (const std::string& g : o.fit.gate.describe()) std::printf("    gate: %s\n", g.c_str());
  // No NaN in any case.
  EXPECT_TRUE(finite(o.rays)) << name;
  EXPECT_TRUE(std::isfinite(o.fit.model.screen.curvature));
  for (const ModuleFit& m : o.fit.modules) {
    EXPECT_TRUE(std::isfinite(m.rmsPx)) << name << " module " << m.module;
    for (double sd : m.stdDev) EXPECT_FALSE(std::isnan(sd)) << name << " module " << m.module;
  }
  return o;
}

// ---- screens ----

TEST(DisplayFit, FlatScreen) {
  Case c = demoCase(11, 0.0);
  const Outcome o = run("flat k=0", c);
  EXPECT_TRUE(o.fit.passesQualityChecks());
  EXPECT_NEAR(o.fit.model.screen.curvature, 0.0, 5e-4);
  EXPECT_LT(o.rays.rmsPx, 0.1);
  EXPECT_LT(o.rays.maxPx, 1.5);
  EXPECT_LT(o.rays.rmsPx, 0.02 * o.nominalRays.rmsPx);  // the fit removes ≥ 98% of the error
}

TEST(DisplayFit, NearlyFlatScreen) {
  Case c = demoCase(12, 1.0 / 10000.0);  // R = 10 km
  const Outcome o = run("nearly flat R=10km", c);
  EXPECT_TRUE(o.fit.passesQualityChecks());
  EXPECT_NEAR(o.fit.model.screen.curvature, 1e-4, 5e-4);
  EXPECT_LT(o.rays.rmsPx, 0.1);
}

TEST(DisplayFit, StronglyCurvedScreen) {
  // R = 0.6 W; the nominal design is curved too (a flat drawing of a curved screen is not a
  // nominal model anyone would start from), the truth's k is off by its usual perturbation.
  const double k = 1.0 / (0.6 * 1.6);
  Case c = demoCase(13);
  c.nominal = demoNominal(k);
  GroundTruthOptions gt;
  gt.seed = 13;
  c.truth = makeGroundTruth(c.nominal, gt);
  const Outcome o = run("strongly curved R=0.6W", c);
  // Rays leaving a strongly curved screen's edges at grazing angles meet the observer line far
  // from where a small error would put them: the gate may refuse (measured: true worst 24 mm
  // on the observer line against the 15 mm limit); what it installs is within its limits.
  if (o.fit.passesQualityChecks()) {
    EXPECT_LE(o.rays.maxObserverMm, c.fit.gate.worstObserverMm);
  } else {
    EXPECT_FALSE(o.fit.gate.describe().empty());
  }
  EXPECT_NEAR(o.fit.model.screen.curvature, c.truth.screen.curvature, 2e-3);
  EXPECT_LT(o.rays.rmsPx, 0.15);
}

// ---- transfer mismatch ----

// Both transfers are fitted and the stripes' χ² decides (transfer_selection.h): a wrong assumed
// transfer is not installed; the one the data support is, and the report says so.
TEST(DisplayFit, LinearTruthFittedAsConicalIsDetectedAndCorrected) {
  Case c = demoCase(14);
  GroundTruthOptions gt;
  gt.seed = 14;
  gt.transfer = ScreenTransfer::kLinear;
  c.truth = makeGroundTruth(c.nominal, gt);
  c.fit.transfer = ScreenTransfer::kConical;
  const Outcome o = run("linear truth, conical fit", c);
  EXPECT_FALSE(o.fit.transferMismatch);
  EXPECT_EQ(o.fit.model.screen.transfer, ScreenTransfer::kLinear);
  ASSERT_TRUE(o.fit.transferEvidence.has_value());
  EXPECT_TRUE(o.fit.transferEvidence->decided);
  EXPECT_GT(o.fit.transferEvidence->deltaChi2, kDecisiveChi2);
  bool said = false;
  for (const std::string& n : o.fit.notes)
    said |= n.find("the stripes reject the assumed conical transfer") != std::string::npos;
  EXPECT_TRUE(said) << "the report must name the transfer that fits";
  EXPECT_LT(o.rays.maxObserverMm, c.fit.gate.worstObserverMm);
}

TEST(DisplayFit, ConicalTruthFittedAsLinearIsDetectedAndCorrected) {
  Case c = demoCase(15);
  c.fit.transfer = ScreenTransfer::kLinear;
  const Outcome o = run("conical truth, linear fit", c);
  EXPECT_FALSE(o.fit.transferMismatch);
  EXPECT_EQ(o.fit.model.screen.transfer, ScreenTransfer::kConical);
  bool said = false;
  for (const std::string& n : o.fit.notes)
    said |= n.find("the stripes reject the assumed linear transfer") != std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_LT(o.rays.maxObserverMm, c.fit.gate.worstObserverMm);
}

TEST(DisplayFit, MatchingTransferIsNotFlagged) {
  Case c = demoCase(16);
  GroundTruthOptions gt;
  gt.seed = 16;
  gt.transfer = ScreenTransfer::kLinear;
  c.nominal.screen.transfer = ScreenTransfer::kLinear;
  c.truth = makeGroundTruth(c.nominal, gt);
  const Outcome o = run("linear truth, linear fit", c);
  EXPECT_FALSE(o.fit.transferMismatch);
  EXPECT_TRUE(o.fit.passesQualityChecks());
  EXPECT_LT(o.rays.rmsPx, 0.1);
}

// ---- awkward modules ----

TEST(DisplayFit, GrazingModulesYawed45Degrees) {
  Case c = demoCase(17);
  // The two outermost modules moved out to ±1 m and aimed at the screen centre: 45° yaw.
  for (size_t i : {size_t{0}, c.nominal.modules.size() - 1}) {
    OpticalModule& m = c.nominal.modules[i];
    m.position = {i == 0 ? -1.0 : 1.0, 0.0, -1.0};
    m.orientation = aimModuleAt(m.position, Eigen::Vector3d::Zero());
  }
  GroundTruthOptions gt;
  gt.seed = 17;
  c.truth = makeGroundTruth(c.nominal, gt);
  const Outcome o = run("modules yawed ±45°", c);
  EXPECT_TRUE(o.fit.passesQualityChecks());
  for (size_t i : {size_t{0}, c.nominal.modules.size() - 1}) {
    EXPECT_TRUE(o.fit.modules[i].observed);
    EXPECT_LT(o.perModule[i].rmsPx, 0.3) << "module " << i;
  }
}

TEST(DisplayFit, ModuleSeeingTwentyPercentOfTheScreen) {
  Case c = demoCase(18);
  // Module 5 with a 2.2× longer focal length: its image covers ~45% of the width and ~45% of
  // the height, about 20% of the screen's area.
  const size_t narrow = 5;
  c.nominal.modules[narrow].fx *= 2.2;
  c.nominal.modules[narrow].fy *= 2.2;
  GroundTruthOptions gt;
  gt.seed = 18;
  c.truth = makeGroundTruth(c.nominal, gt);
  const Outcome o = run("module seeing 20% of screen", c);
  EXPECT_TRUE(o.fit.modules[narrow].observed);
  EXPECT_GT(o.fit.modules[narrow].correspondences, 20);
  EXPECT_LT(o.perModule[narrow].rmsPx, 0.5);
  EXPECT_TRUE(o.fit.passesQualityChecks());
}

TEST(DisplayFit, UnseenModuleIsReportedAndKeptNominal) {
  Case c = demoCase(19);
  c.sim.hiddenModules = {3};
  c.fit.gate.allowPartial = true;  // without it the unseen module fails the whole calibration
  const Outcome o = run("module not seen at all", c);
  EXPECT_TRUE(o.fit.passesQualityChecks());
  EXPECT_FALSE(o.fit.modules[3].observed);
  EXPECT_EQ(o.fit.model.modules[3].position, c.nominal.modules[3].position);
  bool said = false;
  for (const std::string& n : o.fit.notes)
    said |= n.find("module 3 was not seen") != std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_LT(o.rays.rmsPx, 0.1);  // the other modules are unaffected
}

TEST(DisplayFit, RefitOfOneModuleHoldsTheOthers) {
  // A replaced module: the installed calibration (here the truth itself) is right for every
  // module but 5, which starts from its nominal pose; refitting with the rest held must move
  // only module 5 and bring it to the truth.
  Case c = demoCase(23);
  DisplayModel start = c.truth;
  start.modules[5] = c.nominal.modules[5];
  for (int m = 0; m < 16; ++m) {
    if (m != 5) c.fit.heldModules.push_back(m);
  }
  c.fit.fitCurvature = false;
  const SyntheticCalibration data = simulateObservations(c.truth, c.sim);
  const FitResult fit = fitDisplay(start, data.observations, c.fit);
  for (int m = 0; m < 16; ++m) {
    if (m == 5) continue;
    EXPECT_EQ(fit.model.modules[static_cast<size_t>(m)].position,
              c.truth.modules[static_cast<size_t>(m)].position)
        << m;
    EXPECT_EQ(fit.model.modules[static_cast<size_t>(m)].fx,
              c.truth.modules[static_cast<size_t>(m)].fx)
        << m;
  }
  const std::vector<RayErrorStats> perModule = compareRays(c.truth, fit.model);
  const std::vector<RayErrorStats> before = compareRays(c.truth, start);
  std::printf("STABILITY | %-28s | module 5 ray px rms %.4f (started at %.2f) | %s\n",
              "refit of one module", perModule[5].rmsPx, before[5].rmsPx,
              fit.passesQualityChecks() ? "passes" : "REFUSED");
  EXPECT_LT(perModule[5].rmsPx, 0.1);
  EXPECT_GT(before[5].rmsPx, 10.0 * perModule[5].rmsPx);
  EXPECT_TRUE(fit.passesQualityChecks());
  c.fit.heldModules = {16};
  EXPECT_THROW(fitDisplay(start, data.observations, c.fit), InputError);
}

// ---- noise, outliers, start ----

class NoiseLevel : public testing::TestWithParam<std::pair<double, double>> {};

TEST_P(NoiseLevel, RayErrorGrowsWithCameraNoise) {
  const auto [noise, tolerance] = GetParam();
  Case c = demoCase(20);
  c.sim.noisePx = noise;
  const Outcome o = run("camera noise " + std::to_string(noise).substr(0, 3) + " px", c);
  // The re-estimated noise (module px) tracks the camera noise (≈ 0.27 module px per camera px
  // on the demo display).
  EXPECT_NEAR(o.fit.correspondenceSigmaPx / noise, 0.27, 0.08);
  // The gate's limits are fixed: a noisier camera either still meets them, and then the rays
  // truly do, or the calibration is refused with a reason — never installed beyond them.
  if (o.fit.passesQualityChecks()) {
    EXPECT_LT(o.rays.rmsPx, tolerance);
    EXPECT_LE(o.rays.maxPx, c.fit.gate.worstPx);
    EXPECT_LE(o.rays.maxObserverMm, c.fit.gate.worstObserverMm);
  } else {
    EXPECT_FALSE(o.fit.gate.describe().empty());
  }
  if (noise <= 0.1) {  // at 0.5 px the corners of demo's outer modules pass 3 px (3σ)
    EXPECT_TRUE(o.fit.passesQualityChecks());
  }
}

// Tolerances ~2× the measured RMS ray error.
INSTANTIATE_TEST_SUITE_P(Stability, NoiseLevel,
                         testing::Values(std::pair{0.1, 0.04}, std::pair{0.5, 0.15},
                                         std::pair{2.0, 0.6}));

TEST(DisplayFit, TenPercentGrossOutliers) {
  Case clean = demoCase(21);
  Case dirty = demoCase(21);
  dirty.sim.outlierFraction = 0.10;
  const Outcome a = run("clean (outlier reference)", clean);
  const Outcome b = run("10% gross outliers", dirty);
  EXPECT_TRUE(b.fit.passesQualityChecks());
  const double fraction = static_cast<double>(b.fit.outliers) /
                          static_cast<double>(b.data.observations.correspondences.size());
  EXPECT_NEAR(fraction, 0.10, 0.02);
  EXPECT_LT(b.rays.rmsPx, 1.5 * a.rays.rmsPx + 0.01);
  // Independent gross errors leave every decode at the typical share: none is left out.
  EXPECT_TRUE(b.fit.unreliableDecodes.empty()) << b.fit.unreliableDecodes.size();
}

// A decode whose gross errors come together (one station's view of one module, as a module seen
// at a steep angle gives) biases its inliers too: it is left out whole and named, the module
// keeps its other stations' decodes, and the fit still passes.
TEST(DisplayFit, ADecodeFullOfGrossErrorsIsLeftOut) {
  Case c = demoCase(23);
  Outcome clean = run("clean (decode reference)", c);
  ASSERT_TRUE(clean.fit.unreliableDecodes.empty());
  CalibrationObservations obs = clean.data.observations;
  // A third of station 0's view of module 5 decoded 4 px off; its inliers 0.3 px off together.
  int n = 0;
  for (Correspondence& k : obs.correspondences) {
    if (k.camera != 0 || k.module != 5) continue;
    k.modulePx += (n++ % 3 == 0) ? Eigen::Vector2d(4.0, -4.0) : Eigen::Vector2d(0.3, 0.0);
  }
  ASSERT_GE(n, 20);
  const FitResult fit = fitDisplay(c.nominal, obs, c.fit);
  ASSERT_EQ(fit.unreliableDecodes.size(), 1u);
  EXPECT_EQ(fit.unreliableDecodes[0].station, 0);
  EXPECT_EQ(fit.unreliableDecodes[0].module, 5);
  bool named = false;
  for (const std::string& note : fit.notes)
    named |= note.find("station 0 module 5") != std::string::npos;
  EXPECT_TRUE(named);
  EXPECT_TRUE(fit.passesQualityChecks());
  // Its bias did not move the module: within 3σ of the clean fit's ray error plus the truth's.
  const RayErrorStats five = compareRays(c.truth, fit.model)[5];
  EXPECT_LT(five.maxPx, clean.perModule[5].maxPx + 3.0 * fit.gate.modules[5].predicted.worstPx);
  // Kept, the same decode pulls the module off (the reason it goes).
  FitOptions keep = c.fit;
  keep.unreliableDecodeTail = 0.0;
  const FitResult kept = fitDisplay(c.nominal, obs, keep);
  EXPECT_TRUE(kept.unreliableDecodes.empty());
  const RayErrorStats keptFive = compareRays(c.truth, kept.model)[5];
  std::printf("module 5 worst: clean %.3f px, decode left out %.3f, kept %.3f\n",
              clean.perModule[5].maxPx, five.maxPx, keptFive.maxPx);
  EXPECT_GT(keptFive.maxPx, five.maxPx);
}

TEST(DisplayFit, BinomialTail) {
  EXPECT_DOUBLE_EQ(fit::binomialUpperTail(10, 0, 0.3), 1.0);
  EXPECT_NEAR(fit::binomialUpperTail(10, 10, 0.5), std::pow(0.5, 10), 1e-15);
  // P(X ≥ 2), n 3, p 0.5: (3 + 1) / 8.
  EXPECT_NEAR(fit::binomialUpperTail(3, 2, 0.5), 0.5, 1e-12);
  EXPECT_EQ(fit::binomialUpperTail(100, 1, 0.0), 0.0);
  EXPECT_EQ(fit::binomialUpperTail(5, 6, 0.5), 0.0);
}

TEST(DisplayFit, BadStartFiveCentimetresFiveDegrees) {
  Case c = demoCase(22);
  // Every module truly sits 5 cm from its drawn place and is turned 5° about a random axis.
  GroundTruthOptions gt;
  gt.seed = 22;
  c.truth = makeGroundTruth(c.nominal, gt);
  SeededRandom random(99);
  for (OpticalModule& m : c.truth.modules) {
    const Eigen::Vector3d dir =
        Eigen::Vector3d(random.normal(), random.normal(), random.normal()).normalized();
    const Eigen::Vector3d axis =
        Eigen::Vector3d(random.normal(), random.normal(), random.normal()).normalized();
    m.position = c.nominal.modules[static_cast<size_t>(m.id)].position + 0.05 * dir;
    m.orientation = (Eigen::AngleAxisd(5.0 * kDeg, axis) *
                     c.nominal.modules[static_cast<size_t>(m.id)].orientation)
                        .normalized();
  }
  c.truth.validate();
  const Outcome o = run("bad start 5 cm 5°", c);
  EXPECT_TRUE(o.fit.passesQualityChecks());
  EXPECT_LT(o.rays.rmsPx, 0.15);
}

// ---- scale ----

TEST(DisplayFit, OneHundredTwentyEightModules) {
  NominalDisplayOptions options;
  options.preset = "default";
  options.modules = 128;
  options.width = 256;  // small images keep the suite fast; the geometry is the default's
  options.height = 192;
  Case c;
  c.nominal = makeNominalDisplay(options);
  GroundTruthOptions gt;
  gt.seed = 23;
  c.truth = makeGroundTruth(c.nominal, gt);
  c.sim.seed = 123;
  c.sim.rig.spanM = 3.2;
  c.sim.rowStepPx = 8;
  const Outcome o = run("128 modules (256x192)", c);
  EXPECT_TRUE(o.fit.passesQualityChecks());
  int observed = 0;
  for (const ModuleFit& m : o.fit.modules) observed += m.observed;
  EXPECT_EQ(observed, 128);
  EXPECT_LT(o.rays.rmsPx, 0.1);
}

// ---- the degenerate case ----

TEST(DisplayFit, DegenerateSetupIsReportedNotFitted) {
  // Flat screen, one camera station, no stripe-direction data (every module seen over the
  // whole screen): the module's points are coplanar and nothing tells where its rays go
  // beyond the screen, so focal length and distance cannot be separated.
  Case c = demoCase(24, 0.0);
  c.sim.rig.stations = 1;
  c.sim.stripes = false;
  c.sim.lobeVisibility = false;
  c.fit.maxIterations = 50;
  const Outcome o = run("degenerate (flat, 1 station, no stripes)", c);
  EXPECT_FALSE(o.fit.passesQualityChecks());
  int flagged = 0, namesFocalAndDistance = 0;
  for (const Deficiency& d : o.fit.deficiencies) {
    if (d.module < 0) continue;
    ++flagged;
    bool focal = false, distance = false;
    for (const std::string& p : d.parameters) {
      focal |= p == "fx" || p == "fy";
      distance |= p == "position.z" || p == "position.x";
    }
    namesFocalAndDistance += focal && distance;
  }
  EXPECT_EQ(flagged, static_cast<int>(c.nominal.modules.size())) << "every module must be flagged";
  EXPECT_EQ(namesFocalAndDistance, flagged) << "and named by focal length and distance";
}

TEST(DisplayFit, StripesLiftTheDegeneracy) {
  // The same flat screen, with stripe-direction data from five stations: determined.
  Case c = demoCase(24, 0.0);
  const Outcome o = run("flat, 5 stations, stripes", c);
  EXPECT_TRUE(o.fit.deficiencies.empty());
  EXPECT_TRUE(o.fit.passesQualityChecks());
}

TEST(DisplayFit, TooFewStationsAreRefused) {
  // Two stations: each module is seen in two narrow stripes. The blocks are not singular, but
  // the covariance puts module positions centimetres wide: refused, not installed.
  Case c = demoCase(27);
  c.sim.rig.stations = 2;
  const Outcome o = run("2 stations (too few)", c);
  EXPECT_FALSE(o.fit.passesQualityChecks());
  EXPECT_GT(o.fit.gate.failingModules(), 0);
}

TEST(DisplayFit, TooFewStationsAreRefusedAtAnyNoise) {
  // The gate's limits do not grow with the camera's noise: two stations at 2 px noise are
  // refused, each failing module named with its predicted error.
  Case c = demoCase(27);
  c.sim.rig.stations = 2;
  c.sim.noisePx = 2.0;
  const Outcome o = run("2 stations, 2 px noise", c);
  EXPECT_FALSE(o.fit.passesQualityChecks());
  int named = 0;
  for (const ModuleGate& g : o.fit.gate.modules) {
    if (g.passes) continue;
    EXPECT_FALSE(g.reason.empty()) << "module " << g.module;
    named += g.reason.find("predicted worst error") != std::string::npos;
  }
  EXPECT_GT(named, 0);
}

TEST(DisplayFit, StandardDeviationsMatchTheActualErrors) {
  // The reported σ of the module positions must describe the real errors: over all modules,
  // the normalised errors (error / σ) have an RMS near 1 (between 0.4 and 2.5 here, a loose
  // band: 48 samples, and the truth's distortion is not exactly representable by σ alone).
  Case c = demoCase(25);
  const Outcome o = run("covariance check", c);
  double sumSq = 0.0;
  int n = 0;
  for (size_t m = 0; m < c.truth.modules.size(); ++m) {
    for (int axis = 0; axis < 3; ++axis) {
      const double err =
          1e3 * (o.fit.model.modules[m].position[axis] - c.truth.modules[m].position[axis]);
      const double sd = o.fit.modules[m].stdDev[static_cast<size_t>(3 + axis)];
      ASSERT_GT(sd, 0.0);
      sumSq += (err / sd) * (err / sd);
      ++n;
    }
  }
  const double rms = std::sqrt(sumSq / n);
  std::printf("    normalised position error RMS %.2f over %d samples\n", rms, n);
  EXPECT_GT(rms, 0.4);
  EXPECT_LT(rms, 2.5);
}

// The camera's intrinsics are held at the checkerboard's estimate, and the fit's answer errs
// with theirs. Their covariance is carried into the σ (fit_uncertainty.h): the variance it adds
// to each module parameter must be the square of what that parameter really moves when the
// intrinsics are off by one σ (here fx and fy together, as a checkerboard's err: Σ = δ² 11ᵀ).
TEST(DisplayFit, HeldIntrinsicsUncertaintyIsWhatTheirErrorMovesTheFit) {
  const Case c = demoCase(31);
  const SyntheticCalibration data = simulateObservations(c.truth, c.sim);
  const double delta = 1e-3 * data.observations.intrinsics.fx;  // 0.1%: a checkerboard's σ
  CalibrationObservations exact = data.observations;
  CalibrationObservations uncertain = exact;
  uncertain.intrinsicsCovariance.topLeftCorner(2, 2).setConstant(delta * delta);
  CalibrationObservations off = uncertain;
  off.intrinsics.fx += delta;
  off.intrinsics.fy += delta;
  const FitResult withoutIt = fitDisplay(c.nominal, exact, c.fit);
  const FitResult carried = fitDisplay(c.nominal, uncertain, c.fit);
  const FitResult moved = fitDisplay(c.nominal, off, c.fit);
  ASSERT_TRUE(withoutIt.passesQualityChecks() && carried.passesQualityChecks());
  EXPECT_FALSE(withoutIt.intrinsicsCarried);
  EXPECT_TRUE(carried.intrinsicsCarried);
  // Position z (mm) and fx (px) of every module: how far the fit moved against the σ it added.
  double sumSqRatio = 0.0, sumSqAdded = 0.0, sumSqBefore = 0.0;
  int n = 0;
  for (size_t m = 0; m < c.nominal.modules.size(); ++m) {
    const double shift[] = {
        1e3 * (moved.model.modules[m].position.z() - carried.model.modules[m].position.z()),
        moved.model.modules[m].fx - carried.model.modules[m].fx};
    const size_t index[] = {5, 6};
    for (int k = 0; k < 2; ++k) {
      const double before = withoutIt.modules[m].stdDev[index[k]];
      const double after = carried.modules[m].stdDev[index[k]];
      ASSERT_GE(after, before) << "module " << m;
      const double added = std::sqrt(after * after - before * before);
      sumSqRatio += std::pow(std::abs(shift[k]) / added, 2);
      sumSqAdded += added * added;
      sumSqBefore += before * before;
      ++n;
    }
  }
  const double rmsRatio = std::sqrt(sumSqRatio / n);
  std::printf("    moved / carried σ: RMS %.3f over %d parameters; carried σ %.2f× the rest\n",
              rmsRatio, n, std::sqrt(sumSqAdded / sumSqBefore));
  // Measured 1.04 (seed 31); differencing the robustified residuals gave 1.14.
  EXPECT_GT(rmsRatio, 0.85);
  EXPECT_LT(rmsRatio, 1.12);
}

TEST(DisplayFit, AStopRequestEndsTheFitAtOnceAndFailsTheQualityGate) {
  Case c = demoCase(17);
  const SyntheticCalibration data = simulateObservations(c.truth, c.sim);
  int polls = 0;
  c.fit.stopRequested = [&polls] { return ++polls > 3; };
  const FitResult stopped = fitDisplay(c.nominal, data.observations, c.fit);
  EXPECT_TRUE(stopped.stopped);
  EXPECT_FALSE(stopped.passesQualityChecks());
  EXPECT_LE(stopped.iterations, 4);  // the poll that said stop is the last iteration
  EXPECT_EQ(polls, 4);               // nothing ran after it (not the other transfer either)
  c.fit.stopRequested = [] { return false; };
  const FitResult full = fitDisplay(c.nominal, data.observations, c.fit);
  EXPECT_FALSE(full.stopped);
  EXPECT_TRUE(full.passesQualityChecks());
  EXPECT_GT(full.iterations, stopped.iterations);
}

TEST(DisplayFit, RejectsObservationsThatReferToNothing) {
  Case c = demoCase(26);
  SyntheticCalibration data = simulateObservations(c.truth, c.sim);
  data.observations.correspondences[0].module = 99;
  EXPECT_THROW(fitDisplay(c.nominal, data.observations, c.fit), InputError);
  data = simulateObservations(c.truth, c.sim);
  data.observations.stripes[0].cameraPx.x() = std::nan("");
  EXPECT_THROW(fitDisplay(c.nominal, data.observations, c.fit), InputError);
}

}  // namespace
}  // namespace parallax
