#include "calibration/capture/calibration_captures.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/camera/observations_json.h"
#include "calibration/capture/camera_picture.h"
#include "calibration/capture/camera_response.h"
#include "calibration/capture/fiducial_detector.h"
#include "calibration/capture/stripe_peak.h"
#include "calibration/display/conventions.h"
#include "calibration/display/json_fields.h"
#include "calibration/display/json_file.h"
#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax {
namespace {

using jsonfield::array;
using jsonfield::fail;
using jsonfield::integer;
using jsonfield::member;
using jsonfield::number;
using nlohmann::json;

constexpr const char* kPatternsFormatName = "parallax-patterns";
constexpr int kPatternsFormatVersion = 1;
constexpr size_t kMaxCaptureSets = 4096;

int framesPerAxis(int extent, const StructuredLightOptions& patterns) {
  return 2 + grayBitCount(extent, patterns.periodPx) + patterns.phaseSteps;
}

std::string frameName(size_t set, char axis, size_t frame) {
  return fmt::format("set{:03d}_{}{:02d}.png", set, axis, frame);
}

cv::Mat loadPicture(const std::string& path, const CameraMetadata& camera) {
  return linearFromRecorded8(
      readCameraPicture(path, camera.intrinsics.width, camera.intrinsics.height),
      camera.responseGamma);
}

}  // namespace

void CalibrationCaptures::validate(const DisplayModel& nominal) const {
  patterns.validate();
  const int modules = static_cast<int>(nominal.modules.size());
  if (moduleWidth != nominal.modules.front().width ||
      moduleHeight != nominal.modules.front().height) {
    fail("module_width",
         fmt::format("the patterns are {}x{}, the nominal display's modules {}x{}", moduleWidth,
                     moduleHeight, nominal.modules.front().width, nominal.modules.front().height));
  }
  const size_t columns = static_cast<size_t>(framesPerAxis(moduleWidth, patterns));
  const size_t rows = static_cast<size_t>(framesPerAxis(moduleHeight, patterns));
  for (size_t i = 0; i < stations.size(); ++i) {
    const StationCaptures& s = stations[i];
    const std::string field = fmt::format("stations[{}]", i);
    if (s.station < 0 || s.station >= static_cast<int>(camera.stations.size())) {
      fail(field + ".station",
           fmt::format("must be 0..{}", static_cast<int>(camera.stations.size()) - 1));
    }
    if (s.group.empty()) fail(field + ".group", "must name at least one module");
    for (int m : s.group) {
      if (m < 0 || m >= modules)
        fail(field + ".group", fmt::format("module {} is not 0..{}", m, modules - 1));
    }
    if (s.columnFrames.size() != columns || s.rowFrames.size() != rows) {
      fail(field, fmt::format("needs {} column and {} row pictures, has {} and {}", columns, rows,
                              s.columnFrames.size(), s.rowFrames.size()));
    }
    for (const auto* frames : {&s.columnFrames, &s.rowFrames}) {
      for (const cv::Mat& f : *frames) {
        if (f.type() != CV_32F || f.cols != camera.intrinsics.width ||
            f.rows != camera.intrinsics.height) {
          fail(field, fmt::format("every picture must be linear (CV_32F) and {}x{}",
                                  camera.intrinsics.width, camera.intrinsics.height));
        }
      }
    }
  }
}

std::vector<std::vector<int>> moduleGroups(int modules, int stride) {
  std::vector<std::vector<int>> groups;
  stride = std::max(1, std::min(stride, modules));
  for (int g = 0; g < stride; ++g) {
    std::vector<int> group;
    for (int m = g; m < modules; m += stride) group.push_back(m);
    groups.push_back(group);
  }
  return groups;
}

