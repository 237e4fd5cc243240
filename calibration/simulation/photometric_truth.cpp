#include "calibration/simulation/photometric_truth.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "calibration/display/json_fields.h"
#include "calibration/display/json_file.h"
#include "calibration/simulation/seeded_random.h"
#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax {
namespace {

using jsonfield::fail;
using jsonfield::member;
using nlohmann::json;
constexpr const char* kFormatName = "parallax-photometric-truth";
constexpr int kFormatVersion = 1;

}  // namespace

double ModulePhotometricTruth::falloff(double u, double v, int width, int height) const {
  if (vignetting == 0.0) return 1.0;
  // Image position in half widths / heights from the centre; the farthest corner from the
  // falloff's centre gets 1 − vignetting.
  const double x = 2.0 * u / width - 1.0, y = 2.0 * v / height - 1.0;
  const double cx = vignettingCentre.x(), cy = vignettingCentre.y();
  const double far =
      (1.0 + std::abs(cx)) * (1.0 + std::abs(cx)) + (1.0 + std::abs(cy)) * (1.0 + std::abs(cy));
  const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / far;
  return 1.0 - vignetting * std::min(r2, 1.0);
}

Eigen::Vector3d ModulePhotometricTruth::light(const Eigen::Vector3d& codes, double u, double v,
                                              int width, int height) const {
  Eigen::Vector3d drive;
  for (int c = 0; c < 3; ++c)
    drive[c] = std::pow(std::clamp(codes[c], 0.0, 255.0) / 255.0, gamma[c]);
  return falloff(u, v, width, height) * (primaries * drive + black);
}

cv::Mat PhotometricTruth::emittedLight(int module, int width, int height,
                                       const std::uint8_t* rgb) const {
  if (module < 0 || module >= static_cast<int>(modules.size()) || width < 1 || height < 1) {
    throw std::invalid_argument("emittedLight: no such module or an empty frame");
  }
  const ModulePhotometricTruth& m = modules[static_cast<size_t>(module)];
  // The response as a table per channel (the frame has 8-bit codes only).
  std::array<std::array<double, 256>, 3> drive{};
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 256; ++k)
      drive[static_cast<size_t>(c)][static_cast<size_t>(k)] = std::pow(k / 255.0, m.gamma[c]);
  cv::Mat out(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y) {
    cv::Vec3f* row = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < width; ++x) {
      const std::uint8_t* p =
          rgb + 3 * (static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x));
      const Eigen::Vector3d d(drive[0][p[0]], drive[1][p[1]], drive[2][p[2]]);
      const Eigen::Vector3d l =
          m.falloff(x + 0.5, y + 0.5, width, height) * (m.primaries * d + m.black);
      row[x] = cv::Vec3f(static_cast<float>(l.x()), static_cast<float>(l.y()),
                         static_cast<float>(l.z()));
    }
  }
  return out;
}

void PhotometricTruthOptions::validate() const {
  auto check = [](bool ok, const char* field, const std::string& why) {
    if (!ok) throw InputError({"", field, 0}, why);
  };
  check(gammaMin >= 1.0 && gammaMax <= 3.5 && gammaMin <= gammaMax, "gamma",
        "must be 1 <= gamma_min <= gamma_max <= 3.5");
  check(gainSigma >= 0.0 && gainSigma <= 0.2, "gain_sigma", "must be 0..0.2");
  check(mixingMax >= 0.0 && mixingMax <= 0.3, "mixing_max", "must be 0..0.3");
  check(blackMin >= 0.0 && blackMin <= blackMax && blackMax <= 0.05, "black",
        "must be 0 <= black_min <= black_max <= 0.05");
  check(vignettingMin >= 0.0 && vignettingMin <= vignettingMax && vignettingMax <= 0.6,
        "vignetting", "must be 0 <= vignetting_min <= vignetting_max <= 0.6");
  check(weakModules >= 0 && tintedModules >= 0, "weak_modules", "must be >= 0");
}

