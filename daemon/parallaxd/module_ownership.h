#pragma once
// Which rank of a cluster (cluster.h) renders and pushes which modules: the modules its link
// reaches. By default contiguous blocks in module order (rank r of N holds modules
// [r·M/N, (r+1)·M/N)); `[cluster] modules` gives the map explicitly. A rank holds the ray
// textures, the frames and the link of its own modules only, so its memory grows with its
// module count, not the display's.

#include <string>
#include <vector>

#include "daemon/parallaxd/daemon_config.h"

namespace parallax::daemon {

class ModuleOwnership {
 public:
  // The config's map when it gives one, else contiguous blocks. Throws InputError naming
  // cluster.modules (file and line) when the map does not fit: a list per rank, every module
  // of the display exactly once.
  static ModuleOwnership of(const ClusterConfig& config, int modules, int ranks);
  // One rank with every module: a daemon without a cluster.
  static ModuleOwnership single(int modules) { return of({}, modules, 1); }

  int ranks() const { return static_cast<int>(byRank_.size()); }
  int modules() const { return static_cast<int>(owner_.size()); }
  // In increasing order: a rank's local module i is modulesOf(rank)[i].
  const std::vector<int>& modulesOf(int rank) const;
  int ownerOf(int module) const;
  // "rank 1 (modules 3-5)", "rank 2 (modules 0, 7, 9)", "rank 3 (no modules)": for errors.
  std::string describe(int rank) const;

 private:
  std::vector<std::vector<int>> byRank_;
  std::vector<int> owner_;
};

// The link spec of one rank: its own modules' devices (the [hardware.modules] serials of the
// modules it owns, in their order), or "" for a simulator of its own. Throws InputError
// (hardware.socket) for a shared simulator socket on several ranks: each rank needs the link
// that reaches its modules.
std::string linkSpecOfRank(const HardwareConfig& hardware, const ModuleOwnership& ownership,
                           int rank);

}  // namespace parallax::daemon
