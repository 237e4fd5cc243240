#pragma once
// Faults written as text, for `parallax-simhw --fault` and tests: MODULE:KIND[:COUNT[:PARAM]]
// with KIND one of drop, flip, stall, slow, disconnect, crash (PROTOCOL.md, "Fault injection").
// Examples: "3:drop:2" (module 3 loses its next 2 chunks), "0:slow:10:5000" (the next 10
// chunks to module 0 take 5 ms each), "2:stall:8:5" (module 2 acknowledges 5 frames, then hangs
// on the next 8), "7:crash".

#include <string>

#include "hw/link/link_protocol.h"

namespace parallax::hw {

struct FaultSpec {
  int module = 0;
  Fault fault;
};

// Throws InputError (field "--fault") explaining what is wrong with the text.
FaultSpec parseFaultSpec(const std::string& text);

}  // namespace parallax::hw