PhotometricTruth makePhotometricTruth(int moduleCount, const PhotometricTruthOptions& options) {
  options.validate();
  PhotometricTruth truth;
  truth.seed = options.seed;
  SeededRandom random(options.seed);
  // The weak and tinted modules, drawn first and apart from the per-module streams.
  SeededRandom pick = random.split();
  std::vector<int> special(static_cast<size_t>(std::max(moduleCount, 0)), 0);  // 1 weak, 2 tinted
  for (int kind = 1; kind <= 2; ++kind) {
    const int count = kind == 1 ? options.weakModules : options.tintedModules;
    for (int n = 0, tries = 0; n < count && tries < 100 * moduleCount; ++tries) {
      const int i = pick.index(moduleCount);
      if (special[static_cast<size_t>(i)] != 0) continue;
      special[static_cast<size_t>(i)] = kind;
      ++n;
    }
  }
  for (int i = 0; i < moduleCount; ++i) {
    SeededRandom r = random.split();  // one stream per module: adding modules shifts nothing
    ModulePhotometricTruth m;
    for (int c = 0; c < 3; ++c) m.gamma[c] = r.uniform(options.gammaMin, options.gammaMax);
    Eigen::Matrix3d mixing = Eigen::Matrix3d::Identity();
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col)
        if (row != col) mixing(row, col) = r.uniform(0.0, options.mixingMax);
    Eigen::Vector3d gain;
    for (int c = 0; c < 3; ++c) {
      gain[c] = 1.0 + r.clippedNormal(options.gainSigma, 2.0 * options.gainSigma);
    }
    const double weak = r.uniform(0.6, 0.7);
    const int tintChannel = r.index(3);
    const double tint = r.uniform(0.6, 0.7);
    if (special[static_cast<size_t>(i)] == 1) gain *= weak;
    if (special[static_cast<size_t>(i)] == 2) gain[tintChannel] *= tint;
    // Mixing adds light to every channel: scale so a module's white stays near 1.
    m.primaries = mixing * gain.asDiagonal() / (1.0 + options.mixingMax);
    for (int c = 0; c < 3; ++c) m.black[c] = r.uniform(options.blackMin, options.blackMax);
    m.vignetting = r.uniform(options.vignettingMin, options.vignettingMax);
    m.vignettingCentre = Eigen::Vector2d(r.uniform(-0.15, 0.15), r.uniform(-0.15, 0.15));
    truth.modules.push_back(m);
  }
  return truth;
}

void savePhotometricTruth(const PhotometricTruth& truth, const std::string& path) {
  json j;
  j["format"] = kFormatName;
  j["version"] = kFormatVersion;
  j["seed"] = truth.seed;
  j["modules"] = json::array();
  for (const ModulePhotometricTruth& m : truth.modules) {
    json primaries = json::array();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) primaries.push_back(m.primaries(r, c));
    j["modules"].push_back(
        {{"gamma", {m.gamma.x(), m.gamma.y(), m.gamma.z()}},
         {"primaries", primaries},
         {"black", {m.black.x(), m.black.y(), m.black.z()}},
         {"vignetting", m.vignetting},
         {"vignetting_centre", {m.vignettingCentre.x(), m.vignettingCentre.y()}}});
  }
  writeFileAtomically(path, j.dump(2) + "\n");
}

PhotometricTruth loadPhotometricTruth(const std::string& path) {
  try {
    const json j = readJsonFile(path);
    jsonfield::requireFormat(j, kFormatName, kFormatVersion);
    PhotometricTruth truth;
    const json& seed = member(j, "seed");
    if (!seed.is_number_unsigned()) fail("seed", "must be a non-negative integer");
    truth.seed = seed.get<std::uint64_t>();
    const json& modules = jsonfield::array(member(j, "modules"), "modules", 4096);
    for (size_t i = 0; i < modules.size(); ++i) {
      const std::string at = fmt::format("modules[{}]", i);
      ModulePhotometricTruth m;
      const std::vector<double> gamma =
          jsonfield::numbers(member(modules[i], "gamma", at), at + ".gamma", 3);
      for (int c = 0; c < 3; ++c) {
        m.gamma[c] = gamma[static_cast<size_t>(c)];
        if (m.gamma[c] < 0.2 || m.gamma[c] > 5.0) fail(at + ".gamma", "must be 0.2..5");
      }
      const std::vector<double> p =
          jsonfield::numbers(member(modules[i], "primaries", at), at + ".primaries", 9);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          m.primaries(r, c) = p[static_cast<size_t>(3 * r + c)];
          if (m.primaries(r, c) < 0.0 || m.primaries(r, c) > 10.0)
            fail(at + ".primaries", "must be 0..10");
        }
      const std::vector<double> black =
          jsonfield::numbers(member(modules[i], "black", at), at + ".black", 3);
      for (int c = 0; c < 3; ++c) {
        m.black[c] = black[static_cast<size_t>(c)];
        if (m.black[c] < 0.0 || m.black[c] > 1.0) fail(at + ".black", "must be 0..1");
      }
      m.vignetting = jsonfield::number(member(modules[i], "vignetting", at), at + ".vignetting");
      if (m.vignetting < 0.0 || m.vignetting > 0.9) fail(at + ".vignetting", "must be 0..0.9");
      const std::vector<double> centre = jsonfield::numbers(
          member(modules[i], "vignetting_centre", at), at + ".vignetting_centre", 2);
      m.vignettingCentre = Eigen::Vector2d(centre[0], centre[1]);
      if (m.vignettingCentre.cwiseAbs().maxCoeff() > 1.0)
        fail(at + ".vignetting_centre", "must be within -1..1");
      truth.modules.push_back(m);
    }
    return truth;
  } catch (const InputError& e) {
    throw e.inFile(path);
  }
}

}  // namespace parallax
