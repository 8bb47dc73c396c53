// Option values of the prt command: what a bad one is, and how a message
// shows it.
//
// Every bad option value exits 2 (README, "Exit status"). A value that can be
// judged alone is checked by a CLI11 validator below, while the command line
// is parsed, before any work; a rule across options (--env without
// --target-error, --samples with --basis wavelet) is a UsageError, thrown by
// the command before it reads any input. main.cpp maps both to 2. An option
// that does not fit the input file (--bands 9 for a 3-band transfer,
// --direct on a shadowed one) is the file's mismatch: a prt::Error naming the
// file, exit 1.
//
// Numbers in messages go through show_number ({:.6g}: "1e+308", "inf",
// "nan", never 309 digits); text the user typed through show_text (quoted,
// at most 40 characters).
#pragma once

#include <prt/io.h>

#include <prt/error.h>

#include <CLI/CLI.hpp>

#include <cstdint>
#include <initializer_list>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace prt::cli {

// A bad option value or combination: exit 2.
class UsageError : public Error {
 public:
  using Error::Error;
};

std::string show_number(double x);          // {:.6g}
std::string show_text(std::string_view s);  // 'text', or its first 40 characters and "..."

// Validators whose messages say what is expected and what was given; `why`
// (optional) says why the range is what it is, in the message. CLI11 puts
// the option's name in front: "--bands: must be a whole number from 1 to 64,
// got '100'".
CLI::Validator int_range(int lo, int hi, std::string why = {});
CLI::Validator positive_number();  // finite, > 0
// A finite number from lo to hi; lo_open / hi_open exclude that end.
CLI::Validator number_range(double lo, double hi, bool lo_open = false, bool hi_open = false, std::string why = {});
CLI::Validator finite_number();
// A seed: 0 to 2^64 - 1, digits only (no sign, no spaces, no wrap-around).
CLI::Validator seed_value();
// "WxH", digits only, each from 1 to `max`.
CLI::Validator size_value(int max);
// "a,b,c": three finite numbers, each from lo to hi (`names` names them in
// the message: "r,g,b", "yaw,pitch,roll").
CLI::Validator triple_value(const char* names, double lo = -std::numeric_limits<double>::infinity(),
                            double hi = std::numeric_limits<double>::infinity(), std::string why = {});
// A power of two from 2 to 256 (a wavelet cube face).
CLI::Validator cube_resolution();
// A size in bytes: a number with K, M, G or T (powers of 1000) or KiB, MiB,
// GiB or TiB (of 1024), or none (bytes); at least 1 MB, below 2^63 bytes.
CLI::Validator memory_size_value();
std::size_t parse_memory_size(const std::string& text);  // checked by memory_size_value()
// A count up to 2^64 - 1 (vertices, bytes): digits only, from lo to hi
// (no sign, no exponent, no spaces: "-1" wrapped to 2^64 - 1, "1e20" was
// CLI11's conversion error).
CLI::Validator count_range(std::uint64_t lo, std::uint64_t hi, std::string why = {});
// One of the whole numbers `values` (a choice of bits or sizes), digits only:
// "must be 16 or 32, got '64'" (CLI::IsMember took '' and said "1e20" alone).
CLI::Validator int_one_of(std::initializer_list<int> values, std::string why = {});
// A file or directory name, for every path option and argument of every
// command: not empty ('' named no file: `--ao-map ''` was taken as not
// given, `-o ''` failed after the work). Message: "expected a path, got ''".
CLI::Validator path_value();
// A deformation: bend:ANGLE or twist:ANGLE (prt::parse_deform's message).
CLI::Validator deform_value();
// One of `names` (message: "expected a, b or c, got 'x'").
CLI::Validator one_of(std::initializer_list<const char*> names);

// A name read by `parse` (one of prt's enum parsers: parse_transfer_mode,
// sh::parse_window, ...), whose prt::Error becomes the message:
// "--mode: unknown mode 'foo' (expected unshadowed, shadowed or interreflected)".
template <typename Parse>
CLI::Validator parsed_by(Parse parse) {
  return CLI::Validator(
      [parse](std::string& s) -> std::string {
        try {
          parse(s);
        } catch (const Error& e) {
          return e.what();
        }
        return {};
      },
      "");
}

// "a,b,c" -> three finite doubles; throws UsageError naming `option`.
void parse_triple(const std::string& text, const char* option, double out[3]);

// Calls f(); a prt::Error it throws is re-thrown as a UsageError with
// "option: " in front (an option's value, exit 2).
template <typename F>
auto for_option(const char* option, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error& e) {
    throw UsageError(std::string(option) + ": " + e.what());
  }
}

// The same for an option's file (an output directory that does not exist):
// a prt::Error, exit 1.
template <typename F>
auto for_path(const char* option, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error& e) {
    throw Error(std::string(option) + ": " + e.what());
  }
}

// An input of a command: what the message calls it ("MESH", "--env") and its path.
struct Input {
  std::string name, path;
};

// Whether two paths name the same file: prt::same_file (prt/io.h).
using prt::same_file;

// Throws UsageError when `output`, given to `option`, is one of `inputs`:
// the same file (std::filesystem::equivalent: also through a symbolic or
// hard link) or, when one does not exist yet, the same path. No command
// writes over its own input.
void check_not_input(const std::string& option, const std::string& output, std::initializer_list<Input> inputs);
void check_not_input(const std::string& option, const std::string& output, std::span<const Input> inputs);

// An output of a command: its option ("--output", "--ao-map") and its path
// ("" when not given).
struct Output {
  std::string option, path;
};

// Throws UsageError when two of `outputs` are the same file (same_file: the
// same path once made absolute and normal, "a.png" and "./a.png", or
// std::filesystem::equivalent where both exist, through a symbolic or hard
// link too): one would overwrite the other. Every command with more than one
// output calls it, next to check_not_input.
void check_distinct_outputs(std::initializer_list<Output> outputs);
void check_distinct_outputs(std::span<const Output> outputs);

}  // namespace prt::cli