int groupStrideFor(const DisplayModel& nominal, const std::vector<CameraStation>& stations,
                   int least) {
  const size_t modules = nominal.modules.size();
  const Screen& screen = nominal.screen;
  const double sigma = diffusionSigma(screen.diffusionDeg);
  // Every module's angle (in lobe σ) along the screen's middle row, from every station.
  constexpr int kSamples = 256;
  const auto angleAt = [&](double x, size_t c, size_t m) {
    return stripeAngle(screen, screen.pointAt(x, 0.0), nominal.modules[m].position,
                       stations[c].tapeCentre) /
           sigma;
  };
  std::vector<std::vector<std::vector<double>>> angles(
      stations.size(), std::vector<std::vector<double>>(modules, std::vector<double>(kSamples)));
  // Whether module m's stripe is on the screen from station c (its angle nears zero on the
  // row), and whether its lobe is cut: off the screen, or cut by the screen's edge above half
  // its peak, so that it cannot be fitted and nothing will subtract it from a partner's stripe
  // (stripe_peak.h).
  std::vector<std::vector<bool>> onScreen(stations.size(), std::vector<bool>(modules));
  std::vector<std::vector<bool>> cut(stations.size(), std::vector<bool>(modules));
  constexpr double kCutSigmas = 1.5;
  for (size_t c = 0; c < stations.size(); ++c) {
    for (size_t m = 0; m < modules; ++m) {
      double smallest = std::numeric_limits<double>::infinity();
      for (int i = 0; i < kSamples; ++i) {
        angles[c][m][static_cast<size_t>(i)] =
            angleAt(screen.width * ((i + 0.5) / kSamples - 0.5), c, m);
        smallest = std::min(smallest, std::abs(angles[c][m][static_cast<size_t>(i)]));
      }
      onScreen[c][m] = smallest < 0.5;
      cut[c][m] = !onScreen[c][m] || std::abs(angleAt(-0.5 * screen.width, c, m)) < kCutSigmas ||
                  std::abs(angleAt(0.5 * screen.width, c, m)) < kCutSigmas;
    }
  }
  // A cut partner o's light relative to m's own, at the worst point of m's lobe fit (where m is
  // at least stripe_peak.h's fitFraction of its peak).
  const double fitSigmas = std::sqrt(-2.0 * std::log(StripePeakOptions{}.fitFraction));
  const auto worstShare = [&](size_t c, size_t m, size_t o) {
    double worst = 0.0;
    for (size_t i = 0; i < kSamples; ++i) {
      const double am = angles[c][m][i], ao = angles[c][o][i];
      if (std::abs(am) <= fitSigmas) worst = std::max(worst, std::exp(-0.5 * (ao * ao - am * am)));
    }
    return worst;
  };
  const auto count = static_cast<int>(modules);
  for (int stride = std::max(1, least); stride < count; ++stride) {
    bool apart = true;
    for (size_t c = 0; c < stations.size() && apart; ++c) {
      for (size_t m = 0; m < modules && apart; ++m) {
        if (!onScreen[c][m]) continue;
        for (size_t o = m % static_cast<size_t>(stride); o < modules && apart;
             o += static_cast<size_t>(stride)) {
          // A partner whose whole lobe is on the screen is fitted and subtracted.
          if (o != m && cut[c][o]) apart = worstShare(c, m, o) <= kGroupLightShare;
        }
      }
    }
    if (apart) return stride;
  }
  return std::max(1, count);
}

CalibrationObservations observationsFrame(const CameraMetadata& camera) {
  CalibrationObservations obs;
  obs.intrinsics = camera.intrinsics;
  obs.intrinsicsCovariance = camera.intrinsicsCovariance;
  obs.stations = camera.stations;
  obs.fiducials = camera.fiducials;
  return obs;
}

CheckerboardCalibration calibrateCapturesCamera(CalibrationCaptures* captures,
                                                const CheckerboardCalibrationOptions& options) {
  if (!captures->checkerboard) fail("checkerboard", "the captures hold no checkerboard pictures");
  const int width = captures->camera.intrinsics.width, height = captures->camera.intrinsics.height;
  CheckerboardCalibration result = calibrateFromCheckerboard(
      captures->checkerboard->pictures, captures->checkerboard->board, width, height, options);
  captures->camera.intrinsics = result.intrinsics;
  captures->camera.intrinsicsCovariance = result.covariance;
  captures->camera.intrinsicsKnown = true;
  return result;
}

