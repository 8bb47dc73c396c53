// prt/names.h - one way to name and parse an enum.
//
// Each enum with names has one table of {value, name} entries, in the order
// its names are listed, and its name/parse functions are these two templates
// over that table:
//
//   constexpr EnumName<Window> kWindowNames[] = {
//       {Window::None, "none"}, {Window::Hanning, "hanning"}, {Window::Hanning, "hann", true}, ...};
//   std::string_view window_name(Window w) { return enum_name(kWindowNames, w); }
//   Window parse_window(std::string_view s) { return parse_enum(kWindowNames, s, "window"); }
//
// parse_enum throws prt::Error "unknown WHAT 'TEXT' (expected a, b or c)",
// listing the names that are not aliases.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

namespace prt {

template <typename E>
struct EnumName {
  E value;
  std::string_view name;
  bool alias = false;  // accepted by parse_enum, but neither listed nor returned by enum_name
};

namespace detail {
// Throws prt::Error "unknown WHAT 'TEXT' (expected a, b or c)".
[[noreturn]] void throw_unknown_name(std::string_view what, std::string_view text,
                                     std::span<const std::string_view> names);
}  // namespace detail

// The name of `value`: its first entry that is not an alias; "?" when the
// table has none (a value outside the enum).
template <typename E, std::size_t N>
constexpr std::string_view enum_name(const EnumName<E> (&table)[N], E value) {
  for (const EnumName<E>& e : table)
    if (e.value == value && !e.alias) return e.name;
  return "?";
}

// The value named `text` (names and aliases, exact match). Throws prt::Error
// "unknown WHAT 'TEXT' (expected ...)" otherwise.
template <typename E, std::size_t N>
E parse_enum(const EnumName<E> (&table)[N], std::string_view text, std::string_view what) {
  for (const EnumName<E>& e : table)
    if (e.name == text) return e.value;
  std::string_view names[N];
  std::size_t n = 0;
  for (const EnumName<E>& e : table)
    if (!e.alias) names[n++] = e.name;
  detail::throw_unknown_name(what, text, std::span<const std::string_view>(names, n));
}

}  // namespace prt
