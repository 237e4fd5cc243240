#include "calibration/simulation/sweep_setups.h"

#include <utility>

#include "calibration/display/display_presets.h"

namespace parallax {

std::vector<SweepSetup> sweepSetups() {
  std::vector<SweepSetup> out;
  auto add = [&](std::string name, auto&& change) {
    SweepSetup s;
    s.name = std::move(name);
    change(s);
    out.push_back(s);
  };
  add("base: 5 stations 0.3 px", [](SweepSetup&) {});
  add("noise 0.1 px", [](SweepSetup& s) { s.noisePx = 0.1; });
  add("noise 1 px", [](SweepSetup& s) { s.noisePx = 1.0; });
  add("noise 2 px", [](SweepSetup& s) { s.noisePx = 2.0; });
  add("3 stations", [](SweepSetup& s) { s.stations = 3; });
  add("2 stations", [](SweepSetup& s) { s.stations = 2; });
  add("linear screen", [](SweepSetup& s) { s.truth = s.nominal = ScreenTransfer::kLinear; });
  add("linear truth, conical nominal", [](SweepSetup& s) { s.truth = ScreenTransfer::kLinear; });
  add("conical truth, linear nominal", [](SweepSetup& s) { s.nominal = ScreenTransfer::kLinear; });
  add("mismatch at 1 px", [](SweepSetup& s) {
    s.truth = ScreenTransfer::kLinear;
    s.noisePx = 1.0;
  });
  add("observer line 1 m", [](SweepSetup& s) {
    s.observerM = 1.0;
    s.spanM = 1.6;
  });
  add("observer line 6 m", [](SweepSetup& s) { s.observerM = 6.0; });
  add("observer line 10 m", [](SweepSetup& s) { s.observerM = 10.0; });
  add("narrow span 1 m", [](SweepSetup& s) { s.spanM = 1.0; });
  add("wide span 5 m", [](SweepSetup& s) { s.spanM = 5.0; });
  add("2 modules unseen", [](SweepSetup& s) { s.unseen = {3, 12}; });
  add("72 modules", [](SweepSetup& s) { s.modules = 72; });
  return out;
}

DisplayModel sweepNominal(const SweepSetup& setup) {
  NominalDisplayOptions options;
  options.preset = setup.modules == 16 ? "demo" : "default";
  if (setup.modules != 16) {
    options.modules = setup.modules;
    options.width = 256;
    options.height = 192;
  }
  options.transfer = setup.nominal;
  DisplayModel model = makeNominalDisplay(options);
  model.observer.z = setup.observerM;
  return model;
}

}  // namespace parallax
