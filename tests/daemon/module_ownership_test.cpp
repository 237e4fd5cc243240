// Which rank of a cluster renders which modules (module_ownership.h): contiguous blocks by
// default, an explicit map checked against the display and the job, and each rank's link.

#include "daemon/parallaxd/module_ownership.h"

#include <gtest/gtest.h>

#include "common/input_error.h"

namespace parallax::daemon {
namespace {

TEST(ModuleOwnership, ContiguousBlocksCoverEveryModuleOnce) {
  for (int ranks = 1; ranks <= 7; ++ranks) {
    const ModuleOwnership o = ModuleOwnership::of({}, 16, ranks);
    std::vector<int> seen;
    for (int r = 0; r < ranks; ++r) {
      const std::vector<int>& mine = o.modulesOf(r);
      // Blocks differ by one module at most: the work is spread evenly.
      EXPECT_GE(static_cast<int>(mine.size()), 16 / ranks);
      EXPECT_LE(static_cast<int>(mine.size()), 16 / ranks + 1);
      for (int m : mine) {
        EXPECT_EQ(o.ownerOf(m), r);
        seen.push_back(m);
      }
    }
    std::vector<int> every(16);
    for (int m = 0; m < 16; ++m) every[static_cast<size_t>(m)] = m;
    EXPECT_EQ(seen, every) << ranks << " ranks";
  }
  EXPECT_EQ(ModuleOwnership::of({}, 16, 3).describe(1), "rank 1 (modules 5-9)");
}

TEST(ModuleOwnership, AnExplicitMapIsKeptAndDescribed) {
  ClusterConfig c;
  c.modules = {{3, 0}, {1, 2}};
  const ModuleOwnership o = ModuleOwnership::of(c, 4, 2);
  EXPECT_EQ(o.modulesOf(0), (std::vector<int>{0, 3}));
  EXPECT_EQ(o.ownerOf(3), 0);
  EXPECT_EQ(o.ownerOf(2), 1);
  EXPECT_EQ(o.describe(0), "rank 0 (modules 0, 3)");
  // One rank (no launcher) drives the whole display whatever the map says.
  EXPECT_EQ(ModuleOwnership::of(c, 4, 1).modulesOf(0).size(), 4u);
}

TEST(ModuleOwnership, AMapThatDoesNotFitNamesTheKeyAndWhy) {
  const auto refusal = [](std::vector<std::vector<int>> map, int ranks) {
    ClusterConfig c;
    c.modules = std::move(map);
    c.file = "parallax.toml";
    c.line = 12;
    try {
      ModuleOwnership::of(c, 4, ranks);
    } catch (const InputError& e) {
      EXPECT_EQ(e.location().field, "cluster.modules");
      EXPECT_EQ(e.location().line, 12);
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal({{0, 1}, {2, 3}}, 3).find("2 ranks, but the job has 3"), std::string::npos);
  EXPECT_NE(refusal({{0, 1}, {1, 2, 3}}, 2).find("module 1 is given to rank 0 and to rank 1"),
            std::string::npos);
  EXPECT_NE(refusal({{0, 1}, {2}}, 2).find("module 3 is given to no rank"), std::string::npos);
  EXPECT_NE(refusal({{0, 1}, {2, 3, 9}}, 2).find("module 9 does not exist"), std::string::npos);
}

TEST(ModuleOwnership, EachRankLinksItsOwnModulesDevices) {
  HardwareConfig usb;
  usb.kind = "usb";
  usb.vid = 0x1d50;
  usb.pid = 0x6150;
  usb.serialToModule = {{"A", 0}, {"B", 1}, {"C", 2}, {"D", 3}};
  const ModuleOwnership o = ModuleOwnership::of({}, 4, 2);
  EXPECT_EQ(linkSpecOfRank(usb, o, 0), "usb:1d50:6150:A,B");
  EXPECT_EQ(linkSpecOfRank(usb, o, 1), "usb:1d50:6150:C,D");
  // A simulator each (started by the rank), never one shared socket.
  HardwareConfig sim;
  EXPECT_EQ(linkSpecOfRank(sim, o, 1), "");
  sim.socket = "/run/simhw.sock";
  EXPECT_THROW(linkSpecOfRank(sim, o, 1), InputError);
  EXPECT_EQ(linkSpecOfRank(sim, ModuleOwnership::single(4), 0), "simhw:/run/simhw.sock");
}

TEST(ModuleOwnership, TheConfigReadsTheMapAndRefusesABadOne) {
  const DaemonConfig c = parseDaemonConfig(
      "[cluster]\nmodules = [[0, 1], [2, 3]]\ntimeout_ms = 5000\n", "parallax.toml");
  EXPECT_EQ(c.cluster.modules, (std::vector<std::vector<int>>{{0, 1}, {2, 3}}));
  EXPECT_EQ(c.cluster.timeoutMs, 5000);
  EXPECT_EQ(c.cluster.line, 2);
  try {
    parseDaemonConfig("[cluster]\nmodules = [0, 1]\n", "parallax.toml");
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "cluster.modules");
    EXPECT_EQ(e.location().line, 2);
  }
  EXPECT_THROW(parseDaemonConfig("[cluster]\nranks = 2\n", "parallax.toml"), InputError);
}

}  // namespace
}  // namespace parallax::daemon
