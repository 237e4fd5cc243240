// Prints the module count of the built-in `demo` display: proof that an installed Parallax
// compiles (headers) and links (static libraries and their dependencies) from outside.
#include <cstdio>

#include "calibration/display/display_presets.h"

int main() {
  const parallax::DisplayModel demo = parallax::resolveDisplay("demo");
  std::printf("demo display: %zu modules\n", demo.modules.size());
  return demo.modules.empty() ? 1 : 0;
}
