// More than one core (issue 14, item 5): the executors against the concept's requirements, and
// the measurement model and filter on an executor against their sequential results, bit for bit.
#include <doctest/doctest.h>

#include <atomic>
#include <cstddef>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/executor/concept.hpp"
#include "tacmap/executor/thread_pool.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/testing/conformance.hpp"
#ifdef TACMAP_TEST_TBB
#include "tacmap/executor/tbb_executor.hpp"
#endif

namespace test_executor {

namespace {

// Near misses: one requirement missing each.
struct no_parallel_for {
  [[nodiscard]] std::size_t concurrency() const { return 1; }
};
struct no_concurrency {
  void parallel_for(std::size_t count, tacmap::chunk_function f) {
    if (count > 0) f(0, count);
  }
};
static_assert(!tacmap::executor<no_parallel_for>);
static_assert(!tacmap::executor<no_concurrency>);
static_assert(tacmap::executor<tacmap::sequential_executor>);
static_assert(tacmap::executor<tacmap::thread_pool_executor>);

// Requirement 1: every index of [0, count) exactly once, in ranges with begin < end.
template <class E>
void check_covers(E& e, std::size_t count) {
  std::vector<std::atomic<int>> hits(count);
  std::atomic<bool> empty_range{false};
  e.parallel_for(count, [&](std::size_t b, std::size_t end) {
    if (b >= end || end > count) empty_range = true;
    for (std::size_t i = b; i < end && i < count; ++i) hits[i].fetch_add(1);
  });
  CHECK_FALSE(empty_range.load());
  std::size_t once = 0;
  for (const auto& h : hits) once += h.load() == 1 ? 1U : 0U;
  CHECK(once == count);
}

// Requirement 2: a chunk's exception reaches the caller, and the executor stays usable.
template <class E>
void check_exception(E& e) {
  CHECK_THROWS_WITH_AS(e.parallel_for(1000,
                                      [](std::size_t b, std::size_t end) {
                                        if (b <= 500 && 500 < end)
                                          throw std::domain_error("chunk 500 failed");
                                      }),
                       "chunk 500 failed", std::domain_error);
  check_covers(e, 777);
}

}  // namespace

TEST_CASE("sequential_executor and an empty executor_ref run the loop in one call") {
  tacmap::sequential_executor s;
  int calls = 0;
  s.parallel_for(10, [&](std::size_t b, std::size_t e) {
    ++calls;
    CHECK(b == 0);
    CHECK(e == 10);
  });
  s.parallel_for(0, [&](std::size_t, std::size_t) { ++calls; });
  CHECK(calls == 1);
  const tacmap::executor_ref none;
  CHECK_FALSE(static_cast<bool>(none));
  CHECK(none.concurrency() == 1);
  check_covers(none, 5);
}

TEST_CASE("thread_pool_executor: coverage, exceptions, bad thread counts, nesting") {
  CHECK_THROWS_WITH_AS(tacmap::thread_pool_executor(0),
                       doctest::Contains("threads = 0; expected at least 1"),
                       std::invalid_argument);
  for (const std::size_t threads : {1U, 2U, 3U}) {
    CAPTURE(threads);
    tacmap::thread_pool_executor pool(threads);
    CHECK(pool.concurrency() == threads);
    for (const std::size_t count : {0U, 1U, 2U, 7U, 64U, 10007U}) check_covers(pool, count);
    check_exception(pool);
    // Through an executor_ref, as a model holds it.
    const tacmap::executor_ref ref(pool);
    CHECK(static_cast<bool>(ref));
    CHECK(ref.concurrency() == threads);
    check_covers(ref, 1234);
  }
  SUBCASE("the work is shared between threads") {
    tacmap::thread_pool_executor pool(2);
    std::mutex m;
    std::vector<std::thread::id> ids;
    // Chunks that wait for each other: only two threads running at once can finish this.
    std::atomic<int> arrived{0};
    pool.parallel_for(2, [&](std::size_t, std::size_t) {
      {
        const std::lock_guard<std::mutex> lock(m);
        ids.push_back(std::this_thread::get_id());
      }
      arrived.fetch_add(1);
      while (arrived.load() < 2) std::this_thread::yield();
    });
    REQUIRE(ids.size() == 2);
    CHECK(ids[0] != ids[1]);
  }
  SUBCASE("a nested call runs inline instead of waiting for itself") {
    tacmap::thread_pool_executor pool(2);
    std::atomic<std::size_t> inner{0};
    pool.parallel_for(4, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        pool.parallel_for(10, [&](std::size_t ib, std::size_t ie) { inner += ie - ib; });
    });
    CHECK(inner.load() == 40);
  }
  SUBCASE("callers on two threads take turns") {
    tacmap::thread_pool_executor pool(2);
    std::atomic<std::size_t> total{0};
    auto run = [&] {
      for (int k = 0; k < 50; ++k)
        pool.parallel_for(100, [&](std::size_t b, std::size_t e) { total += e - b; });
    };
    std::thread other(run);
    run();
    other.join();
    CHECK(total.load() == 2 * 50 * 100);
  }
}

