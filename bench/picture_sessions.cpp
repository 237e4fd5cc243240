#include "bench/picture_sessions.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "calibration/capture/calibration_captures.h"
#include "calibration/capture/checkerboard_calibration.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "calibration/fit/prediction_coverage.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "calibration/simulation/sweep_setups.h"
#include "calibration/simulation/synthetic_observations.h"

namespace parallax {

PictureSession renderPictureSession(const DisplayModel& nominal, std::uint64_t seed,
                                    const PictureSessionOptions& options) {
  PictureSession out;
  GroundTruthOptions gt;
  gt.seed = seed;
  gt.transfer = options.truthTransfer;
  out.truth = makeGroundTruth(nominal, gt);
  CameraRigOptions rig;
  rig.stations = options.stations;
  rig.spanM = options.spanM;
  rig.intrinsics = CameraIntrinsics::centred(640, 360, 700.0, -0.04);
  CameraRenderOptions sensor;
  if (options.sensorNoise) sensor.noiseSigma = *options.sensorNoise;
  if (options.blurSigmaPx) sensor.blurSigmaPx = *options.blurSigmaPx;
  const SimulatedRig camera = makeSimulatedRig(out.truth, rig, seed * 7919 + 1, sensor);
  out.camera = camera.truth;
  SimulatedSessionOptions session;
  session.darkModules = options.darkModules;
  CalibrationCaptures captures = renderSession(out.truth, camera.truth, camera.metadata, session);
  if (!options.trueIntrinsics) {
    CheckerboardShotOptions shots;
    shots.pictures = 12;
    captures.checkerboard = simulateCheckerboardCaptures(camera.truth, CheckerboardBoard{}, shots);
    captures.camera.intrinsicsKnown = false;
    out.checkerboard = calibrateCapturesCamera(&captures);
  }
  if (!options.lensBlurStated) captures.camera.lensBlurSigmaPx.reset();
  out.intrinsicsUsed = captures.camera.intrinsics;
  CaptureDecoderOptions decoder;
  decoder.pixelStep = 6;
  out.obs = decodeCaptures(captures, nominal, decoder);
  return out;
}

namespace {

// The synthetic sweep's camera noise p (σ in px of its 1920 × 1080 camera at f 2100) as the
// simulated sensor's noise (recorded units, full scale 1): 0.0375·p makes the fit measure the
// same correspondence σ on both paths (`--noise-map`, demo seed 1000: synthetic 0.296 module px
// per camera px of noise; pictures 7.9 module px per unit of sensor noise, 0.035 at the
// sensor's default 0.004, i.e. the default is the sweep's 0.1 px). The pictures' 640 × 360
// camera (f 700) sees the same angles with 3× larger pixels: p is p/3 of its own px.
constexpr double kSensorNoisePerSyntheticPx = 0.0375;

// A sweep setup (sweep_setups.h) as a picture session's options.
PictureSessionOptions sessionOptionsOf(const SweepSetup& s) {
  PictureSessionOptions options;
  options.stations = s.stations;
  options.spanM = s.spanM;
  options.sensorNoise = s.noisePx * kSensorNoisePerSyntheticPx;
  options.truthTransfer = s.truth;
  options.darkModules = s.unseen;
  return options;
}

// What the predicted σ says against the truth, over a set of modules.
using Coverage = PredictionCoverage;

std::string coverageText(const Coverage& c) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.1f%% of %d, %.2f / %.2f",
                c.modules ? 100.0 * c.coverage() : 0.0, c.modules, c.ratioPx(), c.ratioMm());
  return buf;
}

struct SetupTally {
  int runs = 0, accepted = 0, violations = 0;  // violations: installed modules beyond limits
  double worstPx = 0, worstMm = 0, boundPx = 0, boundMm = 0;  // accepted runs
  double refusedWorstMm = 0;  // refused runs' true worst (mm): how near a wrong install came
  double sigmaSum = 0;        // the fit's σ, module px
  double seconds = 0;
  Coverage installed, judged;
  std::string firstRefusal;
};

