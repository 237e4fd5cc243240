#include "calibration/display/display_model_json.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>

#include "calibration/display/display_presets.h"
#include "common/input_error.h"
#include "test_displays.h"

namespace parallax {
namespace {

using nlohmann::json;

std::string temporaryPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("parallax_test_" + name)).string();
}

TEST(DisplayModelJson, RoundTripIsBitExact) {
  DisplayModel model = testing::smallDisplay(0.37, ScreenTransfer::kLinear, 7);
  model.modules[3].k1 = -0.123456789012345678;
  model.modules[3].k2 = 1e-300;
  model.modules[2].mirror = false;
  model.modules[1].position.y() = std::nextafter(0.1, 1.0);
  const std::string path = temporaryPath("roundtrip.json");
  saveDisplayModel(model, path);
  const DisplayModel back = loadDisplayModel(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back.name, model.name);
  EXPECT_EQ(back.screen.width, model.screen.width);
  EXPECT_EQ(back.screen.curvature, model.screen.curvature);
  EXPECT_EQ(back.screen.transfer, model.screen.transfer);
  EXPECT_EQ(back.screen.diffusionDeg, model.screen.diffusionDeg);
  EXPECT_EQ(back.observer.z, model.observer.z);
  EXPECT_EQ(back.displayableBox.min, model.displayableBox.min);
  ASSERT_EQ(back.modules.size(), model.modules.size());
  for (size_t i = 0; i < model.modules.size(); ++i) {
    const OpticalModule &a = model.modules[i], &b = back.modules[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.position, b.position);
    EXPECT_EQ(a.orientation.coeffs(), b.orientation.coeffs());
    EXPECT_EQ(a.fx, b.fx);
    EXPECT_EQ(a.fy, b.fy);
    EXPECT_EQ(a.cx, b.cx);
    EXPECT_EQ(a.cy, b.cy);
    EXPECT_EQ(a.k1, b.k1);
    EXPECT_EQ(a.k2, b.k2);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.mirror, b.mirror);
  }
  // And the text is stable: saving what was loaded writes the same bytes.
  EXPECT_EQ(displayModelToJson(back).dump(), displayModelToJson(model).dump());
}

struct BadInput {
  std::string name;
  std::function<void(json&)> corrupt;
  std::string field;   // the field the error must name
  std::string reason;  // and a piece of its reason
};

void PrintTo(const BadInput& b, std::ostream* os) { *os << b.name; }

class DisplayModelJsonErrors : public ::testing::TestWithParam<BadInput> {};

