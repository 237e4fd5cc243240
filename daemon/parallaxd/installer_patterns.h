#pragma once
// What installers put on the modules: `identify` (a module shows its own number, large, so a
// person behind the screen can tell which projector is which) and `testcard` (a crosshatch
// over colour bars, to check focus, geometry and colour of every module at a glance).
// Both are drawn in module pixels and mirrored like the module's image (rear projection), so
// digits read the right way round from the viewers' side.

#include "tracer/frame.h"

namespace parallax::daemon {

Frame identifyFrame(int width, int height, int moduleIndex, bool mirrored);
Frame testCardFrame(int width, int height, int moduleIndex, bool mirrored);

}  // namespace parallax::daemon