void runOne(const SweepSetup& s, std::uint64_t seed, const PictureSweepOptions& sweep,
            SetupTally* t) {
  const auto start = std::chrono::steady_clock::now();
  const DisplayModel nominal = sweepNominal(s);
  const PictureSession session = renderPictureSession(nominal, seed, sessionOptionsOf(s));
  FitOptions fit;
  fit.threads = sweep.threads;
  fit.gate.allowPartial = sweep.allowPartial;
  const FitResult result = fitDisplay(nominal, session.obs, fit);
  const std::vector<RayErrorStats> rays = compareRays(session.truth, result.model);
  // The σ are judged by the fit's estimates, also of the modules --allow-partial held nominal.
  std::vector<RayErrorStats> estimated = rays;
  if (!result.gate.heldNominal.empty()) {
    DisplayModel model = result.model;
    for (size_t i = 0; i < result.gate.heldNominal.size(); ++i)
      model.modules[static_cast<size_t>(result.gate.heldNominal[i])] = result.gate.heldEstimates[i];
    estimated = compareRays(session.truth, model);
  }
  const bool accepted = result.passesQualityChecks();
  ++t->runs;
  t->accepted += accepted;
  t->sigmaSum += result.correspondenceSigmaPx;
  const std::vector<std::string> why = result.gate.describe();
  if (!accepted && t->firstRefusal.empty())
    t->firstRefusal = why.empty() ? "(refused without a reason)" : why.front();
  double runWorstPx = 0, runWorstMm = 0, runBoundPx = 0, runBoundMm = 0;
  Coverage runCoverage;
  const ModuleGate* worstModule = nullptr;  // the module furthest off on the observer line
  for (const ModuleGate& g : result.gate.modules) {
    const RayErrorStats& e = rays[static_cast<size_t>(g.module)];
    if (e.samples > 0 &&
        (!worstModule ||
         e.maxObserverMm > rays[static_cast<size_t>(worstModule->module)].maxObserverMm))
      worstModule = &g;
    const bool heldNominal =
        std::count(result.gate.heldNominal.begin(), result.gate.heldNominal.end(), g.module) > 0;
    if (accepted && !heldNominal) {
      runWorstPx = std::max(runWorstPx, e.maxPx);
      runWorstMm = std::max(runWorstMm, e.maxObserverMm);
      runBoundPx = std::max(runBoundPx, g.boundPx);
      runBoundMm = std::max(runBoundMm, g.boundObserverMm);
      if (e.maxPx > fit.gate.worstPx || e.maxObserverMm > fit.gate.worstObserverMm) {
        ++t->violations;
        std::printf(
            "BEYOND THE LIMITS: %s seed %llu: installed module %d is %.3f px / %.2f mm off at "
            "its worst (limits %.1f px / %.1f mm; predicted 3σ worst %.3f px / %.2f mm)\n",
            s.name.c_str(), static_cast<unsigned long long>(seed), g.module, e.maxPx,
            e.maxObserverMm, fit.gate.worstPx, fit.gate.worstObserverMm, g.boundPx,
            g.boundObserverMm);
      }
    }
    // As the synthetic sweep: coverage over modules with a bounded prediction in fits that
    // finished with a decided transfer, accepted or not ("judged"), and the installed ones.
    if (!result.gate.reasons.empty() || !g.predicted.bounded || g.predicted.samples == 0 ||
        g.held || e.samples == 0)
      continue;
    const double k = fit.gate.sigmas;
    const Coverage one = Coverage::ofModule(g, estimated[static_cast<size_t>(g.module)], k);
    runCoverage.add(one);
    t->judged.add(one);
    if (accepted && !heldNominal) t->installed.add(one);
  }
  if (!accepted && worstModule)
    t->refusedWorstMm =
        std::max(t->refusedWorstMm, rays[static_cast<size_t>(worstModule->module)].maxObserverMm);
  t->worstPx = std::max(t->worstPx, runWorstPx);
  t->worstMm = std::max(t->worstMm, runWorstMm);
  t->boundPx = std::max(t->boundPx, runBoundPx);
  t->boundMm = std::max(t->boundMm, runBoundMm);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  t->seconds += seconds;
  if (sweep.verbose) {
    std::string furthest;
    if (worstModule) {
      const RayErrorStats& e = rays[static_cast<size_t>(worstModule->module)];
      char buf[160];
      std::snprintf(buf, sizeof buf,
                    "furthest off: module %d, %.3f px / %.2f mm (3σ worst %.3f / %.2f%s), ",
                    worstModule->module, e.maxPx, e.maxObserverMm, worstModule->boundPx,
                    worstModule->boundObserverMm, worstModule->passes ? "" : ", fails");
      furthest = buf;
    }
    std::printf(
        "  %s seed %llu: %s, true worst %.3f px / %.2f mm, 3σ worst %.3f / %.2f, "
        "%sjudged %s, σ %.3f module px, %.0f s%s%s\n",
        s.name.c_str(), static_cast<unsigned long long>(seed), accepted ? "accepted" : "refused",
        runWorstPx, runWorstMm, runBoundPx, runBoundMm, furthest.c_str(),
        coverageText(runCoverage).c_str(), result.correspondenceSigmaPx, seconds,
        why.empty() ? "" : ": ", why.empty() ? "" : why.front().c_str());
  }
  std::fflush(stdout);
}

