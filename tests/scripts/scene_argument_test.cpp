// `--scene` arguments: a bare library name means the library's script, the source of truth.

#include "scripts/scene_argument.h"

#include <gtest/gtest.h>

#include "common/input_error.h"
#include "tracer/scene_fixtures.h"

namespace parallax {
namespace {

TEST(SceneArgument, LibraryNamesLoadTheirScripts) {
  for (const char* name : {"cornell", "shapes", "orbit"}) {
    const std::string script = librarySceneScript(name);
    ASSERT_FALSE(script.empty()) << name;
    EXPECT_NE(script.find(std::string("scripts/scenes/") + name + ".lua"), std::string::npos);
  }
  const Scene fromName = loadSceneArgument("cornell", {}, 0.0);
  const Scene fromFixture = makeCornellScene();
  EXPECT_EQ(fromName.triangleCount(), fromFixture.triangleCount());
  EXPECT_EQ(fromName.lights.size(), fromFixture.lights.size());
  // Parameters reach the script through the bare name as well.
  EXPECT_NO_THROW(loadSceneArgument("orbit", {"speed=0.5"}, 1.0));
}

TEST(SceneArgument, OnlyPlainNamesAreLookedUpInTheLibrary) {
  EXPECT_EQ(librarySceneScript("xyz"), "");  // a C++ fixture with no script
  EXPECT_EQ(librarySceneScript("../cornell"), "");
  EXPECT_EQ(librarySceneScript("lib/paper"), "");
  EXPECT_EQ(librarySceneScript(""), "");
  EXPECT_EQ(loadSceneArgument("xyz", {}, 0.0).triangleCount(), 1);
  EXPECT_THROW(loadSceneArgument("no_such_scene", {}, 0.0), InputError);
}

}  // namespace
}  // namespace parallax
