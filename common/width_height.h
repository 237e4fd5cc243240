#pragma once
// A size given on a command line as WIDTHxHEIGHT (1024x768): the module resolution of
// `parallax display` and `parallax-simhw`, the camera of `parallax simulate`, a view's size.
// Only the form is checked here; each caller checks the range it can use.

#include <string>
#include <string_view>

namespace parallax {

struct WidthHeight {
  int width = 0;
  int height = 0;
};

// Two decimal numbers of 1 to 5 digits joined by 'x'. Throws InputError naming `field` (the
// option, e.g. "--resolution") and quoting `text` otherwise.
WidthHeight parseWidthHeight(std::string_view text, const std::string& field);

}  // namespace parallax