void requireKnownIntrinsics(const CameraMetadata& camera, const std::string& file,
                            const std::string& purpose) {
  if (camera.intrinsicsKnown) return;
  throw InputError(
      {file, "intrinsics.focal_px", 0},
      fmt::format(
          "missing: {} needs the camera's intrinsics (camera.json gives only the picture size; "
          "calibrate the camera from its checkerboard pictures first)",
          purpose));
}

namespace {

double medianOf(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// A coded picture linearized above the set's black reference: where the modules' own response
// bends the patterns, it shapes only the light above their black (their black level and the
// room's light add after it). Clipped pixels stay as recorded, so the decoder still sees them
// clipped; pixels no brighter in the white than in the black are left alone.
cv::Mat linearizedAboveBlack(const cv::Mat& picture, const cv::Mat& white, const cv::Mat& black,
                             double exponent, double clipped) {
  cv::Mat out = picture.clone();
  for (int y = 0; y < out.rows; ++y) {
    const float* w = white.ptr<float>(y);
    const float* b = black.ptr<float>(y);
    float* v = out.ptr<float>(y);
    for (int x = 0; x < out.cols; ++x) {
      const double range = static_cast<double>(w[x]) - b[x];
      if (!(range > 0.0) || v[x] >= clipped) continue;
      const double above = std::max(0.0, (static_cast<double>(v[x]) - b[x]) / range);
      v[x] = static_cast<float>(b[x] + range * std::pow(above, exponent));
    }
  }
  return out;
}

// A set's white and black references as the camera recorded them, for the lobes when the
// modules (not the camera) bend the patterns.
StripeReferences recordedReferences(const StationCaptures& s, double assumedGamma) {
  return StripeReferences{s.columnFrames[0], s.columnFrames[1], clippedLinear(assumedGamma)};
}

// The phase pictures measured a response the camera.json did not state: the camera's, or the
// modules' own (a projector driven without linearization), which the phase alone cannot tell
// apart. The lobes can: they are the screen's diffusion, lit by a white module (whatever its
// response), so only the camera's response changes their width. The first picture set's lobes
// are fitted both ways; the width nearer the nominal's diffusion says which.
template <typename Linear>
void decideWhichEndBends(const CalibrationCaptures& captures, const DisplayModel& nominal,
                         const CaptureDecoderOptions& decoder, const Linear& linear,
                         CameraResponseCheck* response) {
  const StationCaptures& s = captures.stations.front();
  CaptureDecoderOptions probe = decoder;
  probe.pixelStep = std::max(decoder.pixelStep, 4);  // a lobe width needs few rows
  probe.onPictureSet = nullptr;
  const StripeReferences recorded = recordedReferences(s, response->assumedGamma);
  const auto medianWidth = [&](const StripeReferences* references) {
    CalibrationObservations scratch = observationsFrame(captures.camera);
    std::vector<double> widths;
    decodeStation(linear(s.columnFrames), linear(s.rowFrames), s.group, nominal, s.station, probe,
                  &scratch, nullptr, references, &widths);
    return medianOf(std::move(widths)) / diffusionSigma(nominal.screen.diffusionDeg);
  };
  response->lobeWidthRecorded = medianWidth(&recorded);
  response->lobeWidthRelinearized = medianWidth(nullptr);
  response->modulesBend = std::isfinite(response->lobeWidthRecorded) &&
                          std::isfinite(response->lobeWidthRelinearized) &&
                          std::abs(std::log(response->lobeWidthRecorded)) <
                              std::abs(std::log(response->lobeWidthRelinearized));
}

}  // namespace

CalibrationObservations decodeCaptures(const CalibrationCaptures& captures,
                                       const DisplayModel& nominal,
                                       const CaptureDecoderOptions& options) {
  requireKnownIntrinsics(captures.camera, "", "decoding the pictures");
  captures.validate(nominal);
  CaptureDecoderOptions decoder = options;
  decoder.patterns = captures.patterns;
  if (captures.camera.lensBlurSigmaPx) decoder.lensBlurSigmaPx = *captures.camera.lensBlurSigmaPx;
  // The response measured (camera_response.h): when camera.json gives none, each set's pictures
  // are re-linearized with the measured one before anything is decoded from them.
  CameraResponseCheck response = checkCameraResponse(captures);
  const double exponent = response.usedGamma() / response.assumedGamma;
  const auto linear = [&](const std::vector<cv::Mat>& frames) {
    if (!response.corrected) return frames;  // headers only: the pixels are shared
    std::vector<cv::Mat> out(frames.size());
    for (size_t f = 0; f < frames.size(); ++f) cv::pow(frames[f], exponent, out[f]);
    return out;
  };
  decoder.saturatedLinear = clippedLinear(response.usedGamma());
  if (response.corrected) decideWhichEndBends(captures, nominal, decoder, linear, &response);
  // The modules bend: the patterns linearized above each set's black, the camera's clipping
  // as recorded.
  const bool aboveBlack = response.modulesGamma() > 0.0;
  if (aboveBlack) decoder.saturatedLinear = clippedLinear(response.assumedGamma);
  const auto decoded = [&](const std::vector<cv::Mat>& frames) {
    if (!aboveBlack) return linear(frames);
    std::vector<cv::Mat> out = frames;  // the references as recorded
    for (size_t f = 2; f < frames.size(); ++f) {
      out[f] = linearizedAboveBlack(frames[f], frames[0], frames[1], response.aboveBlackExponent,
                                    decoder.saturatedLinear);
    }
    return out;
  };
  CalibrationObservations obs = observationsFrame(captures.camera);
  obs.cameraResponse = response;
  obs.lensBlurSigmaPx = captures.camera.lensBlurSigmaPx;
  // Fiducials first (from each station's first black reference picture): the pose they give
  // is what the decoder predicts the stripes from.
  std::vector<std::optional<CameraPose>> poses(captures.camera.stations.size());
  std::vector<bool> fiducialsDone(captures.camera.stations.size(), false);
  for (const StationCaptures& s : captures.stations) {
    if (fiducialsDone[static_cast<size_t>(s.station)]) continue;
    fiducialsDone[static_cast<size_t>(s.station)] = true;
    detectFiducials(response.modulesBend ? s.columnFrames[1] : linear({s.columnFrames[1]})[0],
                    nominal.screen, s.station, FiducialDetectorOptions{}, &obs);
    poses[static_cast<size_t>(s.station)] = poseFromFiducials(obs, nominal.screen, s.station);
  }
  const int sets = static_cast<int>(captures.stations.size());
  for (int i = 0; i < sets; ++i) {
    const StationCaptures& s = captures.stations[static_cast<size_t>(i)];
    const auto& pose = poses[static_cast<size_t>(s.station)];
    // The lobes and fiducials in the camera's light: as recorded when the modules bend it.
    const StripeReferences recorded = recordedReferences(s, response.assumedGamma);
    decodeStation(decoded(s.columnFrames), decoded(s.rowFrames), s.group, nominal, s.station,
                  decoder, &obs, pose ? &*pose : nullptr,
                  response.modulesBend ? &recorded : nullptr);
    if (options.onPictureSet) options.onPictureSet(i + 1, sets);
  }
  return obs;
}

double clippedLinear(double gamma) { return std::pow(254.5 / 255.0, gamma); }

cv::Mat linearFromRecorded8(const cv::Mat& recorded8, double gamma) {
  // A lookup table: 256 values, exact.
  float table[256];
  for (int i = 0; i < 256; ++i) table[i] = static_cast<float>(std::pow(i / 255.0, gamma));
  cv::Mat linear(recorded8.size(), CV_32F);
  for (int y = 0; y < recorded8.rows; ++y) {
    const uint8_t* in = recorded8.ptr<uint8_t>(y);
    float* out = linear.ptr<float>(y);
    for (int x = 0; x < recorded8.cols; ++x) out[x] = table[in[x]];
  }
  return linear;
}

cv::Mat recorded8FromLinear(const cv::Mat& linear, double gamma) {
  cv::Mat out(linear.size(), CV_8U);
  for (int y = 0; y < linear.rows; ++y) {
    const float* in = linear.ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int x = 0; x < linear.cols; ++x) {
      const double v = std::pow(std::clamp(static_cast<double>(in[x]), 0.0, 1.0), 1.0 / gamma);
      o[x] = static_cast<uint8_t>(std::lround(255.0 * v));
    }
  }
  return out;
}