void printRow(const std::string& name, const SetupTally& t) {
  std::printf(
      "| %s | %d | %d / %d | %.3f / %.2f | %.3f / %.2f | %.2f | %s | %s | %.3f | %.0f | %s |\n",
      name.c_str(), t.runs, t.accepted, t.runs - t.accepted, t.worstPx, t.worstMm, t.boundPx,
      t.boundMm, t.refusedWorstMm, coverageText(t.installed).c_str(),
      coverageText(t.judged).c_str(), t.runs ? t.sigmaSum / t.runs : 0.0,
      t.runs ? t.seconds / t.runs : 0.0, t.firstRefusal.c_str());
  std::fflush(stdout);
}

void printSums(const std::string& name, const Coverage& c) {
  std::printf("| %s | %d | %d | %.9g | %.9g | %.9g | %.9g |\n", name.c_str(), c.modules, c.covered,
              c.trueSumSqPx, c.predictedSumSqPx, c.trueSumSqMm, c.predictedSumSqMm);
}

}  // namespace

bool pictureSetupByName(const std::string& name, DisplayModel* nominal,
                        PictureSessionOptions* options) {
  for (const SweepSetup& s : sweepSetups()) {
    if (s.name != name) continue;
    *nominal = sweepNominal(s);
    // The setup's own options; what the command line chose beyond them stays.
    const PictureSessionOptions chosen = *options;
    *options = sessionOptionsOf(s);
    options->trueIntrinsics = chosen.trueIntrinsics;
    options->lensBlurStated = chosen.lensBlurStated;
    if (chosen.blurSigmaPx) options->blurSigmaPx = chosen.blurSigmaPx;
    return true;
  }
  return false;
}