TEST_P(DisplayModelJsonErrors, NameTheFieldAndTheReason) {
  json j = displayModelToJson(testing::smallDisplay(0.0, ScreenTransfer::kConical, 3));
  GetParam().corrupt(j);
  try {
    displayModelFromJson(j);
    FAIL() << "accepted " << GetParam().name;
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, GetParam().field) << e.what();
    EXPECT_NE(std::string(e.what()).find(GetParam().reason), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Each, DisplayModelJsonErrors,
    ::testing::Values(
        BadInput{"missing_key", [](json& j) { j["screen"].erase("height"); }, "screen.height",
                 "missing"},
        BadInput{"missing_module_key", [](json& j) { j["modules"][1].erase("focal_px"); },
                 "modules[1].focal_px", "missing"},
        BadInput{"wrong_type", [](json& j) { j["screen"]["width"] = "wide"; }, "screen.width",
                 "must be a number, got string"},
        BadInput{"wrong_type_mirror", [](json& j) { j["modules"][0]["mirror"] = 1; },
                 "modules[0].mirror", "true or false"},
        BadInput{"infinite",
                 [](json& j) { j["observer"]["z"] = std::numeric_limits<double>::infinity(); },
                 "observer.z", "finite"},
        BadInput{"nan", [](json& j) { j["modules"][2]["position"][1] = std::nan(""); },
                 "modules[2].position[1]", "finite"},
        BadInput{"non_positive_size", [](json& j) { j["screen"]["width"] = 0.0; }, "screen.width",
                 "must be positive"},
        BadInput{"negative_resolution", [](json& j) { j["modules"][0]["resolution"][1] = -4; },
                 "modules[0].resolution", "between 1 and"},
        BadInput{"module_in_front", [](json& j) { j["modules"][1]["position"][2] = 0.1; },
                 "modules[1].position", "behind the screen"},
        BadInput{"non_unit_quaternion",
                 [](json& j) {
                   j["modules"][0]["orientation"] = {1.0, 0.1, 0.0, 0.0};
                 },
                 "modules[0].orientation", "unit length"},
        BadInput{"zero_focal", [](json& j) { j["modules"][2]["focal_px"][0] = 0.0; },
                 "modules[2].focal_px", "non-zero"},
        BadInput{"folding_screen", [](json& j) { j["screen"]["curvature"] = 1.25; },
                 "screen.curvature", "fold"},
        BadInput{"unknown_version", [](json& j) { j["version"] = 2; }, "version",
                 "unknown version 2"},
        BadInput{"wrong_format", [](json& j) { j["format"] = "something-else"; }, "format",
                 "parallax-display"},
        BadInput{"unknown_transfer", [](json& j) { j["screen"]["transfer"] = "magic"; },
                 "screen.transfer", "conical"},
        BadInput{"observer_behind", [](json& j) { j["observer"]["z"] = -1.0; }, "observer.z",
                 "in front of the screen"},
        BadInput{"duplicate_id", [](json& j) { j["modules"][2]["id"] = 0; }, "modules[2].id",
                 "used twice"},
        BadInput{"empty_box", [](json& j) { j["displayable_box"]["max"][2] = -1.0; },
                 "displayable_box", "max must exceed min"},
        // Finite but absurd (issue 18, defect 16): the physical ranges of display_model.h.
        BadInput{"absurd_screen_height", [](json& j) { j["screen"]["height"] = 1e300; },
                 "screen.height", "outside the physical range"},
        BadInput{"absurd_module_x", [](json& j) { j["modules"][1]["position"][0] = 1e308; },
                 "modules[1].position[0]", "outside the physical range"},
        BadInput{"absurd_distortion", [](json& j) { j["modules"][0]["distortion"][0] = 1e10; },
                 "modules[0].distortion[0]", "outside the physical range"},
        BadInput{"absurd_focal", [](json& j) { j["modules"][2]["focal_px"][1] = 1e12; },
                 "modules[2].focal_px[1]", "outside the physical range"},
        BadInput{"absurd_principal_point",
                 [](json& j) { j["modules"][0]["principal_px"][0] = -1e9; },
                 "modules[0].principal_px[0]", "module widths from the centre"},
        BadInput{"absurd_observer", [](json& j) { j["observer"]["z"] = 1e6; }, "observer.z",
                 "outside the physical range"},
        BadInput{"absurd_box", [](json& j) { j["displayable_box"]["min"][0] = -1e200; },
                 "displayable_box.min[0]", "outside the physical range"},
        BadInput{"absurd_curvature",
                 [](json& j) {
                   j["screen"]["width"] = 1e-6;
                   j["screen"]["curvature"] = 1e5;
                 },
                 "screen.curvature", "outside the physical range"}),
    [](const ::testing::TestParamInfo<BadInput>& p) { return p.param.name; });

// Loads `text` as a display file named `name`: the error it raises, which names the file.
std::string loadErrorOf(const std::string& name, const std::string& text, int* line) {
  const std::string path = temporaryPath(name);
  std::ofstream(path) << text;
  std::string what = "(loaded without an error)";
  try {
    loadDisplayModel(path);
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().file, path);
    *line = e.location().line;
    what = e.what();
  }
  std::filesystem::remove(path);
  return what;
}

TEST(DisplayModelJson, SyntaxErrorsNameTheFileAndLine) {
  int line = 0;
  const std::string what = loadErrorOf(
      "broken.json",
      "{\n  \"format\": \"parallax-display\",\n  \"version\": 1,\n  \"screen\": {,\n}\n", &line);
  EXPECT_EQ(line, 4) << what;
}

// A number beyond a double is refused by the parser as out of range, not as a syntax error:
// it once escaped as "[json.exception.out_of_range.406] number overflow parsing '1e400'",
// without the file.
TEST(DisplayModelJson, ANumberBeyondADoubleNamesTheFileAndLine) {
  int line = 0;
  const std::string what = loadErrorOf("overflow.json",
                                       "{\n  \"format\": \"parallax-display\",\n  \"version\": "
                                       "1,\n  \"screen\": {\"width\": 1e400}\n}\n",
                                       &line);
  EXPECT_EQ(line, 4) << what;
  EXPECT_NE(what.find("number overflow parsing '1e400'"), std::string::npos) << what;
}

