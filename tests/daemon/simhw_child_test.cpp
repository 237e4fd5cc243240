// Where parallaxd's own simulator keeps its truth files: one folder per nominal display and
// seed, so daemons on different displays sharing a cache and a seed never overwrite each
// other's ground truth (the frames helper's bench on `default` broke a demo run that way).

#include "daemon/parallaxd/simhw_child.h"

#include <gtest/gtest.h>

#include <set>

#include "calibration/display/display_presets.h"

namespace parallax::daemon {
namespace {

DisplayModel nominal(const std::string& preset, std::optional<int> modules = std::nullopt) {
  NominalDisplayOptions o;
  o.preset = preset;
  o.modules = modules;
  return makeNominalDisplay(o);
}

TEST(SimhwChild, KeepsATruthFolderPerDisplayAndSeed) {
  const std::string demo = SimhwChild::folderFor("/c", nominal("demo"), 7);
  EXPECT_EQ(demo, SimhwChild::folderFor("/c", nominal("demo"), 7)) << "the same display again";
  EXPECT_EQ(demo.rfind("/c/simulated-display/demo-", 0), 0u) << demo;
  EXPECT_EQ(demo.substr(demo.size() - 7), "/seed-7") << demo;
  // Another preset, the same preset with another module count, another seed: all apart.
  const std::set<std::string> folders = {demo, SimhwChild::folderFor("/c", nominal("default"), 7),
                                         SimhwChild::folderFor("/c", nominal("demo", 4), 7),
                                         SimhwChild::folderFor("/c", nominal("demo"), 8)};
  EXPECT_EQ(folders.size(), 4u);
  // Any parameter counts, not only the size: a module moved by a micrometre.
  DisplayModel moved = nominal("demo");
  moved.modules[0].position.x() += 1e-6;
  EXPECT_NE(SimhwChild::folderFor("/c", moved, 7), demo);
  // A display file may name itself anything: the name stays one plain path segment.
  DisplayModel named = nominal("demo");
  named.name = "../../etc/x y";
  const std::string folder = SimhwChild::folderFor("/c", named, 7);
  EXPECT_EQ(folder.find(".."), std::string::npos) << folder;
  EXPECT_EQ(folder.rfind("/c/simulated-display/______etc_x_y-", 0), 0u) << folder;
}

}  // namespace
}  // namespace parallax::daemon
