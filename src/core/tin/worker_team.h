/// \file worker_team.h
/// \brief A team of threads kept for one whole triangulation (internal).
///
/// Why not dw::parallelFor / parallelForDynamic: they start and join fresh threads on every call, and
/// the TIN has about ten parallel passes. On 16 cores that is 150 thread starts and joins per call,
/// several milliseconds of serial work in the caller at 2M points, where the whole 16-thread run
/// takes ~0.15 s. The team starts its threads once; each pass then costs one wake-up.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "pcl_delaunay_walk/core/parallel_for.h"

namespace dw {
namespace tin {
namespace detail {

class WorkerTeam {
 public:
  /// Starts threads - 1 helpers; the calling thread is worker 0. A helper that cannot be started
  /// (resource limits) is not an error: the team is smaller.
  explicit WorkerTeam(unsigned threads) {
    helpers_.reserve(threads > 1 ? threads - 1 : 0);
    for (unsigned w = 1; w < threads; ++w) {
      try {
        helpers_.emplace_back([this, w]() { helperLoop(w); });
      } catch (...) {
        break;
      }
    }
  }
  ~WorkerTeam() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : helpers_) t.join();
  }
  WorkerTeam(const WorkerTeam&) = delete;
  WorkerTeam& operator=(const WorkerTeam&) = delete;

  /// Workers in the team, the caller included.
  unsigned size() const { return static_cast<unsigned>(helpers_.size()) + 1; }

  /// Runs body(worker) once on every worker (the caller as worker 0) and returns when all have
  /// finished; rethrows the first exception caught.
  void everyWorker(const std::function<void(unsigned)>& body) {
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
    dw::detail::TaskClaims claims;
    everyWorker([&](unsigned) { claims.drain(count, fn); });
    claims.rethrow();
  }

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
  std::exception_ptr error_;
};

}  // namespace detail
}  // namespace tin
}  // namespace dw
