#include "progress.h"

#include <fmt/core.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>

namespace prt::cli {

namespace {
std::atomic<bool> g_interrupted{false};
void on_sigint(int) { g_interrupted = true; }
using Handler = void (*)(int);
Handler g_previous = SIG_DFL;
}  // namespace

ProgressBar::ProgressBar(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {
  g_interrupted = false;
  g_previous = std::signal(SIGINT, on_sigint);
}

ProgressBar::~ProgressBar() {
  std::signal(SIGINT, g_previous);
  if (tty_ && !quiet_ && last_percent_ >= 0) fmt::print(stderr, "\n");
}

bool ProgressBar::interrupted() { return g_interrupted; }

Progress ProgressBar::callback() {
  return [this](std::size_t done, std::size_t total, const char* phase) { return update(done, total, phase); };
}

bool ProgressBar::update(std::size_t done, std::size_t total, const char* phase) {
  if (g_interrupted) return false;
  if (quiet_ || total == 0) return true;
  const auto now = std::chrono::steady_clock::now();
  if (phase_ != phase) {
    if (tty_ && last_percent_ >= 0) fmt::print(stderr, "\n");
    phase_ = phase;
    phase_start_ = now;
    last_percent_ = -1;
  }
  const int percent = int(100.0 * double(done) / double(total));
  const double elapsed = std::chrono::duration<double>(now - phase_start_).count();
  const double eta = done > 0 ? elapsed * double(total - done) / double(done) : 0.0;
  if (tty_) {
    // Redraw at most 10 times a second, and at the end.
    if (done < total && now - last_draw_ < std::chrono::milliseconds(100)) return true;
    last_draw_ = now;
    constexpr int kWidth = 30;
    const int filled = int(kWidth * double(done) / double(total));
    fmt::print(stderr, "\r{:<8} [{}{}] {:3d}% {}/{}  {:.1f}s, ETA {:.1f}s  ", phase, std::string(filled, '#'),
               std::string(kWidth - filled, ' '), percent, done, total, elapsed, eta);
    last_percent_ = percent;
  } else if (percent / 25 != last_percent_ / 25 || (done == total && last_percent_ != 100)) {
    // Not a terminal (a log): a line at 0, 25, 50, 75 and 100%.
    fmt::print(stderr, "{}: {}% ({}/{}), {:.1f}s elapsed\n", phase, percent, done, total, elapsed);
    last_percent_ = percent;
  }
  std::fflush(stderr);
  return true;
}

}  // namespace prt::cli
