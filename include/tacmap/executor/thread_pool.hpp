// tacmap: `thread_pool_executor` — an `executor` (tacmap/executor/concept.hpp) on a fixed set of
// standard-library threads that the user owns.
//
// The threads are created once, with the executor, and wait between calls: a touch costs a
// wake-up (microseconds), never a thread creation (tens of microseconds each, as much as a
// whole update on the paper's 120 px map). The calling thread works too, so `threads` counts
// it: thread_pool_executor(2) starts one thread and splits each loop between it and the caller.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "tacmap/executor/concept.hpp"

namespace tacmap {

/// Runs each `parallel_for` on `threads` threads: the caller and `threads - 1` threads of its own,
/// started by the constructor and joined by the destructor. Chunks are handed out in order, a
/// range at a time, to whichever thread is free (other work on the machine can slow any thread
/// down). One `parallel_for` runs at a time: concurrent callers wait for each other; a call of
/// `parallel_for` from inside a running chunk runs sequentially on that thread. Not copyable or
/// movable (its threads refer to it).
class thread_pool_executor {
 public:
  /// `threads` >= 1: how many threads run a loop, the caller included (e.g.
  /// std::thread::hardware_concurrency()). Throws std::invalid_argument for 0, and
  /// std::system_error when the system cannot start a thread.
  explicit thread_pool_executor(std::size_t threads) {
    if (threads == 0)
      throw std::invalid_argument(
          "thread_pool_executor: threads = 0; expected at least 1 (the calling thread counts: 2 "
          "uses the caller and one more thread; 1 runs every loop on the caller)");
    workers_.reserve(threads - 1);
    try {
      for (std::size_t i = 0; i + 1 < threads; ++i) workers_.emplace_back([this] { work(); });
    } catch (...) {
      stop();
      throw;
    }
  }
  thread_pool_executor(const thread_pool_executor&) = delete;
  thread_pool_executor& operator=(const thread_pool_executor&) = delete;
  ~thread_pool_executor() { stop(); }

  [[nodiscard]] std::size_t concurrency() const { return workers_.size() + 1; }

  void parallel_for(std::size_t count, chunk_function f) {
    if (count == 0) return;
    const std::thread::id self = std::this_thread::get_id();
    // Nested (from a chunk of this executor's running loop) or nothing to share: inline. The
    // nested case would otherwise wait for itself.
    if (workers_.empty() || count == 1 || running_on(self)) {
      f(0, count);
      return;
    }
    const std::lock_guard<std::mutex> one_loop(call_mutex_);
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      job_ = &f;
      count_ = count;
      // 16 ranges per thread: the last range taken is what the other threads may wait for at
      // the end (a sixteenth of a thread's share), and a thread slowed down by other work on
      // the machine hands its share to the others; a range still holds many chunks (a grid's
      // loop has thousands), so taking one (an atomic increment) costs nothing measurable.
      // (At 640 x 480 on 2 threads a range is then about 0.8 ms of a 15 ms loop; with 4 per
      // thread it was 3 ms.)
      ranges_ = std::min(count, 16 * concurrency());
      next_.store(0, std::memory_order_relaxed);
      failed_.store(false, std::memory_order_relaxed);
      error_ = nullptr;
      busy_ = workers_.size();
      caller_ = self;
      ++generation_;
    }
    wake_.notify_all();
    run_ranges(f);
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return busy_ == 0; });
    job_ = nullptr;
    caller_ = std::thread::id{};
    if (error_) {
      std::exception_ptr e = error_;
      error_ = nullptr;
      std::rethrow_exception(e);
    }
  }

 private:
  // True when `id` is the thread running the current loop's caller or one of the workers.
  bool running_on(std::thread::id id) {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (job_ == nullptr) return false;
    if (id == caller_) return true;
    return std::any_of(workers_.begin(), workers_.end(),
                       [id](const std::thread& t) { return t.get_id() == id; });
  }

  // Takes ranges of the current loop until none is left (or one has thrown).
  void run_ranges(const chunk_function& f) {
    for (;;) {
      const std::size_t r = next_.fetch_add(1, std::memory_order_relaxed);
      if (r >= ranges_ || failed_.load(std::memory_order_relaxed)) return;
      const std::size_t begin = r * count_ / ranges_, end = (r + 1) * count_ / ranges_;
      try {
        f(begin, end);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
        failed_.store(true, std::memory_order_relaxed);
      }
    }
  }

  void work() {
    std::uint64_t seen = 0;
    for (;;) {
      const chunk_function* job = nullptr;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
        if (stopping_) return;
        seen = generation_;
        job = job_;
      }
      run_ranges(*job);
      const std::lock_guard<std::mutex> lock(mutex_);
      if (--busy_ == 0) done_.notify_one();
    }
  }

  void stop() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_)
      if (t.joinable()) t.join();
  }

  std::mutex call_mutex_;  // one loop at a time
  std::mutex mutex_;       // guards the fields below but next_ and failed_
  std::condition_variable wake_, done_;
  std::uint64_t generation_ = 0;  // one more per loop: a worker runs each loop once
  bool stopping_ = false;
  const chunk_function* job_ = nullptr;  // the current loop (null between loops)
  std::size_t count_ = 0, ranges_ = 0;   // its chunks, and the ranges they are split in
  std::size_t busy_ = 0;                 // workers not yet done with the current loop
  std::thread::id caller_;
  std::atomic<std::size_t> next_{0};  // the next range to take
  std::atomic<bool> failed_{false};   // a range threw: start no more
  std::exception_ptr error_;          // the first exception thrown
  std::vector<std::thread> workers_;
};

static_assert(executor<thread_pool_executor>);

}  // namespace tacmap
