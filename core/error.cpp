#include <prt/error.h>

namespace prt::detail {

void check_failed(const char* expr, const char* file, int line, const std::string& values) {
  std::ostringstream os;
  os << "internal error: check failed: " << expr << values << " at " << file << ":" << line;
  throw InternalError(os.str());
}

}  // namespace prt::detail
