#include "calibration/display/display_model_json.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "calibration/display/json_fields.h"
#include "calibration/display/json_file.h"
#include "common/atomic_file.h"
#include "common/content_checksum.h"
#include "common/input_error.h"

namespace parallax {
namespace {

using nlohmann::json;

using jsonfield::fail;
using jsonfield::join;
using jsonfield::member;

double number(const json& object, const std::string& key, const std::string& path) {
  return jsonfield::number(member(object, key, path), join(path, key));
}

std::vector<double> numbers(const json& object, const std::string& key, const std::string& path,
                            size_t count) {
  return jsonfield::numbers(member(object, key, path), join(path, key), count);
}

int integer(const json& j, const std::string& field) {
  return static_cast<int>(jsonfield::integer(j, field, -(1LL << 30), 1LL << 30));
}

Eigen::Vector3d vec3(const json& object, const std::string& key, const std::string& path) {
  const auto v = numbers(object, key, path, 3);
  return {v[0], v[1], v[2]};
}

json vec3Json(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

OpticalModule moduleFromJson(const json& j, const std::string& path) {
  OpticalModule m;
  m.id = integer(member(j, "id", path), join(path, "id"));
  m.position = vec3(j, "position", path);
  const auto q = numbers(j, "orientation", path, 4);
  m.orientation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  const auto f = numbers(j, "focal_px", path, 2);
  m.fx = f[0];
  m.fy = f[1];
  const auto c = numbers(j, "principal_px", path, 2);
  m.cx = c[0];
  m.cy = c[1];
  const auto k = numbers(j, "distortion", path, 2);
  m.k1 = k[0];
  m.k2 = k[1];
  const json& res = member(j, "resolution", path);
  if (!res.is_array() || res.size() != 2) fail(join(path, "resolution"), "must be [width, height]");
  m.width = integer(res[0], join(path, "resolution") + "[0]");
  m.height = integer(res[1], join(path, "resolution") + "[1]");
  const json& mirror = member(j, "mirror", path);
  if (!mirror.is_boolean()) {
    fail(join(path, "mirror"), fmt::format("must be true or false, got {}", mirror.type_name()));
  }
  m.mirror = mirror.get<bool>();
  return m;
}

}  // namespace

json displayModelToJson(const DisplayModel& model) {
  json modules = json::array();
  for (const OpticalModule& m : model.modules) {
    const Eigen::Quaterniond& q = m.orientation;
    modules.push_back({{"id", m.id},
                       {"position", vec3Json(m.position)},
                       {"orientation", {q.w(), q.x(), q.y(), q.z()}},
                       {"focal_px", {m.fx, m.fy}},
                       {"principal_px", {m.cx, m.cy}},
                       {"distortion", {m.k1, m.k2}},
                       {"resolution", {m.width, m.height}},
                       {"mirror", m.mirror}});
  }
  return {
      {"format", kDisplayFormatName},
      {"version", kDisplayFormatVersion},
      {"name", model.name},
      {"screen",
       {{"width", model.screen.width},
        {"height", model.screen.height},
        {"curvature", model.screen.curvature},
        {"transfer", transferName(model.screen.transfer)},
        {"diffusion_deg", model.screen.diffusionDeg}}},
      {"observer", {{"y", model.observer.y}, {"z", model.observer.z}}},
      {"displayable_box",
       {{"min", vec3Json(model.displayableBox.min)}, {"max", vec3Json(model.displayableBox.max)}}},
      {"modules", modules}};
}

DisplayModel displayModelFromJson(const json& j) {
  if (!j.is_object())
    fail("", fmt::format("the document must be an object, got {}", j.type_name()));
  jsonfield::requireFormat(j, kDisplayFormatName, kDisplayFormatVersion);
  DisplayModel model;
  if (j.contains("name")) {
    if (!j["name"].is_string()) fail("name", "must be a string");
    model.name = j["name"].get<std::string>();
  }
  const json& screen = member(j, "screen", "");
  model.screen.width = number(screen, "width", "screen");
  model.screen.height = number(screen, "height", "screen");
  model.screen.curvature = number(screen, "curvature", "screen");
  model.screen.diffusionDeg = number(screen, "diffusion_deg", "screen");
  const json& transfer = member(screen, "transfer", "screen");
  if (!transfer.is_string() ||
      !parseTransfer(transfer.get<std::string>(), &model.screen.transfer)) {
    fail("screen.transfer",
         fmt::format("must be \"conical\" or \"linear\", got {}", transfer.dump()));
  }
  const json& observer = member(j, "observer", "");
  model.observer.y = number(observer, "y", "observer");
  model.observer.z = number(observer, "z", "observer");
  const json& box = member(j, "displayable_box", "");
  model.displayableBox.min = vec3(box, "min", "displayable_box");
  model.displayableBox.max = vec3(box, "max", "displayable_box");
  const json& modules = member(j, "modules", "");
  if (!modules.is_array())
    fail("modules", fmt::format("must be an array, got {}", modules.type_name()));
  if (modules.size() > static_cast<size_t>(kMaxModules)) {
    fail("modules", fmt::format("at most {} modules, got {}", kMaxModules, modules.size()));
  }
  for (size_t i = 0; i < modules.size(); ++i) {
    model.modules.push_back(moduleFromJson(modules[i], fmt::format("modules[{}]", i)));
  }
  model.validate();
  return model;
}

namespace {

// The checksum covers the document without its own field, in compact canonical form: keys
// sorted, doubles shortest-round-trip, so parsing the file and dumping it again gives back
// exactly the bytes that were hashed when it was saved.
std::string checksumOfDocument(json document) {
  document.erase(kDisplayChecksumField);
  return contentChecksum(document.dump());
}

}  // namespace

DisplayModel loadDisplayModel(const std::string& path) {
  json j = readJsonFile(path, kMaxDisplayFileBytes);
  if (j.is_object() && j.contains(kDisplayChecksumField)) {
    const json& stored = j[kDisplayChecksumField];
    if (!stored.is_string() || stored.get<std::string>() != checksumOfDocument(j)) {
      throw InputError({path, kDisplayChecksumField, 0},
                       "does not match the content: the file is damaged or was edited (remove "
                       "the checksum field to accept a hand edit)");
    }
    j.erase(kDisplayChecksumField);
  }
  try {
    return displayModelFromJson(j);
  } catch (const InputError& e) {
    throw e.inFile(path);
  }
}

void saveDisplayModel(const DisplayModel& model, const std::string& path) {
  json document = displayModelToJson(model);
  document[kDisplayChecksumField] = checksumOfDocument(document);
  writeFileAtomically(path, document.dump(2) + "\n");
}

}  // namespace parallax
