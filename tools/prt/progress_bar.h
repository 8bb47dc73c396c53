// A progress bar with an ETA on stderr, Ctrl-C as a request to stop, and a
// command's outputs written all at once or not at all.
//
// While an InterruptScope lives (a ProgressBar and an Outputs hold one; they
// nest), SIGINT sets a flag instead of killing the process. A ProgressBar's
// callback() returns false once it is set, the library throws
// prt::Error("cancelled"), and the command exits 130 without writing any
// output. Outputs stages what a command writes (prt::StagedWrites): each file
// goes to its temporary name, and commit() renames them all, or, after
// Ctrl-C, removes them and the command exits 130. So Ctrl-C during the
// compute, during the write step or between the frames of a sequence leaves
// the old files and no temporary (".NAME.tmpPID-N.EXT").
#pragma once

#include <prt/error.h>
#include <prt/io.h>
#include <prt/progress.h>

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <type_traits>

namespace prt::cli {

// SIGINT sets a flag while one lives. The outermost installs the handler
// (SA_RESTART: other system calls go on) and clears the flag; its destructor
// puts the previous handler back.
class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

  static bool interrupted();
};

// Peak resident memory of this process so far, in bytes (getrusage's
// ru_maxrss, KiB on Linux).
std::size_t peak_resident_bytes();

class ProgressBar {
 public:
  // memory_limit > 0: the bar also shows the process's resident memory
  // against it ("1.23/4.00 GB").
  explicit ProgressBar(bool quiet, std::size_t memory_limit = 0);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  Progress callback();
  static bool interrupted() { return InterruptScope::interrupted(); }

 private:
  bool update(std::size_t done, std::size_t total, const char* phase);

  InterruptScope interrupts_;
  bool quiet_, tty_;
  std::size_t memory_limit_ = 0;
  std::string phase_;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point phase_start_, last_draw_;
};

// Runs compute(progress callback) under a ProgressBar. Returns its result, or
// std::nullopt after printing "prt COMMAND: interrupted; nothing written"
// when Ctrl-C cancelled it (the caller then exits 130).
template <typename F>
auto run_with_progress(bool quiet, const char* command, F&& compute, std::size_t memory_limit = 0)
    -> std::optional<std::invoke_result_t<F, Progress>> {
  {
    ProgressBar bar(quiet, memory_limit);
    try {
      return compute(bar.callback());
    } catch (const Error&) {
      if (!ProgressBar::interrupted()) throw;
    }
  }
  std::fprintf(stderr, "prt %s: interrupted; nothing written\n", command);
  return std::nullopt;
}

// The outputs of one command run. Create it before the work Ctrl-C should
// stop cleanly (it holds an InterruptScope), write every output inside
// write(), and return commit():
//
//   Outputs out("precompute");
//   ... compute (run_with_progress) ...
//   out.write([&] { write_transfer(path, t); });
//   return out.commit();  // 0, or 130 after Ctrl-C
//
// An exception or an early return leaves nothing: the destructor removes
// the temporaries of what was not committed.
class Outputs {
 public:
  explicit Outputs(const char* command) : command_(command) {}

  // Runs f() with this thread's write_atomically calls staged here.
  //
  // Test hook: with PRT_TEST_PAUSE_BEFORE_RENAME=MS in the environment, once
  // f() has written its temporaries, prints "PRT_TEST_PAUSE_BEFORE_RENAME: N
  // file(s) written to temporary names, not renamed" to stderr and waits up
  // to MS milliseconds, or until Ctrl-C: the window in which a test
  // interrupts the write step. Nothing else reads it.
  template <typename F>
  void write(F&& f) {
    {
      StagedWrites::Scope scope(staged_);
      f();
    }
    test_pause();
  }
  static bool interrupted() { return InterruptScope::interrupted(); }
  std::size_t staged() const { return staged_.size(); }

  // With SIGINT, SIGTERM and SIGHUP blocked on this thread: after Ctrl-C,
  // removes the temporaries, prints "prt COMMAND: interrupted; nothing
  // written" and returns 130; else renames every file into place (throws
  // prt::Error naming the file, leaving nothing of the run, if a rename
  // fails) and returns 0. A Ctrl-C after that point finds the outputs whole.
  int commit();

 private:
  void test_pause() const;  // PRT_TEST_PAUSE_BEFORE_RENAME

  InterruptScope interrupts_;  // first in, last out: the temporaries go before the handler
  StagedWrites staged_;
  const char* command_;
};

}  // namespace prt::cli
