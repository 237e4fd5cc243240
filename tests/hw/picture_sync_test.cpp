// The picture sync code (calibration/capture/sync_code.h) in a real capture session: the
// simulated camera behind the link photographs the patterns, and a buffered camera in front of
// it delivers each picture late (the frames a webcam's or GStreamer's queue holds), with or
// without auto exposure. Every late picture is retaken, none recorded as the frame after it;
// with auto exposure each coded picture is brought to the white reference's exposure.

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "calibration/display/display_presets.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "hw/camera/calibration_capture.h"
#include "hw/camera/camera.h"
#include "hw/camera/camera_name.h"
#include "hw/link/socket_transport.h"
#include "hw/simulator/calibration_physics.h"
#include "sim_fixture.h"
#include "small_session.h"

namespace parallax::hw {
namespace {

// Six 128x96 modules, a 320x180 camera.
SmallSession session() {
  CameraRigOptions rig;
  rig.stations = 1;
  rig.intrinsics = CameraIntrinsics::centred(320, 180, 350.0);
  return makeSmallSession(11, rig, 4);
}

// A camera whose pictures come out `lag` captures late, as from a queue of frames; with
// `autoExposure`, each picture's exposure drifts (and the controls do not lock).
class BufferedCamera : public Camera {
 public:
  BufferedCamera(Camera& inner, int lag, bool autoExposure)
      : inner_(inner), lag_(lag), autoExposure_(autoExposure) {}
  std::string name() const override { return "buffered camera"; }
  CameraLockResult lock(const CameraSettings& settings) override {
    CameraLockResult r = inner_.lock(settings);
    if (autoExposure_) r = {false, {"auto exposure off (the backend refuses the property)"}};
    locked_ = r.ok;
    return r;
  }
  void unlock() override { inner_.unlock(); }
  Image capture(std::string* error) override {
    inner_.setStation(station());
    Image now = inner_.capture(error);
    if (now.empty()) return now;
    if (autoExposure_) {
      // Exposure between 55% and 100% of the locked one, changing from picture to picture.
      const double gain = 0.55 + 0.45 * std::abs(std::sin(0.7 * captures_));
      for (uint8_t& p : now.pixels) p = static_cast<uint8_t>(std::lround(p * gain));
    }
    ++captures_;
    queue_.push_back(std::move(now));
    if (static_cast<int>(queue_.size()) <= lag_) return queue_.front();
    Image oldest = std::move(queue_.front());
    queue_.pop_front();
    return oldest;
  }

