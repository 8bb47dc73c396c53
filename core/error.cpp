#include <prt/error.h>

#include <fmt/format.h>

namespace prt::detail {

void check_failed(const char* expr, const char* file, int line, const std::string& values) {
  throw InternalError(fmt::format("internal error: check failed: {}{} at {}:{}", expr, values, file, line));
}

}  // namespace prt::detail
