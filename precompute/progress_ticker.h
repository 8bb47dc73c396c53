// precompute/progress_ticker.h - progress from worker threads (internal to prt::precompute).
#pragma once

#include <prt/error.h>
#include <prt/progress.h>

#include <atomic>
#include <cstddef>
#include <mutex>

namespace prt::detail {

// Workers add the work they have finished; whichever of them takes the lock
// (the others go on without waiting) reports the count done so far, read
// while it holds the lock, so the callback sees a non-decreasing count and is
// called from one thread at a time. (Reading the count before taking the lock
// let a thread report an older count after another had reported a newer one:
// Reference.ProgressAndCancellation failed 7 runs in 900.) Once the callback
// returns false the ticker stays cancelled.
class ProgressTicker {
 public:
  ProgressTicker(const Progress& p, std::size_t total, const char* phase) : p_(p), total_(total), phase_(phase) {}

  // The callback at 0 of the total; throws Error("cancelled") when it says stop.
  void start() {
    if (p_ && !p_(0, total_, phase_)) throw Error("cancelled");
  }
  // Adds n finished units; false once the callback asked to stop.
  bool tick(std::size_t n) {
    if (!p_) return true;
    done_.fetch_add(n, std::memory_order_relaxed);
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (lock.owns_lock() && !cancelled_) {
      const std::size_t now = done_.load(std::memory_order_relaxed);
      if (now > reported_) {
        reported_ = now;
        if (!p_(now, total_, phase_)) cancelled_ = true;
      }
    }
    return !cancelled_;
  }
  bool cancelled() const { return cancelled_; }
  // After the workers: throws Error("cancelled") if the callback asked to
  // stop, else reports the whole total.
  void finish() {
    if (cancelled_) throw Error("cancelled");
    if (p_ && !p_(total_, total_, phase_)) throw Error("cancelled");
  }

 private:
  const Progress& p_;
  std::size_t total_;
  const char* phase_;
  std::atomic<std::size_t> done_{0};
  std::mutex mutex_;           // held by the reporting thread
  std::size_t reported_ = 0;   // the last count reported (under mutex_)
  std::atomic<bool> cancelled_{false};
};

}  // namespace prt::detail
