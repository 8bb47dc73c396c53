#include "options.h"

#include <prt/deform.h>
#include <prt/error.h>
#include <prt/wavelet.h>

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>

namespace prt::cli {

namespace {

// "why" in parentheses, or nothing.
std::string because(const std::string& why) { return why.empty() ? std::string() : " (" + why + ")"; }

// A double at the start of `s` (strtod: out of range is +-inf, not an
// exception); the characters read, 0 for none.
std::size_t number_prefix(const char* s, double& v) {
  char* end = nullptr;
  v = std::strtod(s, &end);
  return std::size_t(end - s);
}

// The whole of `s` as a double.
bool read_number(const std::string& s, double& v) {
  const std::size_t used = number_prefix(s.c_str(), v);
  return used != 0 && used == s.size();
}

// `s` as a whole number of digits only, at most `max`; false otherwise.
bool read_digits(std::string_view s, std::uint64_t max, std::uint64_t& v) {
  if (s.empty() || s.find_first_not_of("0123456789") != std::string_view::npos) return false;
  v = 0;
  for (char c : s) {
    const std::uint64_t d = std::uint64_t(c - '0');
    if (v > (max - d) / 10) return false;  // v * 10 + d > max, without overflow
    v = v * 10 + d;
  }
  return true;
}

// "" or why `text` is not three finite numbers a,b,c in [lo, hi].
std::string triple_problem(const std::string& text, const char* names, double lo, double hi, const std::string& why,
                           double out[3]) {
  const std::string expected = fmt::format("expected three numbers {}, got {}", names, show_text(text));
  std::size_t pos = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t used = number_prefix(text.c_str() + pos, out[i]);
    if (used == 0) return expected;
    pos += used;
    if (i < 2) {
      if (pos >= text.size() || text[pos] != ',') return expected;
      ++pos;
    }
  }
  if (pos != text.size()) return expected;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(out[i])) return "numbers must be finite, got " + show_text(text);
  for (int i = 0; i < 3; ++i)
    if (!(out[i] >= lo && out[i] <= hi))
      return fmt::format("each of {} must be {}{}, got {}", names,
                         std::isinf(hi) ? "at least " + show_number(lo)
                                        : fmt::format("from {} to {}", show_number(lo), show_number(hi)),
                         because(why), show_number(out[i]));
  return {};
}

}  // namespace

std::string show_number(double x) { return fmt::format("{:.6g}", x); }

std::string show_text(std::string_view s) {
  constexpr std::size_t kMax = 40;
  if (s.size() <= kMax) return fmt::format("'{}'", s);
  return fmt::format("'{}...' ({} characters)", s.substr(0, kMax), s.size());
}

CLI::Validator int_range(int lo, int hi, std::string why) {
  return CLI::Validator(
      [lo, hi, why](std::string& s) -> std::string {
        std::size_t used = 0;
        long v = 0;
        try {
          v = std::stol(s, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != s.size() || v < lo || v > hi)
          return fmt::format("must be a whole number from {} to {}{}, got {}", lo, hi, because(why), show_text(s));
        return {};
      },
      fmt::format("INT in [{}, {}]", lo, hi));
}

CLI::Validator positive_number() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        double v = 0;
        if (!read_number(s, v)) return "must be a positive number, got " + show_text(s);
        if (!(v > 0) || !std::isfinite(v)) return "must be a positive number, got " + show_number(v);
        return {};
      },
      "POSITIVE");
}

CLI::Validator number_range(double lo, double hi, bool lo_open, bool hi_open, std::string why) {
  const std::string range = fmt::format("{}{}, {}{}", lo_open ? "(" : "[", show_number(lo), show_number(hi),
                                        hi_open ? ")" : "]");
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        double v = 0;
        if (!read_number(s, v)) return fmt::format("must be a number in {}{}, got {}", range, because(why), show_text(s));
        const bool above = lo_open ? v > lo : v >= lo, below = hi_open ? v < hi : v <= hi;
        if (!std::isfinite(v) || !above || !below)
          return fmt::format("must be a number in {}{}, got {}", range, because(why), show_number(v));
        return {};
      },
      "NUMBER in " + range);
}

CLI::Validator finite_number() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        double v = 0;
        if (!read_number(s, v)) return "must be a number, got " + show_text(s);
        if (!std::isfinite(v)) return "must be a finite number, got " + show_number(v);
        return {};
      },
      "NUMBER");
}

CLI::Validator seed_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        std::uint64_t v = 0;
        if (!read_digits(s, std::numeric_limits<std::uint64_t>::max(), v))
          return fmt::format("must be a whole number from 0 to {} (digits only), got {}",
                             std::numeric_limits<std::uint64_t>::max(), show_text(s));
        return {};
      },
      "UINT64");
}

CLI::Validator size_value(int max) {
  return CLI::Validator(
      [max](std::string& s) -> std::string {
        const auto x = s.find('x');
        std::uint64_t w = 0, h = 0;
        if (x == std::string::npos || !read_digits(std::string_view(s).substr(0, x), std::uint64_t(max), w) ||
            !read_digits(std::string_view(s).substr(x + 1), std::uint64_t(max), h) || w < 1 || h < 1)
          return fmt::format("expected WxH with W and H whole numbers from 1 to {}, got {}", max, show_text(s));
        return {};
      },
      "WxH");
}

CLI::Validator triple_value(const char* names, double lo, double hi, std::string why) {
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        double v[3];
        return triple_problem(s, names, lo, hi, why, v);
      },
      names);
}

