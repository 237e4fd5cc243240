#pragma once
// The message of the InputError `f` throws ("" when it throws none): what a user would read.

#include <functional>
#include <string>

#include "common/input_error.h"

namespace parallax::test {

inline std::string inputErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace parallax::test