void saveCameraMetadata(const CameraMetadata& camera, const std::string& path) {
  json j = cameraMetadataToJson(observationsFrame(camera));
  if (!camera.intrinsicsKnown) {
    // Only the picture size: the intrinsics are to be calibrated from the checkerboard.
    for (const char* key : {"focal_px", "principal_px", "distortion"}) j["intrinsics"].erase(key);
  }
  if (camera.responseGammaStated) j["response_gamma"] = camera.responseGamma;
  if (camera.lensBlurSigmaPx) j["lens_blur_sigma_px"] = *camera.lensBlurSigmaPx;
  writeFileAtomically(path, j.dump(2) + "\n");
}

CameraMetadata loadCameraMetadata(const std::string& path) {
  try {
    const json j = readJsonFile(path);
    CalibrationObservations obs;
    CameraMetadata camera;
    cameraMetadataFromJson(j, &obs, &camera.intrinsicsKnown);
    camera.intrinsics = obs.intrinsics;
    camera.intrinsicsCovariance = obs.intrinsicsCovariance;
    camera.stations = obs.stations;
    camera.fiducials = obs.fiducials;
    if (j.contains("response_gamma")) {
      camera.responseGamma = number(j["response_gamma"], "response_gamma");
      camera.responseGammaStated = true;
      if (!(camera.responseGamma >= 0.2 && camera.responseGamma <= 5.0))
        fail("response_gamma", "must be 0.2..5");
    }
    if (j.contains("lens_blur_sigma_px")) {
      const double blur = number(j["lens_blur_sigma_px"], "lens_blur_sigma_px");
      if (!(blur >= 0.0 && blur <= kMaxLensBlurSigmaPx))
        fail("lens_blur_sigma_px", fmt::format("must be 0..{}", kMaxLensBlurSigmaPx));
      camera.lensBlurSigmaPx = blur;
    }
    return camera;
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(path) : e;
  }
}

