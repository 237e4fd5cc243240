#include "daemon/parallaxd/cluster.h"

#include <unistd.h>

#include <cstdlib>
#include <stdexcept>

namespace parallax::daemon {

std::string Cluster::host() const {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

bool Cluster::all(bool mine, int timeoutMs) {
  bool every = true;
  for (const std::string& vote : gather(mine ? "1" : "0", timeoutMs)) every = every && vote == "1";
  std::string verdict(1, every ? '1' : '0');
  broadcast(verdict);
  return verdict == "1";
}

void SingleProcess::abort(int code) { std::exit(code); }

bool startedByMpiLauncher() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMIX_RANK") != nullptr;
}

#ifndef PARALLAX_WITH_MPI
std::unique_ptr<Cluster> joinCluster(int&, char**&) {
  if (startedByMpiLauncher())
    throw std::runtime_error(
        "started by an MPI launcher, but this parallaxd was built without MPI "
        "(install libopenmpi-dev and build again)");
  return std::make_unique<SingleProcess>();
}
#endif

}  // namespace parallax::daemon
