#include "progress_bar.h"

#include <sys/resource.h>

#include <prt/precompute.h>

#include <fmt/core.h>
#include <pthread.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <thread>

namespace prt::cli {

namespace {
std::atomic<bool> g_interrupted{false};
void on_sigint(int) { g_interrupted = true; }
int g_depth = 0;  // InterruptScopes alive (the main thread creates them)
struct sigaction g_previous {};
}  // namespace

InterruptScope::InterruptScope() {
  if (g_depth++ > 0) return;
  g_interrupted = false;
  struct sigaction sa {};
  sa.sa_handler = on_sigint;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, &g_previous);
}

InterruptScope::~InterruptScope() {
  if (--g_depth == 0) sigaction(SIGINT, &g_previous, nullptr);
}

bool InterruptScope::interrupted() { return g_interrupted; }

std::size_t peak_resident_bytes() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return std::size_t(ru.ru_maxrss) * 1024;
}

ProgressBar::ProgressBar(bool quiet, std::size_t memory_limit)
    : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0), memory_limit_(memory_limit) {}

namespace {
// " 1.23/4.00 GB": resident memory now against the limit; "" without one.
std::string memory_text(std::size_t limit) {
  if (limit == 0) return {};
  return fmt::format(" {:.2f}/{:.2f} GB", double(resident_memory()) / 1e9, double(limit) / 1e9);
}
}  // namespace

ProgressBar::~ProgressBar() {
  if (tty_ && !quiet_ && last_percent_ >= 0) fmt::print(stderr, "\n");
}

void Outputs::test_pause() const {
  static const long ms = [] {
    const char* env = std::getenv("PRT_TEST_PAUSE_BEFORE_RENAME");
    return env && *env ? std::strtol(env, nullptr, 10) : 0L;
  }();
  if (ms <= 0 || interrupted()) return;
  fmt::print(stderr, "PRT_TEST_PAUSE_BEFORE_RENAME: {} file(s) written to temporary names, not renamed\n",
             staged_.size());
  std::fflush(stderr);
  // The flag, not EINTR: the handler may run on another thread.
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  while (!interrupted() && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
}

int Outputs::commit() {
  sigset_t block, old;
  sigemptyset(&block);
  for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&block, s);
  pthread_sigmask(SIG_BLOCK, &block, &old);
  struct Restore {
    sigset_t& mask;
    ~Restore() { pthread_sigmask(SIG_SETMASK, &mask, nullptr); }
  } restore{old};
  if (interrupted()) {
    staged_.discard();
    fmt::print(stderr, "prt {}: interrupted; nothing written\n", command_);
    return 130;
  }
  staged_.commit();
  return 0;
}

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
    fmt::print(stderr, "\r{:<8} [{}{}] {:3d}% {}/{}  {:.1f}s, ETA {:.1f}s{}  ", phase, std::string(filled, '#'),
               std::string(kWidth - filled, ' '), percent, done, total, elapsed, eta, memory_text(memory_limit_));
    last_percent_ = percent;
  } else if (last_percent_ < 0 || percent / 25 != last_percent_ / 25 || (done == total && last_percent_ != 100)) {
    // Not a terminal (a log): a line at 0, 25, 50, 75 and 100%.
    fmt::print(stderr, "{}: {}% ({}/{}), {:.1f}s elapsed{}\n", phase, percent, done, total, elapsed,
               memory_text(memory_limit_));
    last_percent_ = percent;
  }
  std::fflush(stderr);
  return true;
}

}  // namespace prt::cli
