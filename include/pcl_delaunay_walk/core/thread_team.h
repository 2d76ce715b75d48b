/// \file thread_team.h
/// \brief A team of threads kept for a whole job. parallelFor and parallelForDynamic run on it, while a
/// ThreadTeam::Scope lives on the calling thread, instead of starting threads on every call.
///
/// Why: each parallelFor starts and joins fresh threads, 36-47 us with 2 workers and 378-457 us with
/// 16 (docs/benchmarks.md, "Session 20"). The 3D builder makes about five such calls per parallel pass
/// and up to 13 passes on 16 threads; the TIN has about ten passes, several milliseconds of serial work
/// in the caller at 2M points, where its whole 16-thread run takes ~0.15 s. A team starts its threads
/// once; each loop then costs one wake-up. Which indices a worker handles does not change (the loops'
/// blocks depend only on the count and the worker number), so neither does any result.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "pcl_delaunay_walk/core/parallel_for.h"

namespace dw {

class ThreadTeam final : public detail::LoopRunner {
 public:
  /// Starts threads - 1 helpers; the calling thread is worker 0. A helper that cannot be started
  /// (resource limits) is not an error: the team is smaller.
  explicit ThreadTeam(unsigned threads) {
    helpers_.reserve(threads > 1 ? threads - 1 : 0);
    for (unsigned w = 1; w < threads; ++w) {
      try {
        helpers_.emplace_back([this, w]() { helperLoop(w); });
      } catch (...) {
        break;
      }
    }
  }
  ~ThreadTeam() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : helpers_) t.join();
  }
  ThreadTeam(const ThreadTeam&) = delete;
  ThreadTeam& operator=(const ThreadTeam&) = delete;

  /// Workers in the team, the caller included.
  unsigned size() const { return static_cast<unsigned>(helpers_.size()) + 1; }

  /// Runs body(worker) once on every worker (the caller as worker 0) and returns when all have
  /// finished; rethrows the first exception caught. Called from the thread that made the team only.
  void everyWorker(const std::function<void(unsigned)>& body) {
    struct Busy {  // a loop in `body` on this thread cannot use the team meanwhile (tryRun)
      bool& flag;
      explicit Busy(bool& f) : flag(f) { flag = true; }
      ~Busy() { flag = false; }
    } busy(busy_);
    std::exception_ptr error;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      job_ = &body;
      running_ = static_cast<unsigned>(helpers_.size());
      error_ = nullptr;
      ++generation_;
    }
    wake_.notify_all();
    try {
      body(0);
    } catch (...) {
      error = std::current_exception();
    }
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this]() { return running_ == 0; });
    job_ = nullptr;
    if (!error) error = error_;
    if (error) std::rethrow_exception(error);
  }

  /// Calls fn(i) for every i < count, each worker taking the next unclaimed index when it finishes
  /// one (uneven tasks balance). Every task runs even when one throws; the first exception is
  /// rethrown at the end.
  template <typename F>
  void forEach(std::size_t count, F&& fn) {
    if (count == 0) return;
    if (count == 1 || helpers_.empty()) return runEachInOrder(count, fn);
    detail::TaskClaims claims;
    everyWorker([&](unsigned) { claims.drain(count, fn); });
    claims.rethrow();
  }

  /// The loops' entry (detail::LoopRunner): body(w) for every w < workers, unless the team is too
  /// small or already running a loop (a loop nested in one of its bodies starts threads as before).
  bool tryRun(unsigned workers, const std::function<void(unsigned)>& body) override {
    if (busy_ || workers > size()) return false;
    everyWorker([&](unsigned w) {
      if (w < workers) body(w);
    });
    return true;
  }

  /// While it lives, parallelFor and parallelForDynamic called on this thread run on the team.
  class Scope {
   public:
    explicit Scope(ThreadTeam& team) : previous_(detail::loopRunnerOfThisThread()) {
      detail::loopRunnerOfThisThread() = &team;
    }
    ~Scope() { detail::loopRunnerOfThisThread() = previous_; }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    detail::LoopRunner* previous_;
  };

 private:
  void helperLoop(unsigned w) {
    std::size_t seen = 0;
    for (;;) {
      const std::function<void(unsigned)>* job = nullptr;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&]() { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        job = job_;
      }
      std::exception_ptr error;
      try {
        (*job)(w);
      } catch (...) {
        error = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(mutex_);
      if (error && !error_) error_ = error;
      if (--running_ == 0) done_.notify_one();
    }
  }

  std::vector<std::thread> helpers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(unsigned)>* job_ = nullptr;
  std::size_t generation_ = 0;
  unsigned running_ = 0;
  bool stop_ = false;
  bool busy_ = false;  // everyWorker is running (read and written by the owning thread only)
  std::exception_ptr error_;
};

}  // namespace dw