 private:
  Camera& inner_;
  int lag_;
  bool autoExposure_;
  int captures_ = 0;
  std::deque<Image> queue_;
};

CalibrationCaptures capture(const SmallSession& s, int lag, bool autoExposure,
                            const CalibrationCaptureOptions& options, CaptureSyncStats* stats) {
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  LinkClient link(std::make_unique<SocketTransport>(sim.path()));
  SimulatedCamera inner(link);
  BufferedCamera camera(inner, lag, autoExposure);
  return captureCalibration(link, camera, s.nominal, s.rig.metadata, options, {}, nullptr, stats);
}

double meanAbsDifference(const cv::Mat& a, const cv::Mat& b) { return cv::mean(cv::abs(a - b))[0]; }

TEST(PictureSync, LatePicturesAreRetakenNeverRecordedAsTheNextFrame) {
  const SmallSession s = session();
  CaptureSyncStats onTime;
  const CalibrationCaptures reference = capture(s, 0, false, {}, &onTime);
  EXPECT_EQ(onTime.retaken, 0);
  for (int lag : {1, 3}) {
    CaptureSyncStats stats;
    const CalibrationCaptures late = capture(s, lag, false, {}, &stats);
    EXPECT_GE(stats.retaken, lag * stats.pictures / 2) << "lag " << lag;
    ASSERT_EQ(late.stations.size(), reference.stations.size());
    for (size_t i = 0; i < late.stations.size(); ++i) {
      for (size_t f = 0; f < reference.stations[i].columnFrames.size(); ++f) {
        // The same frame up to the sensor's noise; a picture of another frame differs by far
        // more over the lit screen.
        EXPECT_LT(meanAbsDifference(late.stations[i].columnFrames[f],
                                    reference.stations[i].columnFrames[f]),
                  0.01)
            << "lag " << lag << ", set " << i << ", column frame " << f;
      }
      for (size_t f = 0; f < reference.stations[i].rowFrames.size(); ++f) {
        EXPECT_LT(
            meanAbsDifference(late.stations[i].rowFrames[f], reference.stations[i].rowFrames[f]),
            0.01)
            << "lag " << lag << ", set " << i << ", row frame " << f;
      }
    }
  }
  // The stale pictures are not alike: a picture of the previous frame is no stand-in.
  EXPECT_GT(meanAbsDifference(reference.stations[0].columnFrames[3],
                              reference.stations[0].columnFrames[4]),
            0.02);
}

// A camera that photographs the modules while they change: the link updates them one at a
// time, and this camera exposes after each single module's update, so its pictures show every
// intermediate state (some modules on the new frame, the rest still on the old one) in order
// before the complete one. A real camera does this whenever its exposure straddles the
// modules' updates.
class TornCamera : public Camera {
 public:
  // With `tear` false, every picture shows the screen as it is now (the reference). Each state
  // is photographed `repeat` times (a camera that takes pictures faster than the screen
  // changes: two pictures alike prove nothing about the screen being whole).
  TornCamera(SimulatedHardware& hardware, const SmallSession& s, bool tear, int repeat = 1)
      : hardware_(hardware), physics_(s.truth, s.rig.truth), tear_(tear), repeat_(repeat) {
    hardware_.setOnShown([this] {  // the server's thread, after each module's frame
      std::vector<Image> state;
      for (int m = 0; m < hardware_.moduleCount(); ++m) state.push_back(hardware_.shownFrame(m));
      std::lock_guard<std::mutex> lock(mutex_);
      states_.push_back(std::move(state));
    });
  }
  ~TornCamera() override { hardware_.setOnShown({}); }
  std::string name() const override { return "torn camera"; }
  CameraLockResult lock(const CameraSettings&) override { return {true, {}}; }
  void unlock() override {}
  Image capture(std::string* error) override {
    std::vector<Image> state;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (states_.empty()) {
        *error = "nothing shown yet";
        return {};
      }
      if (!tear_) states_.erase(states_.begin(), states_.end() - 1);
      state = states_.front();
      // The newest stays: what the screen shows.
      if (++taken_ >= repeat_ && states_.size() > 1) {
        states_.pop_front();
        taken_ = 0;
      }
    }
    std::vector<const Image*> frames;
    for (const Image& f : state) frames.push_back(f.empty() ? nullptr : &f);
    return physics_.render(frames, 0, station(), CameraSettings{});
  }

