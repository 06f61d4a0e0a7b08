// The xsimd kernels of the measurement update against their scalar references.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "tacmap/filter/detail/posterior_kernel.hpp"

namespace test_posterior_kernel {

namespace {

template <class T>
std::vector<T> random_log_likelihood(std::size_t n, std::mt19937& rng) {
  std::vector<T> ll(n);
  for (auto& v : ll) {
    const auto r = rng() % 100;
    // Mostly moderate values, some hugely negative (underflow territory), some excluded.
    v = r < 5    ? -std::numeric_limits<T>::infinity()
        : r < 15 ? -static_cast<T>(rng() % 100000)
                 : -static_cast<T>(rng() % 4000) / T(100);
  }
  return ll;
}

}  // namespace

TEST_CASE_TEMPLATE("weight_by_likelihood matches its scalar reference", T, float, double) {
  std::mt19937 rng(11);
  for (const std::size_t n : {1U, 3U, 7U, 8U, 9U, 31U, 100U, 8137U}) {
    CAPTURE(n);
    const auto ll = random_log_likelihood<T>(n, rng);
    std::vector<T> prior(n);
    for (auto& p : prior) p = static_cast<T>(rng() % 1000 + 1) / T(1000);
    const auto n_idx = static_cast<Eigen::Index>(n);
    const auto scan = tacmap::detail::scan_log_likelihood(ll.data(), n_idx);
    const auto scan_ref = tacmap::detail::scan_log_likelihood_scalar(ll.data(), n_idx);
    CHECK(scan.first_nan == -1);
    CHECK(scan.max == scan_ref.max);
    std::vector<T> out(n);
    std::vector<T> ref(n);
    const auto sum =
        tacmap::detail::weight_by_likelihood(prior.data(), ll.data(), scan.max, out.data(), n_idx);
    const auto sum_ref = tacmap::detail::weight_by_likelihood_scalar(prior.data(), ll.data(),
                                                                     scan.max, ref.data(), n_idx);
    CHECK(sum.posterior == doctest::Approx(sum_ref.posterior).epsilon(1e-5));
    CHECK(sum.likelihood == doctest::Approx(sum_ref.likelihood).epsilon(1e-5));
    // The factors' sum counts the maximum's factor exp(0) = 1 at least once.
    CHECK(sum.likelihood >= 1.0 - 1e-6);
    double factors = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      if (ll[i] - scan.max >= tacmap::detail::log_factor_floor<T>())
        factors += std::exp(static_cast<double>(ll[i] - scan.max));
    CHECK(sum.likelihood == doctest::Approx(factors).epsilon(1e-5));
    for (std::size_t i = 0; i < n; ++i) {
      CHECK(static_cast<double>(out[i]) ==
            doctest::Approx(static_cast<double>(ref[i])).epsilon(1e-5));
      if (ll[i] == -std::numeric_limits<T>::infinity()) CHECK(out[i] == T(0));  // stays excluded
    }
  }
}

TEST_CASE_TEMPLATE("scan_log_likelihood finds the first NaN in the vector body and the tail", T,
                   float, double) {
  std::mt19937 rng(5);
  for (const std::size_t n : {5U, 16U, 19U, 100U}) {
    for (const std::size_t at : {std::size_t{0}, n / 2, n - 1}) {
      auto ll = random_log_likelihood<T>(n, rng);
      ll[at] = std::numeric_limits<T>::quiet_NaN();
      if (at + 1 < n) ll[n - 1] = std::numeric_limits<T>::quiet_NaN();  // a later NaN too
      const auto s = tacmap::detail::scan_log_likelihood(ll.data(), static_cast<Eigen::Index>(n));
      CHECK(s.first_nan == static_cast<Eigen::Index>(at));
    }
  }
}

}  // namespace test_posterior_kernel
