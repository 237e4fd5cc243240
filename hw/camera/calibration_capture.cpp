#include "hw/camera/calibration_capture.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <sstream>

#include "calibration/capture/picture_quality.h"
#include "calibration/simulation/simulated_session.h"
#include "common/input_error.h"

namespace parallax::hw {
namespace {

std::shared_ptr<const Image> moduleFrame(const cv::Mat& linear, PixelFormat format) {
  auto image = std::make_shared<Image>();
  image->width = linear.cols;
  image->height = linear.rows;
  image->format = format;
  image->pixels.resize(image->byteSize());
  const int bpp = bytesPerPixel(format);
  for (int y = 0; y < linear.rows; ++y) {
    const float* in = linear.ptr<float>(y);
    uint8_t* out = image->pixels.data() + static_cast<size_t>(y) *
                                              static_cast<size_t>(linear.cols) *
                                              static_cast<size_t>(bpp);
    for (int x = 0; x < linear.cols; ++x) {
      const auto v = static_cast<uint8_t>(std::lround(255.0f * std::clamp(in[x], 0.0f, 1.0f)));
      for (int c = 0; c < bpp; ++c) out[x * bpp + c] = v;
    }
  }
  return image;
}

// Puts the modules back into playback mode and unlocks the camera however the session ends.
class SessionGuard {
 public:
  SessionGuard(PatternScreen* screen, Camera& camera) : screen_(screen), camera_(camera) {}
  ~SessionGuard() {
    if (screen_) screen_->end();
    camera_.unlock();
  }