 private:
  SimulatedHardware& hardware_;
  CalibrationPhysics physics_;
  bool tear_;
  int repeat_;
  int taken_ = 0;
  std::mutex mutex_;
  std::deque<std::vector<Image>> states_;
};

// The share of the pixels the decoder uses (lit in the reference's white, dark in its black)
// that differ from the reference's by more than the sensor's noise does after a little blur: a
// module showing another frame lights or darkens a whole stripe. (The sync band is left out:
// the decoder never reads it, and a set taken again carries other codes there.)
double differingShare(const cv::Mat& got, const cv::Mat& want, const std::vector<cv::Mat>& set) {
  const cv::Mat used = set[0] - set[1] > 0.1;
  cv::Mat difference;
  cv::GaussianBlur(got - want, difference, cv::Size(7, 7), 0.0);
  const cv::Mat differs = (cv::abs(difference) > 0.15) & used;
  return static_cast<double>(cv::countNonZero(differs)) / std::max(1, cv::countNonZero(used));
}

CalibrationCaptures captureTorn(const SmallSession& s, bool tear, CaptureSyncStats* stats,
                                int repeat = 1) {
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  TornCamera camera(sim.hardware(), s, tear, repeat);
  LinkClient link(std::make_unique<SocketTransport>(sim.path()));
  return captureCalibration(link, camera, s.nominal, s.rig.metadata, {}, {}, nullptr, stats);
}

void expectSameCaptures(const CalibrationCaptures& torn, const CalibrationCaptures& reference) {
  ASSERT_EQ(torn.stations.size(), reference.stations.size());
  for (size_t i = 0; i < torn.stations.size(); ++i) {
    for (auto [got, want, axis] :
         {std::tuple{&torn.stations[i].columnFrames, &reference.stations[i].columnFrames, "column"},
          std::tuple{&torn.stations[i].rowFrames, &reference.stations[i].rowFrames, "row"}}) {
      ASSERT_EQ(got->size(), want->size());
      for (size_t f = 0; f < want->size(); ++f) {
        EXPECT_LT(differingShare((*got)[f], (*want)[f], *want), 0.001)
            << "set " << i << " (modules "
            << fmt::format("{}", fmt::join(torn.stations[i].group, ",")) << "), " << axis
            << " frame " << f;
      }
    }
  }
}

TEST(PictureSync, PicturesOfModulesStillChangingAreRetakenForEveryModule) {
  const SmallSession s = session();
  CaptureSyncStats onTime, stats;
  const CalibrationCaptures reference = captureTorn(s, false, &onTime);
  EXPECT_EQ(onTime.retaken, 0);
  const CalibrationCaptures torn = captureTorn(s, true, &stats);
  // Most frames change several modules at once, so most were photographed half-changed first.
  EXPECT_GE(stats.retaken, stats.pictures / 2);
  expectSameCaptures(torn, reference);
}

// Every state photographed twice (CI's GStreamer feed under load: the picture file is rewritten
// slower than the pipeline reads it). The white reference taken again at the end of a set then
// shows the same half-changed screen in two pictures in a row; that must not make the whole
// first one look torn (it was refused three times over and the calibration ended).
TEST(PictureSync, TwoAlikePicturesOfAHalfChangedScreenAreNotTakenForTheWhole) {
  const SmallSession s = session();
  CaptureSyncStats onTime, stats;
  const CalibrationCaptures reference = captureTorn(s, false, &onTime);
  const CalibrationCaptures torn = captureTorn(s, true, &stats, 2);
  EXPECT_GE(stats.retaken, stats.pictures / 2);
  expectSameCaptures(torn, reference);
}

// Every state photographed six times: a camera far behind the screen (CI's GStreamer feed at a
// load of 5: the same late picture came for half a second). Two alike pictures of the white
// reference taken again then still show the set's last pattern on some module; the first one
// was taken for torn three times over and the calibration ended. The capture waits until the
// camera's longest delay so far has passed before it believes two alike.
TEST(PictureSync, ACameraFarBehindIsWaitedForBeforeAWhiteReferenceIsCalledTorn) {
  const SmallSession s = session();
  CaptureSyncStats onTime, stats;
  const CalibrationCaptures reference = captureTorn(s, false, &onTime);
  const CalibrationCaptures torn = captureTorn(s, true, &stats, 6);
  EXPECT_GE(stats.retaken, stats.pictures);
  expectSameCaptures(torn, reference);
}

TEST(PictureSync, AutoExposureIsRefusedUnlessAllowedThenMeasuredInEachPicture) {
  const SmallSession s = session();
  try {
    capture(s, 1, true, {}, nullptr);
    ADD_FAILURE() << "a camera that does not lock was used";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("auto exposure off"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
  const CalibrationCaptures reference = capture(s, 0, false, {}, nullptr);
  CalibrationCaptureOptions options;
  options.allowUnlockedCamera = true;
  std::string warned;
  options.onUnlocked = [&](const std::string& what) { warned = what; };
  const CalibrationCaptures drifting = capture(s, 2, true, options, nullptr);
  EXPECT_NE(warned.find("auto exposure"), std::string::npos);
  // Each coded picture at the white reference's exposure: its brightness relative to the
  // locked camera's picture is the white reference's, whatever its own exposure was (within
  // 8%: 8-bit steps of the dimmest pictures; unmeasured, the exposures differ by up to 45%).
  for (size_t i = 0; i < reference.stations.size(); ++i) {
    for (auto [late, locked] :
         {std::pair{&drifting.stations[i].columnFrames, &reference.stations[i].columnFrames},
          std::pair{&drifting.stations[i].rowFrames, &reference.stations[i].rowFrames}}) {
      const double white = cv::mean((*late)[0])[0] / cv::mean((*locked)[0])[0];
      for (size_t f = 2; f < late->size(); ++f) {
        const double ratio = cv::mean((*late)[f])[0] / cv::mean((*locked)[f])[0];
        EXPECT_NEAR(ratio / white, 1.0, 0.08) << "set " << i << ", frame " << f;
      }
    }
  }
}

// A camera in a lit room: light that reaches the screen's dark parts as well as its lit ones
// (the room's lamps, the lens's flare) adds `pedestal` of the full scale, in linear light, to
// every pixel; the exposure is set so that the modules' white still fits.
class RoomLitCamera : public Camera {
 public:
  RoomLitCamera(Camera& inner, double pedestal, double responseGamma)
      : inner_(inner), pedestal_(pedestal), gamma_(responseGamma) {}
  std::string name() const override { return "camera in a lit room"; }
  CameraLockResult lock(const CameraSettings& settings) override { return inner_.lock(settings); }
  void unlock() override { inner_.unlock(); }
  Image capture(std::string* error) override {
    inner_.setStation(station());
    Image picture = inner_.capture(error);
    for (uint8_t& p : picture.pixels) {
      const double light = pedestal_ + (1.0 - pedestal_) * std::pow(p / 255.0, gamma_);
      p = static_cast<uint8_t>(std::lround(255.0 * std::pow(light, 1.0 / gamma_)));
    }
    return picture;
  }

 private:
  Camera& inner_;
  double pedestal_, gamma_;
};

// A quarter of the full scale lifts the dark band over 30% of the white in a module's flanks
// (where its light falls off toward its neighbours'): judged against zero, most columns were
// "not a white reference" and the session gave up. Judged above the picture's dark level, the
// capture is the dark room's, less the light the room added.
TEST(PictureSync, ARoomLitCameraCapturesAsInTheDark) {
  const SmallSession s = session();
  const CalibrationCaptures reference = capture(s, 0, false, {}, nullptr);
  constexpr double kPedestal = 0.25;
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  LinkClient link(std::make_unique<SocketTransport>(sim.path()));
  SimulatedCamera inner(link);
  RoomLitCamera camera(inner, kPedestal, s.rig.metadata.responseGamma);
  CaptureSyncStats stats;
  const CalibrationCaptures lit =
      captureCalibration(link, camera, s.nominal, s.rig.metadata, {}, {}, nullptr, &stats);
  EXPECT_EQ(stats.retaken, 0);
  ASSERT_EQ(lit.stations.size(), reference.stations.size());
  for (size_t i = 0; i < lit.stations.size(); ++i) {
    for (auto [got, want] :
         {std::pair{&lit.stations[i].columnFrames, &reference.stations[i].columnFrames},
          std::pair{&lit.stations[i].rowFrames, &reference.stations[i].rowFrames}}) {
      ASSERT_EQ(got->size(), want->size());
      for (size_t f = 0; f < want->size(); ++f) {
        const cv::Mat dark = ((*got)[f] - kPedestal) / (1.0 - kPedestal);
        EXPECT_LT(meanAbsDifference(dark, (*want)[f]), 0.01) << "set " << i << ", frame " << f;
      }
    }
  }
}

TEST(CameraName, BadNamesAndSourcesAreOneLineEach) {
  const auto refused = [](const std::string& name) -> std::string {
    try {
      const CameraName parsed = parseCameraName(name, "--camera");
      OpenCvCamera camera;  // what openCamera opens for an opencv: name
      std::string error;
      if (parsed.kind == CameraKind::kOpenCv && !camera.open(parsed.argument, &error)) return error;
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  const std::string unknown = refused("usb:3");
  EXPECT_NE(unknown.find("unknown camera \"usb:3\""), std::string::npos) << unknown;
  EXPECT_NE(refused("opencv:").find("needs a source"), std::string::npos);
  const std::string device = refused("opencv:/dev/video97");
  EXPECT_NE(device.find("opencv:/dev/video97: no such device"), std::string::npos) << device;
  const std::string pipeline = refused("opencv:videotestsrc ! no_such_element ! appsink");
  EXPECT_NE(pipeline.find("GStreamer could not start the pipeline"), std::string::npos) << pipeline;
  const std::string syntax = refused("opencv:videotestsrc ! ! appsink");
  EXPECT_NE(syntax.find("GStreamer could not start the pipeline"), std::string::npos) << syntax;
  for (const std::string& line : {unknown, device, pipeline, syntax})
    EXPECT_EQ(line.find('\n'), std::string::npos) << line;
  EXPECT_TRUE(isCameraName("link"));
  EXPECT_TRUE(isCameraName("opencv:0"));
  EXPECT_FALSE(isCameraName("camera.json"));
}

}  // namespace
}  // namespace parallax::hw
