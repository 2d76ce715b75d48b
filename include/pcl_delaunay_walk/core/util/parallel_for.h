/// \file parallel_for.h
/// \brief The core's two parallel loops on std::thread (no OpenMP/TBB dependency), and the team of
/// threads they run on:
///   - parallelFor: static contiguous blocks. Which indices one worker handles depends only on n and
///     the worker count, so per-block state (e.g. statistics) and every result built from it are the
///     same on every run; results written per index are the same for any worker count.
///   - parallelForDynamic: tasks handed out one at a time from a shared counter, for tasks of uneven
///     cost (strips, merges, chunks) whose results are written per task index.
///   - ThreadTeam: threads kept for a whole job. While a ThreadTeam::Scope lives on the calling
///     thread, both loops run on the team's threads instead of starting and joining threads on every
///     call (tens of microseconds with 2 workers, hundreds with 16; the 3D builder and the TIN make
///     dozens of such calls per job). The blocks do not depend on who runs them, so neither does any
///     result.
/// Both loops run the calling thread as worker 0 and rethrow the first exception once every worker
/// has finished, so no worker outlives the call.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace dw {

/// Worker threads to use for `requested` (0: hardware concurrency, at least 1).
inline unsigned resolveThreads(unsigned requested) {
  return requested ? requested : std::max(1u, std::thread::hardware_concurrency());
}

/// Number of workers for n items: resolveThreads(requested), but no more than one per `min_block`
/// items, since starting a thread costs about as much as a few thousand cheap iterations.
inline unsigned workerCount(std::size_t n, unsigned requested, std::size_t min_block = 4096) {
  const std::size_t by_size = std::max<std::size_t>(1, n / std::max<std::size_t>(1, min_block));
  return static_cast<unsigned>(std::min<std::size_t>(resolveThreads(requested), by_size));
}

namespace detail {
/// What parallelFor and parallelForDynamic run their workers on instead of fresh threads, when one is
/// installed on the calling thread (dw::ThreadTeam::Scope, below).
class LoopRunner {
 public:
  /// Runs body(w) for every w < workers, w = 0 on the calling thread, and returns true; or runs nothing
  /// and returns false when it cannot take them now (too few threads, or a loop already running).
  virtual bool tryRun(unsigned workers, const std::function<void(unsigned)>& body) = 0;

 protected:
  ~LoopRunner() = default;
};
/// The calling thread's runner (null: none; each loop starts its own threads).
LoopRunner*& loopRunnerOfThisThread();
}  // namespace detail

/// Calls body(begin, end, worker) once for each of `workers` contiguous blocks of [0, n): block w is
/// [w c, min(n, (w + 1) c)) with c = ceil(n / workers). Rethrows the first exception (by worker index)
/// after all workers have finished.
template <typename Body>
void parallelFor(std::size_t n, unsigned workers, Body&& body) {
  if (workers <= 1 || n < 2) {
    body(std::size_t(0), n, 0u);
    return;
  }
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(workers);
  const std::size_t chunk = (n + workers - 1) / workers;
  auto run = [&](unsigned w) {
    const std::size_t b = std::min(n, w * chunk), e = std::min(n, b + chunk);
    try {
      body(b, e, w);
    } catch (...) {
      errors[w] = std::current_exception();
    }
  };
  if (detail::LoopRunner* team = detail::loopRunnerOfThisThread();
      team != nullptr && team->tryRun(workers, run)) {
    for (auto& e : errors)
      if (e) std::rethrow_exception(e);
    return;
  }
  pool.reserve(workers - 1);
  unsigned started = 1;
  // A thread that cannot be started (resource limits) is not an error: its block runs here instead.
  // Leaving the loop by exception would destroy joinable threads, which terminates the program.
  for (; started < workers; ++started) {
    try {
      pool.emplace_back(run, started);
    } catch (...) {
      break;
    }
  }
  run(0);
  for (unsigned w = started; w < workers; ++w) run(w);
  for (auto& t : pool) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

/// Calls fn(i) for every i < count in order on the calling thread, and rethrows the first exception
/// once all have run: the one-thread form of the parallel loops' contract.
template <typename F>
void runEachInOrder(std::size_t count, F&& fn) {
  std::exception_ptr error;
  for (std::size_t i = 0; i < count; ++i) {
    try {
      fn(i);
    } catch (...) {
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

namespace detail {
/// The shared part of a dynamic loop: every worker calls drain(), which claims indices from one
/// counter until `count` and keeps the first exception (the remaining tasks still run); rethrow()
/// once all workers are done. Used by parallelForDynamic and by thread teams that keep their threads.
struct TaskClaims {
  std::atomic<std::size_t> next{0};
  std::mutex error_mutex;
  std::exception_ptr error;

  template <typename F>
  void drain(std::size_t count, F& fn) {
    for (std::size_t i = next++; i < count; i = next++) {
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  }
  void rethrow() {
    if (error) std::rethrow_exception(error);
  }
};
}  // namespace detail

/// Calls fn(i) for every i < count on up to `threads` threads (0: hardware concurrency), each thread
/// taking the next unclaimed index when it finishes one, so uneven tasks balance. Rethrows the first
/// exception thrown (the remaining tasks still run) after all threads have finished.
template <typename F>
void parallelForDynamic(std::size_t count, unsigned threads, F&& fn) {
  const unsigned workers = static_cast<unsigned>(std::min<std::size_t>(resolveThreads(threads), count));
  if (workers <= 1) return runEachInOrder(count, fn);
  detail::TaskClaims claims;
  auto body = [&]() { claims.drain(count, fn); };
  if (detail::LoopRunner* team = detail::loopRunnerOfThisThread();
      team != nullptr && team->tryRun(workers, [&](unsigned) { body(); })) {
    claims.rethrow();
    return;
  }
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (unsigned w = 1; w < workers; ++w) {
    try {
      pool.emplace_back(body);
    } catch (...) {
      break;  // fewer threads: the shared counter still hands out every index
    }
  }
  body();
  for (auto& t : pool) t.join();
  claims.rethrow();
}

}  // namespace dw

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