#ifdef TACMAP_TEST_TBB
TEST_CASE("tbb_executor: coverage, exceptions, bad thread counts") {
  static_assert(tacmap::executor<tacmap::tbb_executor>);
  CHECK_THROWS_AS(tacmap::tbb_executor(0), std::invalid_argument);
  tacmap::tbb_executor two(2);
  CHECK(two.concurrency() == 2);
  tacmap::tbb_executor all;
  CHECK(all.concurrency() >= 1);
  for (auto* e : {&two, &all}) {
    for (const std::size_t count : {0U, 1U, 7U, 10007U}) check_covers(*e, count);
    check_exception(*e);
  }
}
#endif

namespace {

constexpr tacmap::pixel_size window{.width = 18, .height = 42};

// The log-likelihood of `model` for a touch cut from the map, sequentially and on `e`.
template <class Model>
void check_bit_identical(Model model, const tacmap::image<float>& map, tacmap::executor_ref e) {
  const tacmap::planar_grid<float> grid({.width = map.cols(), .height = map.rows()}, 0.2, window);
  tacmap::image<float> z = map.block(11, 23, window.height, window.width);
  z(3, 4) += 0.25F;  // not an exact cut: no distance is 0
  Eigen::ArrayXf sequential(grid.size()), parallel(grid.size());
  model.log_likelihood(grid, z, sequential);
  model.set_executor(e);
  parallel.setConstant(std::numeric_limits<float>::quiet_NaN());
  model.log_likelihood(grid, z, parallel);
  CHECK(std::memcmp(sequential.data(), parallel.data(),
                    sizeof(float) * static_cast<std::size_t>(sequential.size())) == 0);
  // A touch of the wrong size is refused as sequentially (before any worker runs).
  const tacmap::image<float> wrong(window.height, window.width + 1);
  CHECK_THROWS_AS(model.log_likelihood(grid, wrong, parallel), std::invalid_argument);
}

}  // namespace

TEST_CASE("descriptor_likelihood on an executor gives the sequential values bit for bit") {
  // 101 x 78: 60 x 61 states, which end inside a tile (8 states) and inside a chunk (8 tiles).
  const tacmap::image<float> map = tacmap::testing::conformance_image(101, 78, 3);
  tacmap::thread_pool_executor pool2(2), pool3(3);
  for (tacmap::thread_pool_executor* pool : {&pool2, &pool3}) {
    CAPTURE(pool->concurrency());
    check_bit_identical(tacmap::descriptor_likelihood<tacmap::classic_sift>({}, map, window), map,
                        *pool);
    check_bit_identical(tacmap::descriptor_likelihood<tacmap::sift_lite>({}, map, window), map,
                        *pool);
    // The paper's configuration: all pairs and eq. (2)'s vectorised logarithm.
    check_bit_identical(tacmap::descriptor_likelihood<tacmap::sift_lite>(
                            {}, map, window, tacmap::descriptor_likelihood_params::paper()),
                        map, *pool);
    tacmap::descriptor_likelihood_params both;
    both.both_signs = true;
    check_bit_identical(tacmap::descriptor_likelihood<tacmap::sift_lite>({}, map, window, both),
                        map, *pool);
    // Configurations that stay sequential on an executor: still the same values.
    tacmap::descriptor_likelihood_params shared;
    shared.features = tacmap::window_features::shared_dense;
    check_bit_identical(tacmap::descriptor_likelihood<tacmap::sift_lite>({}, map, window, shared),
                        map, *pool);
    tacmap::descriptor_likelihood_params either;
    either.contrast = tacmap::contrast_sign::either_per_patch;
    check_bit_identical(tacmap::descriptor_likelihood<tacmap::sift_lite>({}, map, window, either),
                        map, *pool);
  }
#ifdef TACMAP_TEST_TBB
  tacmap::tbb_executor tbb(2);
  check_bit_identical(tacmap::descriptor_likelihood<tacmap::classic_sift>({}, map, window), map,
                      tbb);
#endif
}

TEST_CASE("bayes_filter::set_executor: the same belief bit for bit") {
  const tacmap::image<float> map = tacmap::testing::conformance_image(90, 70, 5);
  using filter_t = tacmap::bayes_filter<tacmap::planar_grid<float>, tacmap::odometry_gaussian,
                                        tacmap::descriptor_likelihood<tacmap::sift_lite>>;
  const tacmap::planar_grid<float> grid({.width = map.cols(), .height = map.rows()}, 0.2, window);
  auto make = [&] {
    return filter_t(grid, tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}),
                    tacmap::descriptor_likelihood<tacmap::sift_lite>({}, map, window));
  };
  filter_t sequential = make(), parallel = make();
  tacmap::thread_pool_executor pool(2);
  parallel.set_executor(pool);
  CHECK(static_cast<bool>(parallel.measurement_model().executor()));
  for (int k = 0; k < 3; ++k) {
    const tacmap::image<float> z = map.block(20 + k, 30 + 2 * k, window.height, window.width);
    if (k > 0) {
      sequential.predict({.dx_mm = 0.4, .dy_mm = 0.2});
      parallel.predict({.dx_mm = 0.4, .dy_mm = 0.2});
    }
    const auto a = sequential.update(z);
    const auto b = parallel.update(z);
    CHECK(a.log_evidence == b.log_evidence);
    CHECK(std::memcmp(sequential.belief().data(), parallel.belief().data(),
                      sizeof(float) * static_cast<std::size_t>(grid.size())) == 0);
  }
  parallel.set_executor({});
  CHECK_FALSE(static_cast<bool>(parallel.measurement_model().executor()));
}

}  // namespace test_executor
