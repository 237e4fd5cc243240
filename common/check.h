#pragma once
// Our own invariants (not user input): a failed check is a bug, reported with both values.

#include <sstream>
#include <stdexcept>

namespace parallax {

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

}  // namespace parallax

#define PARALLAX_CHECK(cond)                                                                   \
  do {                                                                                         \
    if (!(cond))                                                                               \
      throw ::parallax::InternalError(std::string(__FILE__) + ":" + std::to_string(__LINE__) + \
                                      ": check failed: " #cond);                               \
  } while (0)

#define PARALLAX_CHECK_OP(a, op, b)                                                             \
  do {                                                                                          \
    const auto& check_a_ = (a);                                                                 \
    const auto& check_b_ = (b);                                                                 \
    if (!(check_a_ op check_b_)) {                                                              \
      std::ostringstream check_msg_;                                                            \
      check_msg_ << __FILE__ << ":" << __LINE__ << ": check failed: " #a " " #op " " #b << " (" \
                 << check_a_ << " vs " << check_b_ << ")";                                      \
      throw ::parallax::InternalError(check_msg_.str());                                        \
    }                                                                                           \
  } while (0)
