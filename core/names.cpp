// The message of parse_enum (prt/names.h).
#include <prt/names.h>

#include <prt/error.h>

#include <fmt/format.h>

#include <string>

namespace prt::detail {

void throw_unknown_name(std::string_view what, std::string_view text, std::span<const std::string_view> names) {
  std::string list;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) list += i + 1 == names.size() ? " or " : ", ";
    list += names[i];
  }
  throw Error(fmt::format("unknown {} '{}' (expected {})", what, text, list));
}

}  // namespace prt::detail
