#include "calibration/display/display_model.h"  // kMaxDisplayExtentM (header only)
#include "daemon/parallaxd/control_request.h"

// The control socket's requests, each declared once: name, arguments, help, where it is served.
// Both sides use this table: the daemon to check and dispatch (its handlers are named by these
// names in conductor_requests.cpp, checked complete when a conductor is made), the client for
// `parallax ctl --help` — without linking the daemon.

namespace parallax::daemon {

const std::vector<RequestSpec>& controlRequests() {
  using K = ArgKind;
  constexpr Served kAtOnce = Served::kAtOnce;
  constexpr Served kQueued = Served::kOnConductorThread;
  // The scene's parameters are bounded as in the config ([scene.parameters]).
  constexpr double kParameterLimit = 1e9;
  // A view is made in memory at once: a bound a client cannot turn into gigabytes.
  constexpr double kMaxViewSide = 8192;
  static const std::vector<RequestSpec> table = {
      {"status", {}, "state, stage, calibration, link health, scene, last error", kAtOnce},
      {"stats", {}, "frame counts and timings of the render loop and the link", kAtOnce},
      {"calibrate",
       {{"module", K::kModule, false, 0, 0, "refit this module only, the others held"},
        {"photometric", K::kString, false, 0, 0,
         "only (the modules' colours; the geometry kept), on (geometry and colours) or off; "
         "default: [calibration] photometric"}},
       "calibrate through the link and install the fit (minutes)",
       kQueued},
      {"cancel", {}, "stop a running calibration; the installed one stays", kAtOnce},
      {"rollback", {}, "install the previous calibration (and its photometry) again", kQueued},
      {"load",
       {{"scene", K::kString, true, 0, 0, "library name (cornell, ...) or .lua file"},
        {"parameters", K::kNumberMap, false, 0, 0, "the scene's parameters by name"}},
       "load a scene script",
       kQueued},
      {"play", {}, "play the scene (ends identify and testcard)", kQueued},
      {"pause", {}, "hold the frame the modules show", kQueued},
      {"set",
       {{"name", K::kString, true, 0, 0, "a parameter the scene declares"},
        {"value", K::kNumber, true, -kParameterLimit, kParameterLimit, "its new value"}},
       "set a scene parameter",
       kQueued},
      {"frame",
       {{"module", K::kModule, true, 0, 0, "the module"},
        {"path", K::kPath, false, 0, 0, "PNG to write (default: in the cache folder)"}},
       "write what a module shows as a PNG",
       kQueued},
      {"view",
       {{"x", K::kNumber, true, -kMaxDisplayExtentM, kMaxDisplayExtentM,
         "the viewer's x on the observer line (m)"},
        {"width", K::kInteger, false, 1, kMaxViewSide, "view pixels across"},
        {"height", K::kInteger, false, 1, kMaxViewSide, "view pixels down"},
        {"path", K::kPath, false, 0, 0, "PNG to write (default: in the cache folder)"}},
       "write what a viewer on the observer line sees",
       kQueued},
      {"reload", {}, "read the config file and the scene script again", kQueued},
      {"identify",
       {{"module", K::kModule, false, 0, 0, "only this module"}},
       "show each module's number (`play` returns to the scene)",
       kQueued},
      {"testcard", {}, "show the test card on every module", kQueued},
      {"scenes", {}, "the scene library's scenes (names for `load`)", kAtOnce},
      {"panel", {}, "the browser control panel's URL, with its token", kAtOnce},
      {"shutdown", {}, "stop the daemon (a running calibration is cancelled)", kAtOnce},
  };
  return table;
}

}  // namespace parallax::daemon
