// Observer views: what a viewer on the observer line sees, assembled from module frames through
// the display physics, against the same view traced directly.

#include "tracer/observer_view.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "calibration/display/display_presets.h"
#include "common/input_error.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_fixtures.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

DisplayModel viewDisplay(int modules, double diffusionPerPitch) {
  NominalDisplayOptions options;
  options.preset = "demo";
  options.modules = modules;
  options.width = 128;
  options.height = 96;
  DisplayModel model = makeNominalDisplay(options);
  model.screen.diffusionDeg = diffusionPerPitch * angularPitchDeg(model);
  return model;
}

std::vector<Frame> uniformFrames(const DisplayModel& model, const Rgb& colour) {
  std::vector<Frame> frames;
  for (const OpticalModule& m : model.modules) {
    Frame f(m.width, m.height);
    std::fill(f.pixels.begin(), f.pixels.end(), colour);
    frames.push_back(f);
  }
  return frames;
}

// Brightness over the central part of the screen (away from where the outer modules' light
// thins out) for a viewer at the observer line's centre.
std::pair<float, float> centralRange(const Frame& view) {
  float lo = 1e9f, hi = -1e9f;
  for (int j = view.height / 4; j < 3 * view.height / 4; ++j) {
    for (int i = view.width / 4; i < 3 * view.width / 4; ++i) {
      lo = std::min(lo, view.at(i, j).x());
      hi = std::max(hi, view.at(i, j).x());
    }
  }
  return {lo, hi};
}

TEST(ObserverView, UniformModulesLookUniformWithTheNominalDiffusion) {
  const DisplayModel model = viewDisplay(24, 1.5);
  ObserverViewOptions options;
  options.width = 96;
  options.height = 54;
  const Frame view = synthesizeObserverView(model, uniformFrames(model, Rgb(0.5f, 0.5f, 0.5f)),
                                            model.observer.pointAt(0.0), options);
  const auto [lo, hi] = centralRange(view);
  // The Gaussian lobes, each weighted by its module's share of the exit angles, sum to ~1:
  // within a few percent (the quadrature's ripple at 1.5 pitches per FWHM).
  EXPECT_NEAR(lo, 0.5f, 0.03f);
  EXPECT_NEAR(hi, 0.5f, 0.03f);
  EXPECT_LT(hi - lo, 0.04f);
}

TEST(ObserverView, TooNarrowADiffusionShowsDarkGaps) {
  const DisplayModel model = viewDisplay(24, 0.3);
  ObserverViewOptions options;
  options.width = 96;
  options.height = 54;
  const Frame view = synthesizeObserverView(model, uniformFrames(model, Rgb(0.5f, 0.5f, 0.5f)),
                                            model.observer.pointAt(0.0), options);
  const auto [lo, hi] = centralRange(view);
  EXPECT_LT(lo, 0.1f * hi) << "a viewer between two modules' rays should see almost nothing";
}

TEST(ObserverView, ModuleFramesSeenThroughThePhysicsMatchTheViewTracedDirectly) {
  const DisplayModel model = viewDisplay(48, 1.5);
  const PhysicalScene scene(makeCornellScene(), model.displayableBox);
  RenderOptions render;
  std::vector<Frame> frames;
  for (int i = 0; i < static_cast<int>(model.modules.size()); ++i) {
    frames.push_back(renderFrame(scene, generateRayTextures(model, i), render));
  }
  ObserverViewOptions options;
  options.width = 96;
  options.height = 54;
  for (double x : {-0.5, 0.0, 0.4}) {
    std::vector<float> coverage;
    const Frame assembled =
        synthesizeObserverView(model, frames, model.observer.pointAt(x), options, &coverage);
    // Only where the display's modules reach this viewer at all (its field of view).
    const long covered =
        std::count_if(coverage.begin(), coverage.end(), [](float w) { return w >= 0.5f; });
    EXPECT_GT(covered, static_cast<long>(coverage.size()) / 2) << "viewer at x = " << x;
    const Frame traced = renderFrame(scene, observerViewRays(model, x, options), render);
    const double psnr = psnrDb(assembled, traced, &coverage);
    RecordProperty("psnr_db_x" + std::to_string(static_cast<int>(x * 10)), std::to_string(psnr));
    // Blending neighbouring modules blurs what lies off the screen plane; still the same picture.
    EXPECT_GT(psnr, 20.0) << "viewer at x = " << x;
    // And a viewer elsewhere sees something else: the comparison is not trivially satisfied.
    const Frame elsewhere = renderFrame(scene, observerViewRays(model, x + 0.6, options), render);
    EXPECT_LT(psnrDb(assembled, elsewhere, &coverage), psnr - 1.0) << "viewer at x = " << x;
  }
}

