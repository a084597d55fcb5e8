// ThreadPool (detail): the persistent pool the DenseNet forward pass runs its GEMMs and
// element-wise loops on (backends/densenet/gemm.hpp, winograd.hpp, densenet.hpp).
//
// ThreadPool(threads, spin_us = 300): requires 1 <= threads <= 256 and 0 <= spin_us <= 100000
//   (InvalidArgument). run(tasks, fn) must be called from one thread at a time (the owner); the
//   pool's workers are its own. requires 0 <= tasks <= 65535 (InvalidArgument); ensures fn(t)
//   ran exactly once for every t < tasks when it returns. Workers (and the caller, waiting for
//   them) poll for about spin_us after each call, then sleep: between the calls of one forward
//   pass both cores stay busy, an idle pool costs nothing. On a machine whose cores are busy
//   with other work, polling takes time from that work and from the pass itself: use spin_us 0
//   there (like ONNX Runtime's allow_spinning = 0), or one thread.
// Threading: as above - one owner thread calls run(); the workers are the pool's own.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

namespace detail {

// A persistent pool: run(tasks, fn) calls fn(t) for t in [0, tasks) on the calling thread and
// the workers, and returns when all are done. No allocation and no lock per call: a forward
// pass makes about 120 calls of 0.05-0.5 ms each, and a sleep/wake round trip through the
// kernel per call (tens of microseconds, more in a VM) costs more than the second thread gains.
// Workers therefore poll for new work for about spin_us after their last task before they block
// on a condition variable; the caller polls for completion, yielding its core after a while so
// a descheduled worker gets it back. Tasks are claimed from one atomic word holding the call's
// generation, its task count and the next task, so a worker late from one call can never take
// (or read the arguments of) the next.
class ThreadPool {
public:
  static constexpr int default_spin_us = 300;
  static constexpr int max_tasks = 0xffff;

  explicit ThreadPool(int threads, int spin_us = default_spin_us) : spin_us_(spin_us) {
    require(threads >= 1 && threads <= 256,
            "threads is " + std::to_string(threads) + ", expected 1..256");
    require(spin_us >= 0 && spin_us <= 100000,
            "spin_us is " + std::to_string(spin_us) + ", expected 0..100000");
    for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { work(); });
  }
  ~ThreadPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_.store(true);
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }
  int spin_us() const { return spin_us_; }

  // requires: 0 <= tasks <= max_tasks (InvalidArgument).
  template <class F>
  void run(int tasks, F& fn) {
    if (!(tasks >= 0 && tasks <= max_tasks)) // (no message built on the hot path)
      SHADOWSENSE_THROW(InvalidArgument("ThreadPool::run: tasks is " + std::to_string(tasks) +
                                        ", expected 0..65535"));
    if (workers_.empty() || tasks <= 1) {
      for (int t = 0; t < tasks; ++t) fn(t);
      return;
    }
    ctx_ = &fn;
    call_ = [](void* c, int t) { (*static_cast<F*>(c))(t); };
    pending_.store(tasks, std::memory_order_relaxed);
    const std::uint64_t generation =
        ((work_.load(std::memory_order_relaxed) >> 32) + 1) & 0xffffffffu;
    // seq_cst publish, then the sleeper check: a worker either sees the new word before it
    // blocks (it re-checks under the mutex after counting itself a sleeper) or is counted here.
    work_.store(generation << 32 | static_cast<std::uint64_t>(tasks) << 16);
    if (sleepers_.load() > 0) {
      { std::lock_guard<std::mutex> lock(mutex_); }
      wake_.notify_all();
    }
    drain(generation);
    if (poll([&] { return pending_.load(std::memory_order_acquire) == 0; })) return;
    std::unique_lock<std::mutex> lock(mutex_);
    caller_waiting_.store(true);
    done_.wait(lock, [&] { return pending_.load() == 0; });
    caller_waiting_.store(false);
  }

private:
  // Polls ready() for about spin_us_; true as soon as it holds. No PAUSE and no sched_yield in
  // the loop: under a hypervisor both can hand the core away (pause-loop exits), which made a
  // 2-thread pass slower than a 1-thread one.
  template <class Ready>
  bool poll(Ready&& ready) const {
    if (spin_us_ == 0) return ready();
    const auto since = std::chrono::steady_clock::now();
    for (int i = 0;; ++i) {
      if (ready()) return true;
      if ((i & 255) == 255 &&
          std::chrono::steady_clock::now() - since > std::chrono::microseconds(spin_us_))
        return ready();
    }
  }
  // Runs tasks of call `generation` until none is left.
  void drain(std::uint64_t generation) {
    std::uint64_t w = work_.load(std::memory_order_acquire);
    for (;;) {
      if ((w >> 32) != generation || (w & 0xffff) >= ((w >> 16) & 0xffff)) return;
      if (!work_.compare_exchange_weak(w, w + 1, std::memory_order_acq_rel,
                                       std::memory_order_acquire))
        continue;
      call_(ctx_, static_cast<int>(w & 0xffff)); // safe: run() waits for this task
      if (pending_.fetch_sub(1) == 1 && caller_waiting_.load()) {
        { std::lock_guard<std::mutex> lock(mutex_); }
        done_.notify_one();
      }
      w = work_.load(std::memory_order_acquire);
    }
  }
  void work() {
    std::uint64_t seen = 0; // the last generation served
    for (;;) {
      auto fresh = [&] {
        return stop_.load(std::memory_order_relaxed) ||
               (work_.load(std::memory_order_acquire) >> 32) != seen;
      };
      if (!poll(fresh)) {
        std::unique_lock<std::mutex> lock(mutex_);
        sleepers_.fetch_add(1);
        wake_.wait(lock, [&] { return stop_.load() || (work_.load() >> 32) != seen; });
        sleepers_.fetch_sub(1);
      }
      if (stop_.load()) return;
      seen = work_.load(std::memory_order_acquire) >> 32;
      drain(seen);
    }
  }

  int spin_us_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  // The call's arguments: written by run() before it publishes work_, read by a worker only
  // after it has claimed a task of that call.
  void* ctx_ = nullptr;
  void (*call_)(void*, int) = nullptr;
  std::atomic<std::uint64_t> work_{0}; // generation << 32 | tasks << 16 | next task
  std::atomic<int> pending_{0}, sleepers_{0};
  std::atomic<bool> stop_{false}, caller_waiting_{false};
};

} // namespace detail

SHADOWSENSE_NAMESPACE_END
