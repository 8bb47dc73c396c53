// prt/error.h - the two error paths of prt.
//
// * prt::Error: a user error (bad file, bad argument). The message names the
//   file or option and what is wrong; the command line prints it and exits
//   non-zero. Library code throws it and never calls exit().
// * PRT_CHECK: a contract violation inside prt (a bug). It throws
//   prt::InternalError with the expression, location and values.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace prt {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace detail {
[[noreturn]] void check_failed(const char* expr, const char* file, int line, const std::string& values);

template <typename A, typename B>
std::string format_pair(const A& a, const B& b) {
  std::ostringstream os;
  os.precision(17);
  os << " (" << a << " vs " << b << ")";
  return os.str();
}
}  // namespace detail

}  // namespace prt

#define PRT_CHECK(cond)                                                   \
  do {                                                                    \
    if (!(cond)) ::prt::detail::check_failed(#cond, __FILE__, __LINE__, ""); \
  } while (0)

#define PRT_CHECK_OP(a, op, b)                                                       \
  do {                                                                               \
    const auto& prt_a_ = (a);                                                        \
    const auto& prt_b_ = (b);                                                        \
    if (!(prt_a_ op prt_b_))                                                         \
      ::prt::detail::check_failed(#a " " #op " " #b, __FILE__, __LINE__,             \
                                  ::prt::detail::format_pair(prt_a_, prt_b_));       \
  } while (0)