CLI::Validator cube_resolution() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        std::uint64_t r = 0;
        if (!read_digits(s, 1u << 20, r) || !wavelet::valid_resolution(int(r)))
          return "must be a power of two from 2 to 256 (16, 32, 64: the cube face size), got " + show_text(s);
        return {};
      },
      "POW2 in [2, 256]");
}

namespace {
// `text` in bytes, or -1 when it is no size.
double memory_size(const std::string& text) {
  double v = 0;
  const std::size_t used = number_prefix(text.c_str(), v);
  if (used == 0) return -1;
  const std::string unit = text.substr(used);
  static const std::pair<const char*, double> units[] = {
      {"", 1},         {"B", 1},          {"K", 1e3},           {"KB", 1e3},           {"M", 1e6},
      {"MB", 1e6},     {"G", 1e9},        {"GB", 1e9},          {"T", 1e12},           {"TB", 1e12},
      {"KiB", 1024.0}, {"MiB", 1048576.0}, {"GiB", 1073741824.0}, {"TiB", 1099511627776.0}};
  for (const auto& [name, scale] : units)
    if (unit == name) return std::isfinite(v) && v >= 0 ? v * scale : -1;
  return -1;
}
}  // namespace

CLI::Validator memory_size_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        const double b = memory_size(s);
        if (!(b >= 1e6 && b < 9.2e18))
          return "must be a size from 1M to 9E, like 8G, 512M or 4GiB (K, M, G, T: powers of 1000; KiB, MiB, GiB, "
                 "TiB: of 1024), got " + show_text(s);
        return {};
      },
      "SIZE");
}

std::size_t parse_memory_size(const std::string& text) { return std::size_t(memory_size(text)); }

CLI::Validator count_range(std::uint64_t lo, std::uint64_t hi, std::string why) {
  return CLI::Validator(
      [lo, hi, why](std::string& s) -> std::string {
        std::uint64_t v = 0;
        if (!read_digits(s, hi, v) || v < lo)
          return fmt::format("must be a whole number from {} to {}{}, got {}", lo, hi, because(why), show_text(s));
        return {};
      },
      fmt::format("UINT in [{}, {}]", lo, hi));
}

CLI::Validator int_one_of(std::initializer_list<int> values, std::string why) {
  std::vector<int> list(values.begin(), values.end());
  std::string expected, set;
  for (std::size_t i = 0; i < list.size(); ++i) {
    expected += (i == 0 ? "" : i + 1 == list.size() ? " or " : ", ") + std::to_string(list[i]);
    set += (i == 0 ? "" : ",") + std::to_string(list[i]);
  }
  return CLI::Validator(
      [list, expected, why](std::string& s) -> std::string {
        std::uint64_t v = 0;
        if (read_digits(s, std::uint64_t(std::numeric_limits<int>::max()), v))
          for (int n : list)
            if (std::uint64_t(n) == v) return {};
        return fmt::format("must be {}{}, got {}", expected, because(why), show_text(s));
      },
      "{" + set + "}");
}

CLI::Validator path_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string { return s.empty() ? "expected a path, got ''" : std::string(); }, "");
}

CLI::Validator deform_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        try {
          parse_deform(s);
          return {};
        } catch (const Error& e) {
          return e.what();
        }
      },
      "bend:ANGLE|twist:ANGLE");
}

CLI::Validator one_of(std::initializer_list<const char*> names) {
  std::vector<std::string> list(names.begin(), names.end());
  std::string expected;
  for (std::size_t i = 0; i < list.size(); ++i)
    expected += (i == 0 ? "" : i + 1 == list.size() ? " or " : ", ") + list[i];
  return CLI::Validator(
      [list, expected](std::string& s) -> std::string {
        for (const std::string& n : list)
          if (s == n) return {};
        return fmt::format("expected {}, got {}", expected, show_text(s));
      },
      "");
}

void parse_triple(const std::string& text, const char* option, double out[3]) {
  const double inf = std::numeric_limits<double>::infinity();
  if (const std::string p = triple_problem(text, "a,b,c", -inf, inf, {}, out); !p.empty())
    throw UsageError(std::string(option) + ": " + p);
}

void check_not_input(const std::string& option, const std::string& output, std::initializer_list<Input> inputs) {
  check_not_input(option, output, std::span<const Input>(inputs.begin(), inputs.size()));
}

void check_not_input(const std::string& option, const std::string& output, std::span<const Input> inputs) {
  for (const Input& in : inputs) {
    if (in.path.empty() || output.empty() || !same_file(output, in.path)) continue;
    throw UsageError(fmt::format("{} {}: is the input {}{}; prt does not write over its inputs (choose another "
                                 "output name)",
                                 option, output, in.name, in.path == output ? "" : " (" + in.path + ")"));
  }
}

void check_distinct_outputs(std::initializer_list<Output> outputs) {
  check_distinct_outputs(std::span<const Output>(outputs.begin(), outputs.size()));
}

void check_distinct_outputs(std::span<const Output> outputs) {
  for (std::size_t j = 1; j < outputs.size(); ++j)
    for (std::size_t i = 0; i < j; ++i) {
      const Output &a = outputs[i], &b = outputs[j];
      if (a.path.empty() || b.path.empty() || !same_file(a.path, b.path)) continue;
      throw UsageError(fmt::format("{} {}: is also the {} file{}; give each output its own name", b.option, b.path,
                                   a.option, a.path == b.path ? "" : " (" + a.path + ")"));
    }
}

}  // namespace prt::cli