void saveCaptures(const CalibrationCaptures& captures, const std::string& directory) {
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec)
    throw InputError({directory, "", 0}, "cannot create the captures folder: " + ec.message());
  json j;
  j["format"] = kPatternsFormatName;
  j["version"] = kPatternsFormatVersion;
  j["period_px"] = captures.patterns.periodPx;
  j["phase_steps"] = captures.patterns.phaseSteps;
  j["min_contrast"] = captures.patterns.minContrast;
  j["module_width"] = captures.moduleWidth;
  j["module_height"] = captures.moduleHeight;
  j["stations"] = json::array();
  for (size_t i = 0; i < captures.stations.size(); ++i) {
    const StationCaptures& s = captures.stations[i];
    json entry{{"station", s.station},
               {"group", s.group},
               {"columns", json::array()},
               {"rows", json::array()}};
    for (auto [frames, axis, key] :
         {std::tuple{&s.columnFrames, 'c', "columns"}, std::tuple{&s.rowFrames, 'r', "rows"}}) {
      for (size_t f = 0; f < frames->size(); ++f) {
        const std::string name = frameName(i, axis, f);
        const std::string path = directory + "/" + name;
        if (!cv::imwrite(path, recorded8FromLinear((*frames)[f], captures.camera.responseGamma))) {
          throw InputError({path, "", 0}, "cannot write the picture");
        }
        entry[key].push_back(name);
      }
    }
    j["stations"].push_back(entry);
  }
  if (captures.checkerboard) saveCheckerboardCaptures(*captures.checkerboard, directory);
  saveCameraMetadata(captures.camera, directory + "/camera.json");
  writeFileAtomically(directory + "/patterns.json", j.dump(2) + "\n");
}

