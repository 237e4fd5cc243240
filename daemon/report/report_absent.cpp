// The trade-offs of features this build does not have yet (issue 25: a section per trade-off,
// one line where its feature is absent). Each becomes a section of its own when it lands.

#include "daemon/report/report.h"

namespace parallax::report {

void writeAbsentSections(Report& report) {
  report.absent("Cluster: rank count against sync overhead and frame rate",
                "Not in the report: the cluster (issue 23) runs under mpirun, which the report "
                "does not launch; `parallax bench cluster` measures it (README, \"A cluster\").");
}

}  // namespace parallax::report
