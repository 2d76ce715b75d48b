/// \file worker_pool.h
/// \brief A persistent pool of worker threads for the benchmark's batch queries. ICP answers one batch
/// per iteration; starting fresh threads for each batch costs tens of microseconds per thread, which at
/// 16 threads is as long as the whole batch of a fast method (100k walks of ~100 ns over 16 threads is
/// ~0.6 ms), so thread-scaling figures would measure thread creation. Workers here stay alive, spin
/// briefly for the next batch (the gap between ICP iterations is short) and then sleep.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace dwb {

class WorkerPool {
 public:
  /// The process-wide pool (grows to the largest thread count asked for).
  static WorkerPool& instance() {
    static WorkerPool pool;
    return pool;
  }

  WorkerPool() = default;
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> lk(m_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& w : workers_) w.join();
  }

  /// Runs fn(0), ..., fn(n - 1) concurrently, fn(0) on the calling thread; returns when all are done.
  /// Calls from several threads at once are serialised.
  void run(unsigned n, const std::function<void(unsigned)>& fn) {
    if (n <= 1) {
      fn(0);
      return;
    }
    std::lock_guard<std::mutex> serial(run_m_);
    while (workers_.size() + 1 < n) {
      const unsigned index = static_cast<unsigned>(workers_.size()) + 1;
      workers_.emplace_back([this, index] { loop(index); });
    }
    {
      std::lock_guard<std::mutex> lk(m_);
      job_ = &fn;
      active_ = n;
      remaining_.store(n - 1);
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    fn(0);
    std::unique_lock<std::mutex> lk(m_);
    done_.wait(lk, [this] { return remaining_.load() == 0; });
  }

 private:
  void loop(unsigned index) {
    std::uint64_t seen = 0;
    for (;;) {
      // A short spin catches the next ICP iteration's batch without a sleep/wake round trip.
      for (int k = 0; k < 20000 && generation_.load(std::memory_order_acquire) == seen; ++k)
        std::this_thread::yield();
      const std::function<void(unsigned)>* job = nullptr;
      {
        std::unique_lock<std::mutex> lk(m_);
        wake_.wait(lk, [&] { return stop_ || generation_.load() != seen; });
        if (stop_) return;
        seen = generation_.load();
        if (index < active_) job = job_;
      }
      if (!job) continue;
      (*job)(index);
      if (remaining_.fetch_sub(1) == 1) {
        std::lock_guard<std::mutex> lk(m_);  // the waiter checks under this lock: no lost wake-up
        done_.notify_one();
      }
    }
  }

  std::mutex run_m_, m_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_;
  const std::function<void(unsigned)>* job_ = nullptr;
  unsigned active_ = 0;
  std::atomic<unsigned> remaining_{0};
  std::atomic<std::uint64_t> generation_{0};
  bool stop_ = false;
};

}  // namespace dwb