int pictureSetupSweep(const PictureSweepOptions& options) {
  std::vector<SweepSetup> chosen;
  for (const SweepSetup& s : sweepSetups())
    if (options.setup == "all" || options.setup == s.name) chosen.push_back(s);
  if (chosen.empty()) {
    std::fprintf(stderr, "unknown setup \"%s\"; the setups:\n", options.setup.c_str());
    for (const SweepSetup& s : sweepSetups()) std::fprintf(stderr, "  %s\n", s.name.c_str());
    return -1;
  }
  double load[1] = {-1.0};
  getloadavg(load, 1);
  std::printf(
      "# picture path over the synthetic sweep's setups: seeds %d-%d, checkerboard intrinsics, "
      "640×360 camera (f 700), pixel step 6; camera noise p px → sensor noise %.4f·p;%s load "
      "%.2f\n"
      "| setup | runs | accepted / refused | true worst px / mm (accepted) | predicted 3σ worst "
      "px / mm (accepted) | true worst mm (refused) | installed: within 3σ, true/pred RMS px / mm "
      "| all judged: within "
      "3σ, true/pred RMS px / mm | fit σ module px | s a run | first refusal |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n",
      options.firstSeed, options.firstSeed + options.seeds - 1, kSensorNoisePerSyntheticPx,
      options.allowPartial ? " --allow-partial;" : "", load[0]);
  std::fflush(stdout);
  SetupTally all;
  std::vector<Coverage> judged;  // per setup
  for (const SweepSetup& s : chosen) {
    SetupTally t;
    for (int i = 0; i < options.seeds; ++i)
      runOne(s, static_cast<std::uint64_t>(options.firstSeed + i), options, &t);
    printRow(s.name, t);
    judged.push_back(t.judged);
    all.runs += t.runs;
    all.accepted += t.accepted;
    all.violations += t.violations;
    all.worstPx = std::max(all.worstPx, t.worstPx);
    all.worstMm = std::max(all.worstMm, t.worstMm);
    all.boundPx = std::max(all.boundPx, t.boundPx);
    all.boundMm = std::max(all.boundMm, t.boundMm);
    all.refusedWorstMm = std::max(all.refusedWorstMm, t.refusedWorstMm);
    all.sigmaSum += t.sigmaSum;
    all.seconds += t.seconds;
    all.installed.add(t.installed);
    all.judged.add(t.judged);
    if (all.firstRefusal.empty()) all.firstRefusal = t.firstRefusal;
  }
  if (chosen.size() > 1) printRow("all", all);
  std::printf(
      "\nall: %d runs, %d accepted, %d refused; installed modules beyond the gate's limits: %d; "
      "installed modules within 3σ: %s\n",
      all.runs, all.accepted, all.runs - all.accepted, all.violations,
      coverageText(all.installed).c_str());
  // The sums behind the ratios, so that seeds and setups run in separate processes pool exactly:
  // over many modules the ratio is sqrt(Σ true² / Σ predicted²), not a mean of the rows' ratios.
  std::printf(
      "\n| judged modules' sums | modules | within 3σ | Σ true² px² | Σ predicted² px² | "
      "Σ true² mm² | Σ predicted² mm² |\n|---|---|---|---|---|---|---|\n");
  for (size_t i = 0; i < chosen.size(); ++i) printSums(chosen[i].name, judged[i]);
  if (chosen.size() > 1) printSums("all", all.judged);
  return all.violations;
}

void pictureNoiseMap(int threads) {
  const SweepSetup base;
  const DisplayModel nominal = sweepNominal(base);
  const std::uint64_t seed = 1000;
  std::printf(
      "# camera noise: the fit's correspondence σ (module px) and stripe σ (mm), %s "
      "seed %llu, 5 stations over 3.2 m\n| path | noise | σ module px | stripe σ mm |\n"
      "|---|---|---|---|\n",
      nominal.name.c_str(), static_cast<unsigned long long>(seed));
  FitOptions fit;
  fit.threads = threads;
  GroundTruthOptions gt;
  gt.seed = seed;
  const DisplayModel truth = makeGroundTruth(nominal, gt);
  for (double p : {0.1, 0.3, 1.0, 2.0}) {
    SyntheticOptions sim;
    sim.seed = seed * 7919 + 1;
    sim.noisePx = p;
    sim.rig.spanM = base.spanM;
    const FitResult r = fitDisplay(nominal, simulateObservations(truth, sim).observations, fit);
    std::printf("| synthetic | %.1f camera px | %.4f | %.3f |\n", p, r.correspondenceSigmaPx,
                r.stripeSigmaMm);
    std::fflush(stdout);
  }
  for (double sensor : {0.004, 0.01, 0.02, 0.04}) {
    PictureSessionOptions options;
    options.spanM = base.spanM;
    options.sensorNoise = sensor;
    const PictureSession session = renderPictureSession(nominal, seed, options);
    const FitResult r = fitDisplay(nominal, session.obs, fit);
    std::printf("| pictures | sensor %.3f | %.4f | %.3f |\n", sensor, r.correspondenceSigmaPx,
                r.stripeSigmaMm);
    std::fflush(stdout);
  }
}

}  // namespace parallax