CalibrationCaptures loadCaptures(const std::string& directory) {
  CalibrationCaptures captures;
  captures.camera = loadCameraMetadata(directory + "/camera.json");
  if (hasCheckerboardCaptures(directory)) {
    captures.checkerboard = loadCheckerboardCaptures(directory, captures.camera.intrinsics.width,
                                                     captures.camera.intrinsics.height);
  } else if (!captures.camera.intrinsicsKnown) {
    throw InputError(
        {directory + "/camera.json", "intrinsics.focal_px", 0},
        fmt::format(
            "missing, and there are no checkerboard pictures ({}) to calibrate the camera from",
            kCheckerboardFileName));
  }
  const std::string path = directory + "/patterns.json";
  try {
    const json j = readJsonFile(path);
    jsonfield::requireFormat(j, kPatternsFormatName, kPatternsFormatVersion);
    captures.patterns.periodPx =
        static_cast<int>(integer(member(j, "period_px", ""), "period_px", 2, 4096));
    captures.patterns.phaseSteps =
        static_cast<int>(integer(member(j, "phase_steps", ""), "phase_steps", 3, 64));
    captures.patterns.minContrast = number(member(j, "min_contrast", ""), "min_contrast");
    captures.moduleWidth =
        static_cast<int>(integer(member(j, "module_width", ""), "module_width", 2, 1 << 15));
    captures.moduleHeight =
        static_cast<int>(integer(member(j, "module_height", ""), "module_height", 2, 1 << 15));
    try {
      captures.patterns.validate();
    } catch (const InputError& e) {
      fail(e.location().field, e.reason());
    }
    const json& stations = array(member(j, "stations", ""), "stations", kMaxCaptureSets);
    const size_t columns =
        static_cast<size_t>(framesPerAxis(captures.moduleWidth, captures.patterns));
    const size_t rows =
        static_cast<size_t>(framesPerAxis(captures.moduleHeight, captures.patterns));
    for (size_t i = 0; i < stations.size(); ++i) {
      const std::string field = fmt::format("stations[{}]", i);
      StationCaptures s;
      s.station =
          static_cast<int>(integer(member(stations[i], "station", field), field + ".station", 0,
                                   static_cast<long long>(captures.camera.stations.size()) - 1));
      const json& group = array(member(stations[i], "group", field), field + ".group", 1 << 16);
      for (size_t g = 0; g < group.size(); ++g) {
        s.group.push_back(
            static_cast<int>(integer(group[g], fmt::format("{}.group[{}]", field, g), 0, 1 << 16)));
      }
      for (auto [frames, key, expected] : {std::tuple{&s.columnFrames, "columns", columns},
                                           std::tuple{&s.rowFrames, "rows", rows}}) {
        const json& names = array(member(stations[i], key, field), field + "." + key, 1024);
        if (names.size() != expected) {
          fail(field + "." + key, fmt::format("needs {} pictures for these patterns, lists {}",
                                              expected, names.size()));
        }
        for (size_t f = 0; f < names.size(); ++f) {
          const std::string nameField = fmt::format("{}.{}[{}]", field, key, f);
          if (!names[f].is_string()) fail(nameField, "must be a file name");
          const std::string name = names[f].get<std::string>();
          if (name.empty() || name.find('/') != std::string::npos ||
              name.find("..") != std::string::npos) {
            fail(nameField, "must be a plain file name inside the captures folder");
          }
          frames->push_back(loadPicture(directory + "/" + name, captures.camera));
        }
      }
      captures.stations.push_back(std::move(s));
    }
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(path) : e;
  }
  return captures;
}

}  // namespace parallax