TEST(DisplayModelJson, FieldErrorsFromAFileNameTheFile) {
  const std::string path = temporaryPath("bad_field.json");
  json j = displayModelToJson(testing::smallDisplay(0.0, ScreenTransfer::kConical, 2));
  j["modules"][1]["focal_px"][1] = 0.0;
  {
    std::ofstream out(path);
    out << j.dump(2);
  }
  try {
    loadDisplayModel(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().file, path);
    EXPECT_EQ(e.location().field, "modules[1].focal_px");
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
  }
  std::filesystem::remove(path);
  EXPECT_THROW(loadDisplayModel(temporaryPath("does_not_exist.json")), InputError);
}

TEST(DisplayPresets, DefaultAndDemoAreWhatTheDesignSays) {
  const DisplayModel def = resolveDisplay("default");
  EXPECT_EQ(def.modules.size(), 72u);
  EXPECT_EQ(def.modules[0].width, 1024);
  EXPECT_EQ(def.modules[0].height, 768);
  EXPECT_EQ(def.pixelCount(), 72L * 1024 * 768);
  EXPECT_EQ(def.screen.width, 1.6);
  EXPECT_EQ(def.screen.height, 0.9);
  EXPECT_EQ(def.observer.z, 2.0);
  EXPECT_EQ(def.observer.y, 0.0);
  EXPECT_NEAR(def.screen.diffusionDeg, 1.5 * angularPitchDeg(def), 1e-12);
  const DisplayModel demo = resolveDisplay("demo");
  EXPECT_EQ(demo.modules.size(), 16u);
  EXPECT_EQ(demo.modules[0].width, 512);
  EXPECT_EQ(demo.modules[0].height, 384);
  EXPECT_NEAR(demo.screen.diffusionDeg, 1.5 * angularPitchDeg(demo), 1e-12);
  // Each module's image covers the whole screen: every corner lands inside the image.
  for (const DisplayModel* model : {&def, &demo}) {
    for (const OpticalModule& m : model->modules) {
      const ModuleOptics optics(m);
      for (double x : {-0.8, 0.0, 0.8}) {
        for (double y : {-0.45, 0.45}) {
          Eigen::Vector2d pixel;
          ASSERT_TRUE(
              optics.project((model->screen.pointAt(x, y) - m.position).normalized(), &pixel));
          EXPECT_GE(pixel.x(), 0.0);
          EXPECT_LE(pixel.x(), m.width);
          EXPECT_GE(pixel.y(), 0.0);
          EXPECT_LE(pixel.y(), m.height);
        }
      }
    }
  }
}

// A display file must be a regular file of sensible size (issue 18, defects 9 and 18): a
// folder, a FIFO (which would block the reader for ever) or /dev/zero (which never ends) is
// refused before reading, naming the file and what it is.
TEST(DisplayModelJson, OnlyRegularFilesAreRead) {
  const std::filesystem::path folder = temporaryPath("kinds");
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder / "folder.json");
  const std::string fifo = (folder / "fifo.json").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::pair<std::string, std::string> cases[] = {
      {(folder / "folder.json").string(), "a folder"}, {fifo, "a FIFO"}, {"/dev/zero", "a device"}};
  for (const auto& [path, kind] : cases) {
    try {
      loadDisplayModel(path);
      ADD_FAILURE() << path << " loaded";
    } catch (const InputError& e) {
      EXPECT_EQ(e.location().file, path);
      EXPECT_NE(std::string(e.what()).find(kind), std::string::npos) << e.what();
    }
  }
  // Larger than any display can be: refused by its size, not parsed.
  const std::string huge = (folder / "huge.json").string();
  {
    std::ofstream out(huge);
    out.seekp(static_cast<std::streamoff>(kMaxDisplayFileBytes) + 1);
    out << ' ';
  }
  try {
    loadDisplayModel(huge);
    ADD_FAILURE() << "a huge file loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("more than"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace parallax
