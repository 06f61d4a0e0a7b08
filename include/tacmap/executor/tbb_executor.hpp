// tacmap: `tbb_executor` — an `executor` (tacmap/executor/concept.hpp) on oneTBB's work-stealing
// scheduler, for programs that already use oneTBB (its threads are then shared with the rest of
// the program instead of competing with a pool of tacmap's own).
//
// Optional: this header needs oneTBB (Debian: libtbb-dev) and the CMake target tacmap::tbb,
// which exists only where oneTBB is found (TACMAP_WITH_TBB); the rest of tacmap never includes it.
#pragma once

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <cstddef>
#include <stdexcept>

#include "tacmap/executor/concept.hpp"

namespace tacmap {

/// Runs each `parallel_for` as a oneTBB `parallel_for` inside a task arena of its own, limited
/// to `threads` threads (the caller included), or oneTBB's default (every core the process may
/// use) when constructed without a count. oneTBB rethrows an exception of a chunk in the caller
/// after cancelling the chunks not yet started (requirement 2).
class tbb_executor {
 public:
  /// oneTBB's default number of threads.
  tbb_executor() = default;
  /// At most `threads` (>= 1) threads. Throws std::invalid_argument for 0.
  explicit tbb_executor(std::size_t threads)
      : arena_(threads == 0 ? throw std::invalid_argument(
                                  "tbb_executor: threads = 0; expected at least 1 (the calling "
                                  "thread counts), or the default constructor for oneTBB's "
                                  "default")
                            : static_cast<int>(threads)) {}

  [[nodiscard]] std::size_t concurrency() const {
    return static_cast<std::size_t>(arena_.max_concurrency());
  }

  void parallel_for(std::size_t count, chunk_function f) {
    if (count == 0) return;
    // About 16 ranges per thread, as thread_pool_executor: long ranges, and little left for
    // one thread at the end.
    const std::size_t grain = std::max<std::size_t>(1, count / (16 * concurrency()));
    arena_.execute([&] {
      oneapi::tbb::parallel_for(
          oneapi::tbb::blocked_range<std::size_t>(0, count, grain),
          [&](const oneapi::tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
    });
  }

 private:
  oneapi::tbb::task_arena arena_;
};

static_assert(executor<tbb_executor>);

}  // namespace tacmap
