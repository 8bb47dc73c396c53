// A progress bar with an ETA on stderr, and Ctrl-C as a request to stop.
//
// While a ProgressBar lives, SIGINT sets a flag instead of killing the
// process; callback() returns false once it is set, the library throws
// prt::Error("cancelled"), and the command exits 130 without writing any
// output (outputs are written only after the work is done, atomically).
#pragma once

#include <prt/error.h>
#include <prt/progress.h>

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <type_traits>

namespace prt::cli {

class ProgressBar {
 public:
  explicit ProgressBar(bool quiet);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  Progress callback();
  static bool interrupted();

 private:
  bool update(std::size_t done, std::size_t total, const char* phase);

  bool quiet_, tty_;
  std::string phase_;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point phase_start_, last_draw_;
};

// Runs compute(progress callback) under a ProgressBar. Returns its result, or
// std::nullopt after printing "prt COMMAND: interrupted; nothing written"
// when Ctrl-C cancelled it (the caller then exits 130).
template <typename F>
auto run_with_progress(bool quiet, const char* command, F&& compute)
    -> std::optional<std::invoke_result_t<F, Progress>> {
  {
    ProgressBar bar(quiet);
    try {
      return compute(bar.callback());
    } catch (const Error&) {
      if (!ProgressBar::interrupted()) throw;
    }
  }
  std::fprintf(stderr, "prt %s: interrupted; nothing written\n", command);
  return std::nullopt;
}

}  // namespace prt::cli