 private:
  PatternScreen* screen_;
  Camera& camera_;
};

std::string joined(const std::vector<int>& values, const char* separator) {
  std::ostringstream out;
  for (size_t i = 0; i < values.size(); ++i) out << (i ? separator : "") << values[i];
  return out.str();
}

// What a picture folder's manifest must agree with to be of this session.
CaptureSessionKey sessionKey(const DisplayModel& nominal, const CameraMetadata& metadata,
                             const CalibrationCaptureOptions& options,
                             const std::vector<int>& stations) {
  CaptureSessionKey key;
  key.pictureWidth = metadata.intrinsics.width;
  key.pictureHeight = metadata.intrinsics.height;
  key.fields = {
      {"display", fmt::format("{}: {} modules of {}x{}", nominal.name, nominal.modules.size(),
                              nominal.modules.front().width, nominal.modules.front().height)},
      {"patterns", fmt::format("period {} px, {} phase steps", options.patterns.periodPx,
                               options.patterns.phaseSteps)},
      {"modules_at_once", fmt::format("every {}", options.groupStride)},
      {"stations", joined(stations, ",")},
  };
  return key;
}

CalibrationCaptures runSession(PatternScreen* screen, Camera& camera, const DisplayModel& nominal,
                               const CameraMetadata& metadata,
                               const CalibrationCaptureOptions& options,
                               const std::function<void(int done, int total)>& progress,
                               const std::atomic<bool>* cancel, CaptureSyncStats* stats);

}  // namespace

void CalibrationCaptureOptions::validate(const CameraMetadata& camera) const {
  patterns.validate();
  if (groupStride < 1 || groupStride > 1024)
    throw InputError({"", "group_stride", 0}, "must be 1..1024");
  for (int s : stations) {
    if (s < 0 || s >= static_cast<int>(camera.stations.size())) {
      throw InputError({"", "stations", 0},
                       fmt::format("station {} is not in the camera metadata (0..{})", s,
                                   static_cast<int>(camera.stations.size()) - 1));
    }
  }
}

std::string CaptureSyncStats::describe() const {
  return fmt::format(
      "{} pictures in {:.1f} s; {} late or torn pictures retaken, {} pattern sets taken again "
      "(a torn white reference); settle time median {:.0f} ms, max {:.0f} ms",
      pictures, seconds, retaken, tornWhites, settleMedianMs, settleMaxMs);
}

cv::Mat linearPicture(const Image& picture, double responseGamma) {
  const int bpp = bytesPerPixel(picture.format);
  cv::Mat grey(picture.height, picture.width, CV_8U);
  for (int y = 0; y < picture.height; ++y) {
    const uint8_t* in = picture.pixels.data() + static_cast<size_t>(y) *
                                                    static_cast<size_t>(picture.width) *
                                                    static_cast<size_t>(bpp);
    uint8_t* out = grey.ptr<uint8_t>(y);
    for (int x = 0; x < picture.width; ++x) {
      int sum = 0;
      for (int c = 0; c < bpp; ++c) sum += in[x * bpp + c];
      out[x] = static_cast<uint8_t>((sum + bpp / 2) / bpp);
    }
  }
  return linearFromRecorded8(grey, responseGamma);
}

CalibrationCaptures captureCalibration(LinkClient& link, Camera& camera,
                                       const DisplayModel& nominal, const CameraMetadata& metadata,
                                       const CalibrationCaptureOptions& options,
                                       const std::function<void(int done, int total)>& progress,
                                       const std::atomic<bool>* cancel, CaptureSyncStats* stats) {
  LinkPatternScreen screen(link);
  return runSession(&screen, camera, nominal, metadata, options, progress, cancel, stats);
}

CalibrationCaptures captureCalibration(PatternScreen& screen, Camera& camera,
                                       const DisplayModel& nominal, const CameraMetadata& metadata,
                                       const CalibrationCaptureOptions& options,
                                       const std::function<void(int done, int total)>& progress,
                                       const std::atomic<bool>* cancel, CaptureSyncStats* stats) {
  return runSession(&screen, camera, nominal, metadata, options, progress, cancel, stats);
}

CalibrationCaptures captureCalibrationOffline(
    Camera& camera, const DisplayModel& nominal, const CameraMetadata& metadata,
    const CalibrationCaptureOptions& options,
    const std::function<void(int done, int total)>& progress, const std::atomic<bool>* cancel,
    CaptureSyncStats* stats) {
  if (!camera.picturesAreFiles()) {
    throw std::runtime_error(
        fmt::format("{}: takes its pictures while the modules show the patterns: it needs the link",
                    camera.name()));
  }
  return runSession(nullptr, camera, nominal, metadata, options, progress, cancel, stats);
}

namespace {

CalibrationCaptures runSession(PatternScreen* screen, Camera& camera, const DisplayModel& nominal,
                               const CameraMetadata& metadata,
                               const CalibrationCaptureOptions& options,
                               const std::function<void(int done, int total)>& progress,
                               const std::atomic<bool>* cancel, CaptureSyncStats* stats) {
  options.validate(metadata);
  const int modules = static_cast<int>(nominal.modules.size());
  const int mw = nominal.modules.front().width, mh = nominal.modules.front().height;
  const std::vector<ModuleLinkInfo> screenModules =
      screen ? screen->modules() : std::vector<ModuleLinkInfo>{};
  if (screen && static_cast<int>(screenModules.size()) != modules) {
    throw std::runtime_error(fmt::format("the link has {} modules, the nominal display {}",
                                         screenModules.size(), modules));
  }
  bool grey = true;
  for (const ModuleLinkInfo& m : screenModules) {
    if (static_cast<int>(m.info.width) != mw || static_cast<int>(m.info.height) != mh) {
      throw std::runtime_error(
          fmt::format("module {} shows {}x{}, the nominal display's modules are {}x{}", m.module,
                      m.info.width, m.info.height, mw, mh));
    }
    grey = grey && (m.info.pixelFormats & (1u << static_cast<int>(PixelFormat::kGray8))) != 0;
  }
  const PixelFormat format = grey ? PixelFormat::kGray8 : PixelFormat::kRgb8;

  CalibrationCaptures captures;
  captures.camera = metadata;
  captures.patterns = options.patterns;
  captures.moduleWidth = mw;
  captures.moduleHeight = mh;
  // Every frame carries its sync code, unless the modules are too small for one and the
  // camera is one whose pictures cannot be late.
  std::string noSync;
  const std::optional<SyncCodeLayout> sync = syncLayoutFor(nominal, &noSync);
  if (!sync && !camera.picturesFollowTheLink())
    throw std::runtime_error(fmt::format("{}: {}", camera.name(), noSync));
  const SyncCodeLayout layout = sync.value_or(SyncCodeLayout{});
  const std::vector<cv::Mat> columnPatterns =
      makePatternFrames(mw, mh, PatternAxis::kColumns, options.patterns);
  const std::vector<cv::Mat> rowPatterns =
      makePatternFrames(mw, mh, PatternAxis::kRows, options.patterns);
  const auto dark = moduleFrame(cv::Mat(mh, mw, CV_32F, cv::Scalar(0)), format);

  std::vector<int> stations = options.stations;
  if (stations.empty()) {
    for (int s = 0; s < static_cast<int>(metadata.stations.size()); ++s) stations.push_back(s);
  }
  CalibrationCaptureOptions planned = options;
  planned.groupStride = groupStrideFor(nominal, metadata.stations, options.groupStride);
  const auto groups = moduleGroups(modules, planned.groupStride);
  const int total = static_cast<int>(stations.size() * groups.size() *
                                     (columnPatterns.size() + rowPatterns.size()));
  int done = 0;

  camera.beginSession(sessionKey(nominal, metadata, planned, stations));
  const CameraLockResult lock = camera.lock(options.cameraSettings);
  if (!lock.ok && !options.allowUnlockedCamera) {
    throw std::runtime_error(fmt::format(
        "{}: {}; refused, since a control that drifts between two patterns shifts their "
        "decoding (lock it on the camera, or allow auto exposure to measure each picture)",
        camera.name(), lock.describe()));
  }
  if (!lock.ok && options.onUnlocked) options.onUnlocked(lock.describe());
  // Pictures taken outside the tool's control (files) are checked for blur and over-exposure;
  // their exposure is measured in each when the operator says it was automatic (allowed). Not
  // otherwise: each estimate carries the sensor's noise, and four phase steps scaled apart
  // decode to a shifted phase (on the small simulated display, twice the ray error).
  const bool files = camera.picturesAreFiles();
  const bool measureExposure = !lock.ok || (files && options.allowUnlockedCamera);
  const PictureQualityLimits quality;
  BlurCheck blurCheck(quality);
  std::vector<std::pair<std::string, std::string>> judged;  // blurCheck's pictures: what, file
  SessionGuard guard(screen, camera);
  if (screen && !screen->setMode(DisplayMode::kPattern))
    throw std::runtime_error("the modules did not switch to pattern mode");
  if (progress) progress(0, total);

  using Clock = std::chrono::steady_clock;
  const auto sessionStart = Clock::now();
  std::vector<double> settleMs;
  int retaken = 0, tornWhites = 0;
  int sequence = 0;  // frames shown so far: the sync code is its residue
  const auto show = [&](const std::vector<int>& group, const std::shared_ptr<const Image>& frame,
                        const std::string& what) {
    if (screen) {
      std::vector<std::shared_ptr<const Image>> frames(static_cast<size_t>(modules), dark);
      for (int m : group) frames[static_cast<size_t>(m)] = frame;
      screen->show(frames, what);
    }
    camera.showing(what);
    ++sequence;
  };
  // A picture the checks refuse: taken again, or, when it is a file (asking again gives the
  // same), the end of the session, naming the file.
  const auto refuse = [&](const std::string& what, const std::string& why, std::string* seen) {
    *seen = why;
    if (files) {
      throw std::runtime_error(
          fmt::format("{}: picture {} refused: {}", what, camera.lastPicture(), why));
    }
  };

  // Takes the picture of what `show` put up last: retaken until the sync code says it is that
  // frame (a white reference: one with the band dark over a lit screen, its geometry stored in
  // `*whiteGeometry`, and not a late picture of `earlierWhite`).
  enum class Kind { kWhite, kBlack, kCoded };
  const auto take = [&](const std::string& what, Kind kind, int code,
                        const SyncPrediction& prediction, const SyncGeometry& geometry,
                        SyncGeometry* whiteGeometry, const cv::Mat* earlierWhite) {
    const auto shown = Clock::now();
    std::string seen;
    for (int attempt = 0;; ++attempt) {
      if (attempt > 0) {
        ++retaken;
        if (std::chrono::duration<double>(Clock::now() - shown).count() > options.settleTimeoutS) {
          throw std::runtime_error(
              fmt::format("{}: after {:g} s the camera still gives pictures it cannot use ({}); "
                          "is it aimed at the screen, with the top edge in view?",
                          what, options.settleTimeoutS, seen));
        }
        if (cancel && cancel->load()) throw CalibrationCancelled();
      }
      std::string error;
      const Image picture = camera.capture(&error);
      if (picture.empty()) {
        if (cancel && cancel->load()) throw CalibrationCancelled();
        throw std::runtime_error(fmt::format("{}: {}", what, error));
      }
      if (picture.width != metadata.intrinsics.width ||
          picture.height != metadata.intrinsics.height) {
        throw std::runtime_error(fmt::format(
            "{}: the camera gave a {}x{} picture, its metadata says {}x{}", what, picture.width,
            picture.height, metadata.intrinsics.width, metadata.intrinsics.height));
      }
      cv::Mat linear = linearPicture(picture, metadata.responseGamma);
      if (files) {
        if (const std::optional<std::string> why = overExposure(linear, quality)) {
          refuse(what, *why, &seen);
          continue;
        }
      }
      if (!sync) {
        // Too small for a code, and a camera whose pictures are never late: as taken.
      } else if (kind == Kind::kWhite) {
        std::string why;
        const std::optional<SyncGeometry> g =
            syncGeometryFromWhite(linear, layout, prediction, &why);
        if (!g) {
          refuse(what, "not the white reference: " + why, &seen);
          continue;
        }
        if (earlierWhite && !whitesDiffer(*earlierWhite, linear)) {
          refuse(what, "the white reference of the modules before", &seen);
          continue;
        }
        *whiteGeometry = *g;
      } else if (kind == Kind::kBlack) {
        if (!looksBlack(linear, geometry, layout, prediction)) {
          refuse(what, "not the black reference: the band or the patterns are lit", &seen);
          continue;
        }
      } else {
        const SyncReading reading = readSyncCode(linear, geometry, layout);
        // A blurred picture is named as such, whether or not its code still reads.
        if (files) {
          if (const std::optional<std::string> why = blurCheck.judge(reading.contrast)) {
            refuse(what, *why, &seen);
            continue;
          }
        }
        if (reading.code != code) {
          refuse(what,
                 fmt::format("a picture of another frame: {}, expected code {}", reading.describe(),
                             code),
                 &seen);
          continue;
        }
        if (measureExposure && reading.exposure > 0.0) linear /= reading.exposure;
        if (files) {
          blurCheck.add(reading.contrast);
          judged.emplace_back(what, camera.lastPicture());
        }
      }
      settleMs.push_back(std::chrono::duration<double, std::milli>(Clock::now() - shown).count());
      return linear;
    }
  };

  // One axis' patterns for one group at one station into `out`. With the sync code, the white
  // reference is taken again at the end, until a picture agrees with the first (the first was
  // whole) or two agree with each other and not with it (the first was torn: a module still
  // on the frame before, which no later picture was checked against): false, to take the
  // axis again.
  const auto takeAxis = [&](const std::vector<int>& group, const std::vector<cv::Mat>& patterns,
                            const std::string& axis, int station, const SyncPrediction& prediction,
                            const cv::Mat* earlierWhite, std::vector<cv::Mat>* out,
                            std::string* torn) {
    out->clear();
    SyncGeometry geometry;
    std::string firstWhite;  // its file, for a picture folder's messages
    for (size_t f = 0; f < patterns.size(); ++f) {
      if (cancel && cancel->load()) throw CalibrationCancelled();
      const std::string what = fmt::format("station {}, modules {}, {} pattern {}", station,
                                           joined(group, ","), axis, f);
      // makePatternFrames' order: white, black, then the coded frames.
      const Kind kind = f == 0 ? Kind::kWhite : f == 1 ? Kind::kBlack : Kind::kCoded;
      const int code = sequence % SyncCodeLayout::kCodes;
      cv::Mat pattern = patterns[f].clone();
      if (sync) {
        drawSyncCode(&pattern, kind == Kind::kCoded ? std::optional<int>(code) : std::nullopt,
                     layout);
      }
      show(group, moduleFrame(pattern, format), what);
      out->push_back(take(what, kind, code, prediction, geometry, &geometry, earlierWhite));
      if (f == 0) firstWhite = camera.lastPicture();
      // A set's last picture counts once its white reference agrees again (below): a set taken
      // again after the bar's end would start a second one.
      if (progress && out->size() < patterns.size())
        progress(done + static_cast<int>(out->size()), total);
    }
    if (!sync) return true;
    const std::string what = fmt::format("station {}, modules {}, {} white reference again",
                                         station, joined(group, ","), axis);
    cv::Mat white = patterns[0].clone();
    drawSyncCode(&white, std::nullopt, layout);
    show(group, moduleFrame(white, format), what);
    // How late this camera's pictures have come so far: the longest any took to settle. Until
    // that long after the white was shown, a picture may still show the set's last pattern on
    // some module, and a slow camera (a loaded machine rendering its feed) gives the same late
    // picture several times over: two alike prove nothing before then.
    const auto shownAgain = Clock::now();
    const double lateMs =
        settleMs.empty() ? 0.0 : *std::max_element(settleMs.begin(), settleMs.end());
    const double trustAfterMs = 1.5 * lateMs;  // half as long again
    const double giveUpMs = 1000.0 * options.settleTimeoutS + trustAfterMs;
    cv::Mat previous;
    for (int attempt = 0;; ++attempt) {
      SyncGeometry againGeometry;
      const cv::Mat again =
          take(what, Kind::kWhite, 0, prediction, geometry, &againGeometry, nullptr);
      const std::optional<std::string> differs = whitesDiffer(out->front(), again);
      if (!differs) break;
      if (files) {
        throw std::runtime_error(fmt::format(
            "{}: picture {} refused: it is not of the same screen as the first white reference "
            "{} ({}): the camera moved, or a module changed while one of them was taken",
            what, camera.lastPicture(), firstWhite, *differs));
      }
      if (attempt > 0) ++retaken;
      const double sinceShownMs =
          std::chrono::duration<double, std::milli>(Clock::now() - shownAgain).count();
      if (sinceShownMs > giveUpMs) {
        throw std::runtime_error(fmt::format(
            "{}: after {:.1f} s the camera's pictures of the white reference still differ from "
            "the first ({})",
            what, 0.001 * sinceShownMs, *differs));
      }
      const WhiteStripes stripes = compareWhiteStripes(geometry, againGeometry);
      // This picture misses stripes the first shows: some module was still changing when it
      // was taken (two such pictures in a row prove nothing): taken again.
      if (stripes.secondMissesStripes) continue;
      // The first misses stripes this one shows: a module of the group was still dark or on its
      // frame before when the first was taken (no module outside the group is lit during the
      // set, so a later picture cannot add a stripe of its own): the set is taken again.
      if (stripes.firstMissesStripes) {
        *torn = *differs;
        return false;
      }
      // Otherwise the first was torn (a module of the group still dark, or one of the group
      // before still lit: the set's other pictures may show it too), or the camera moved: two
      // pictures alike and unlike the first, the later one taken once the camera's longest
      // delay has passed, and the set is taken again.
      if (!previous.empty() && !whitesDiffer(previous, again) && sinceShownMs >= trustAfterMs) {
        *torn = *differs;
        return false;
      }
      previous = again;
    }
    // The modules leave on their white with the band lit, taken like a coded frame: the
    // pictures of the next white reference that still show one of these modules show it lit,
    // never as a stripe of the group after.
    const int code = sequence % SyncCodeLayout::kCodes;
    drawSyncCode(&white, code, layout);
    const std::string closing =
        fmt::format("station {}, modules {}, {} patterns done", station, joined(group, ","), axis);
    show(group, moduleFrame(white, format), closing);
    take(closing, Kind::kCoded, code, prediction, geometry, nullptr, nullptr);
    return true;
  };

  cv::Mat lastWhite;
  for (int station : stations) {
    if (options.beforeStation) options.beforeStation(station);
    camera.setStation(station);
    const SyncPrediction prediction =
        predictSync(nominal, metadata.intrinsics,
                    metadata.stations[static_cast<size_t>(station)].tapeCentre, layout);
    for (const std::vector<int>& group : groups) {
      StationCaptures set;
      set.station = station;
      set.group = group;
      for (auto [patterns, out, axis] : {std::tuple{&columnPatterns, &set.columnFrames, "column"},
                                         std::tuple{&rowPatterns, &set.rowFrames, "row"}}) {
        // A new group's first white reference must not be a late picture of the last one.
        const cv::Mat* earlierWhite =
            patterns == &columnPatterns && !lastWhite.empty() ? &lastWhite : nullptr;
        std::string torn;
        for (int pass = 0;
             !takeAxis(group, *patterns, axis, station, prediction, earlierWhite, out, &torn);
             ++pass) {
          ++tornWhites;
          if (pass == 2) {
            throw std::runtime_error(fmt::format(
                "station {}, {} patterns: the white reference was torn three times ({}): a "
                "module keeps changing while the camera takes it",
                station, axis, torn));
          }
        }
        done += static_cast<int>(patterns->size());
        if (progress) progress(done, total);
        if (sync) lastWhite = out->front();
      }

      captures.stations.push_back(std::move(set));
    }
  }
  // The first pictures had too few before them to be judged: now against the whole session.
  if (const auto blurred = blurCheck.firstBlurred()) {
    const auto& [what, file] = judged[blurred->first];
    throw std::runtime_error(
        fmt::format("{}: picture {} refused: {}", what, file, blurred->second));
  }
  if (stats) {
    stats->pictures = static_cast<int>(settleMs.size());
    stats->retaken = retaken;
    stats->tornWhites = tornWhites;
    if (!settleMs.empty()) {
      std::vector<double> sorted = settleMs;
      std::sort(sorted.begin(), sorted.end());
      stats->settleMedianMs = sorted[sorted.size() / 2];
      stats->settleMaxMs = sorted.back();
    }
    stats->seconds = std::chrono::duration<double>(Clock::now() - sessionStart).count();
  }
  return captures;
}

}  // namespace

}  // namespace parallax::hw
