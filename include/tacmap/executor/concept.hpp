// tacmap: the `executor` concept — more than one core for the whole-grid operations, optional
// (issue 14, item 5).
//
// A whole-grid operation (the measurement model's distances over every window) is a loop over
// independent chunks of the grid. An executor runs such a loop, on one core or on several; the
// operation decides what a chunk is (tiles of window descriptors, so that every state's value is
// computed by exactly the same instructions whichever thread runs it: results are bit for bit
// those of the sequential loop) and the executor only where and when each range of chunks runs.
//
// tacmap owns no threads and keeps no global pool: the user creates an executor
// (`thread_pool_executor`, tacmap/executor/thread_pool.hpp; `tbb_executor`,
// tacmap/executor/tbb_executor.hpp with oneTBB; or their own), hands a model an `executor_ref`
// to it, and keeps it alive while the model uses it. Without one, a model runs its loops
// sequentially, exactly as before (the header-only core needs no thread library).
#pragma once

#include <concepts>
#include <cstddef>
#include <functional>
#include <memory>
#include <type_traits>
#include <utility>

namespace tacmap {

/// A non-owning reference to a callable `void(std::size_t begin, std::size_t end)` that
/// processes the chunks [begin, end) of a loop: what an executor's `parallel_for` is given. A
/// concrete type (rather than a template parameter) so that executors need not be templates
/// and a model can hold any executor behind one `executor_ref`. The callable must outlive the
/// `chunk_function` (it always does inside one `parallel_for` call).
class chunk_function {
 public:
  template <class F>
  requires(!std::same_as<std::remove_cvref_t<F>, chunk_function> &&
           std::invocable<const F&, std::size_t, std::size_t>) chunk_function(const F& f)
  noexcept  // NOLINT(google-explicit-constructor): a lambda converts
      : object_(std::addressof(f)), call_([](const void* o, std::size_t b, std::size_t e) {
          (*static_cast<const F*>(o))(b, e);
        }) {}
  void operator()(std::size_t begin, std::size_t end) const { call_(object_, begin, end); }

 private:
  const void* object_;
  void (*call_)(const void*, std::size_t, std::size_t);
};

/// Runs a loop of independent chunks, possibly on several threads.
///
/// A type `E` models `executor` when, for an `E e` (non-const: running may use its state), a
/// `std::size_t count` and a `chunk_function f`:
///  1. `e.parallel_for(count, f)` calls `f(begin, end)` on disjoint ranges that together cover
///     [0, count) exactly once (any number of calls, in any order, possibly concurrently, each
///     with begin < end), and returns when every call has returned. `count == 0` calls nothing.
///  2. An exception thrown by a call of `f` reaches the caller of `parallel_for`: it is
///     rethrown there (one of them, when several throw) after every call already running has
///     returned; ranges not yet started may then be skipped.
///  3. `e.concurrency()` returns how many calls of `f` may run at once (>= 1): a hint for how
///     finely an operation splits its work.
/// Calls of `f` must not call `parallel_for` on the same executor (thread_pool_executor runs
/// such a nested call inline, sequentially; other executors need not).
///
/// Minimal conforming type (the sequential loop, `sequential_executor` below):
/// ```
/// struct in_order {
///   void parallel_for(std::size_t count, chunk_function f) { if (count > 0) f(0, count); }
///   std::size_t concurrency() const { return 1; }
/// };
/// ```
template <class E>
concept executor = requires(E& e, const E& ce, std::size_t count, chunk_function f) {
  e.parallel_for(count, f);
  { ce.concurrency() } -> std::convertible_to<std::size_t>;
};

/// The default: the whole loop in one call on the calling thread — the behaviour without an
/// executor, at no cost.
struct sequential_executor {
  void parallel_for(std::size_t count, chunk_function f) {
    if (count > 0) f(0, count);
  }
  [[nodiscard]] std::size_t concurrency() const { return 1; }
};

/// A non-owning, copyable reference to any `executor`, which a model stores as a configured
/// value (its type does not change with the executor; one indirect call per whole-grid
/// operation). Empty (default-constructed) means sequential. The referenced executor must
/// outlive every use through the reference.
class executor_ref {
 public:
  executor_ref() = default;
  template <executor E>
  requires(!std::same_as<std::remove_cvref_t<E>, executor_ref>) executor_ref(E& e)
  noexcept  // NOLINT(google-explicit-constructor): model.set_executor(pool)
      : object_(std::addressof(e)),
        run_([](void* o, std::size_t count, chunk_function f) {
          static_cast<E*>(o)->parallel_for(count, f);
        }),
        concurrency_([](const void* o) -> std::size_t {
          return static_cast<std::size_t>(static_cast<const E*>(o)->concurrency());
        }) {}

  /// True when an executor is referenced (else every loop runs sequentially).
  [[nodiscard]] explicit operator bool() const { return object_ != nullptr; }

  void parallel_for(std::size_t count, chunk_function f) const {
    if (object_ == nullptr) {
      if (count > 0) f(0, count);
      return;
    }
    run_(object_, count, f);
  }
  [[nodiscard]] std::size_t concurrency() const {
    return object_ == nullptr ? 1 : concurrency_(object_);
  }

 private:
  void* object_ = nullptr;
  void (*run_)(void*, std::size_t, chunk_function) = nullptr;
  std::size_t (*concurrency_)(const void*) = nullptr;
};

static_assert(executor<sequential_executor>);
static_assert(executor<const executor_ref>);

}  // namespace tacmap
