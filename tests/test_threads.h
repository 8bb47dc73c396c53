// Witnesses that two or more threads really shared a computation's work, for
// the determinism tests (tests/README.md, "Determinism across threads"): a
// comparison of one thread against "many" proves nothing when the job was
// small enough to run as one task.
#pragma once

#include <prt/progress.h>

#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>

#include <chrono>
#include <cstddef>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace prt::test {

// A progress callback that records, per phase, the threads it was called
// from. prt's computations report from the worker that has just finished a
// block (precompute/progress_ticker.h), so two threads seen in a phase mean
// two threads computed blocks of it. The calls at 0 and at the total come
// from the calling thread before and after the work, and are not counted.
class ThreadWitness {
 public:
  Progress progress() {
    return [this](std::size_t done, std::size_t total, const char* phase) {
      if (done > 0 && done < total) {
        std::lock_guard<std::mutex> lock(mutex_);
        seen_[phase].insert(std::this_thread::get_id());
      }
      return true;
    };
  }
  // The fewest threads seen in any of `phases` (0 if one was never reported).
  std::size_t fewest(const std::vector<const char*>& phases) const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t least = ~std::size_t(0);
    for (const char* p : phases) {
      const auto it = seen_.find(p);
      least = std::min(least, it == seen_.end() ? std::size_t(0) : it->second.size());
    }
    return least;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::set<std::thread::id>> seen_;
};

// Calls run(progress) until the progress reports of each of `phases` came
// from two or more threads and returns the last result; `threads` receives
// the fewest threads seen in a phase on that call (the test asserts >= 2).
// A run of a few milliseconds may finish before a sleeping worker is woken
// on a loaded machine: CI's 2 cores running two test processes at once gave
// five runs in a row on one thread (Reference.SameBitsForAnyThreadCount,
// 10 ms a run). So it tries up to 20 times, pausing a little longer after
// each miss (10, 20, ... ms: under 2 s in all) to give the other process's
// burst time to pass.
template <typename Run>
auto until_shared(const Run& run, const std::vector<const char*>& phases, std::size_t& threads) {
  constexpr int kAttempts = 20;
  threads = 0;
  for (int attempt = 0;; ++attempt) {
    ThreadWitness witness;
    auto result = run(witness.progress());
    threads = witness.fewest(phases);
    if (threads >= 2 || attempt + 1 == kAttempts) return result;
    std::this_thread::sleep_for(std::chrono::milliseconds(10 * (attempt + 1)));
  }
}

// Counts the TBB worker threads that joined `arena` while it observes (for
// work with no progress callback, e.g. relighting): a worker joins an arena
// only to take its tasks.
class WorkerWitness : public tbb::task_scheduler_observer {
 public:
  explicit WorkerWitness(tbb::task_arena& arena) : tbb::task_scheduler_observer(arena) { observe(true); }
  ~WorkerWitness() override { observe(false); }
  void on_scheduler_entry(bool is_worker) override {
    if (!is_worker) return;
    std::lock_guard<std::mutex> lock(mutex_);
    workers_.insert(std::this_thread::get_id());
  }
  std::size_t workers() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return workers_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::set<std::thread::id> workers_;
};

}  // namespace prt::test