// The traced reference for a viewer off the observer line: every ray starts at the viewer and
// passes through its view pixel's screen point; on the line it is the x-only form exactly.
TEST(ObserverView, TracedReferenceRaysStartAtTheViewerOnOrOffTheLine) {
  const DisplayModel model = viewDisplay(8, 1.5);
  ObserverViewOptions options;
  options.width = 32;
  options.height = 18;
  const RayTextures online = observerViewRays(model, 0.3, options);
  const RayTextures same = observerViewRays(model, model.observer.pointAt(0.3), options);
  ASSERT_EQ(online.rays().size(), same.rays().size());
  for (size_t i = 0; i < online.rays().size(); ++i) {
    EXPECT_EQ(online.frame().origin(online.rays()[i]), same.frame().origin(same.rays()[i]));
    EXPECT_EQ(online.frame().screenPoint(online.rays()[i]),
              same.frame().screenPoint(same.rays()[i]));
  }
  const Eigen::Vector3d viewer(-0.2, model.observer.y + 0.25, model.observer.z - 0.6);
  const RayTextures off = observerViewRays(model, viewer, options);
  for (size_t i = 0; i < off.rays().size(); ++i) {
    EXPECT_TRUE(off.frame().origin(off.rays()[i]).isApprox(viewer.cast<float>()));
    EXPECT_EQ(off.frame().screenPoint(off.rays()[i]), online.frame().screenPoint(online.rays()[i]));
  }
}

}  // namespace
}  // namespace parallax

namespace parallax {
namespace {

TEST(FrameFiles, PngRoundTripKeepsEveryByteAndBadFilesAreNamed) {
  Frame frame(37, 11);
  for (size_t i = 0; i < frame.pixels.size(); ++i) {
    frame.pixels[i] =
        Rgb(static_cast<float>(i % 7) / 6.0f, static_cast<float>(i % 13) / 12.0f, 0.25f);
  }
  const std::string path = ::testing::TempDir() + "frame_round_trip.png";
  writePng(frame, path);
  EXPECT_EQ(readFrame(path).toSrgb8(), frame.toSrgb8());
  try {
    readFrame(::testing::TempDir() + "no_such_frame.png");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_frame.png"), std::string::npos);
  }
}

// A truncated or damaged PNG is refused with one error naming the file and what is wrong, before
// libpng sees it (libpng would print its own lines on stderr beside ours).
TEST(FrameFiles, TruncatedOrDamagedPngsAreRefusedNamingTheByte) {
  Frame frame(64, 32);
  for (size_t i = 0; i < frame.pixels.size(); ++i)
    frame.pixels[i] = Rgb(static_cast<float>(i % 5) / 4.0f, 0.5f, 0.1f);
  const std::string path = ::testing::TempDir() + "frame_damaged.png";
  writePng(frame, path);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto refusal = [&](const std::string& content) -> std::string {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << content;
    try {
      readFrame(path);
    } catch (const InputError& e) {
      return e.what();
    }
    return "accepted";
  };
  for (size_t keep : {bytes.size() / 2, size_t{40}, bytes.size() - 1}) {
    const std::string why = refusal(bytes.substr(0, keep));
    EXPECT_NE(why.find("frame_damaged.png"), std::string::npos) << why;
    EXPECT_NE(why.find("truncated"), std::string::npos) << keep << ": " << why;
  }
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;  // inside the pixel data: its chunk's CRC no longer matches
  EXPECT_NE(refusal(flipped).find("fails its CRC"), std::string::npos);
  EXPECT_EQ(refusal(bytes), "accepted");
}

}  // namespace
}  // namespace parallax
