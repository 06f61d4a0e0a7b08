// Sums of a whole belief at the sizes tacmap advertises (issue 37, section 2): the chunked sums
// against their double references, and a 16-million-state filter whose flat update, prediction
// and entropy stay normalised. Its own program, compiled with -O2 in every build (Debug, Release,
// the sanitizers): a few seconds.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "table_filter.hpp"
#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/filter/detail/posterior_kernel.hpp"

namespace test_mass_sum {

namespace {

// Values in [lo, 2 lo) that are not powers of two (a belief of 2^-24 each sums exactly in float
// and would hide the lanes' rounding): a fixed pattern, cheap at 16 million.
template <class T>
std::vector<T> mass_values(std::size_t n, double total) {
  std::vector<T> v(n);
  const double lo = total / static_cast<double>(n) / 1.4995;  // the factors average 1.4995
  for (std::size_t i = 0; i < n; ++i)
    v[i] = static_cast<T>(lo * (1.0 + static_cast<double>((i * 2654435761U) % 1000U) / 1000.0));
  return v;
}

// The reference of a float array's sum: every value in double (what mass_sum_scalar does, here
// written out so the test does not trust the header).
template <class T>
double double_sum(const T* v, std::size_t n) {
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) s += static_cast<double>(v[i]);
  return s;
}

}  // namespace

TEST_CASE_TEMPLATE("mass_sum's SIMD kernels equal the double reference at every length", T, float,
                   double) {
  for (const std::size_t n :
       {0U, 1U, 3U, 7U, 8U, 63U, 64U, 65U, 127U, 128U, 129U, 1000U, 8137U, 100003U}) {
    CAPTURE(n);
    const auto v = mass_values<T>(n, 1.0);
    const auto ni = static_cast<Eigen::Index>(n);
    const double ref = double_sum(v.data(), n);
    CHECK(tacmap::detail::mass_sum_scalar(v.data(), ni) == ref);
    // The compile-time architecture and the SSE2 baseline (what a default-flags build runs).
    CHECK(tacmap::detail::mass_sum(v.data(), ni) == doctest::Approx(ref).epsilon(1e-7));
    CHECK(tacmap::detail::mass_sum_simd<xsimd::sse2>(v.data(), ni) ==
          doctest::Approx(ref).epsilon(1e-7));
    // Every value counts once: a value changed anywhere (the tail included) changes the sum.
    if (n > 0) {
      auto w = v;
      w[n - 1] += T(1);
      CHECK(tacmap::detail::mass_sum(w.data(), ni) == doctest::Approx(ref + 1.0).epsilon(1e-7));
      w = v;
      w[n / 2] += T(1);
      CHECK(tacmap::detail::mass_sum_simd<xsimd::sse2>(w.data(), ni) ==
            doctest::Approx(ref + 1.0).epsilon(1e-7));
    }
    const Eigen::Map<const Eigen::Array<T, Eigen::Dynamic, 1>> a(v.data(), ni);
    CHECK(tacmap::detail::chunked_sum(a * T(2)) == doctest::Approx(2.0 * ref).epsilon(1e-7));
  }
}

TEST_CASE("double_sum: every value in double, the same value at every call, at every length") {
  for (const std::size_t n : {0U, 1U, 7U, 8U, 9U, 15U, 16U, 17U, 120U, 1000U, 8137U, 100003U}) {
    CAPTURE(n);
    const auto v = mass_values<float>(n, 1.0);
    const auto ni = static_cast<Eigen::Index>(n);
    const double ref = double_sum(v.data(), n);
    const double s = tacmap::detail::double_sum(v.data(), ni);
    // Double precision (only the order's rounding), not mass_sum's float chunks.
    CHECK(std::abs(s - ref) <= 1e-15 * static_cast<double>(n + 1) * std::abs(ref));
    CHECK(tacmap::detail::double_sum(v.data(), ni) == s);
    const Eigen::Map<const Eigen::ArrayXf> a(v.data(), ni);
    CHECK(tacmap::detail::double_sum(a) == s);
    // Every value counts once: the body's lanes and the tail's.
    for (const std::size_t at : {std::size_t{0}, n / 2, n - 1}) {
      if (n == 0) break;
      auto w = v;
      w[at] += 1.0F;
      CHECK(tacmap::detail::double_sum(w.data(), ni) ==
            doctest::Approx(double_sum(w.data(), n)).epsilon(1e-14));
      CHECK(tacmap::detail::double_sum(w.data(), ni) == doctest::Approx(ref + 1.0).epsilon(1e-6));
    }
  }
}

TEST_CASE("16 million float values: the chunked sums stay within 1e-6, a flat float sum does not") {
  constexpr std::size_t n = 4000U * 4000U;
  const auto v = mass_values<float>(n, 1.0);
  const auto ni = static_cast<Eigen::Index>(n);
  const double ref = double_sum(v.data(), n);
  CHECK(std::abs(ref - 1.0) < 1e-6);
  const Eigen::Map<const Eigen::ArrayXf> a(v.data(), ni);
  // What the sums were before (issue 37): Eigen's float lanes over the whole array.
  CHECK(std::abs(static_cast<double>(a.sum()) - ref) > 1e-4);
  CHECK(std::abs(tacmap::detail::mass_sum(v.data(), ni) - ref) < 1e-6);
  CHECK(std::abs(tacmap::detail::mass_sum_simd<xsimd::sse2>(v.data(), ni) - ref) < 1e-6);
  CHECK(std::abs(tacmap::detail::chunked_sum(a) - ref) < 1e-6);
  // The update's weighting pass (ll = 0: every factor 1, the posterior's sum the values'), in
  // the compile-time architecture and in SSE2 (the scalar reference is compared at smaller
  // sizes in test_posterior_kernel.cpp).
  const std::vector<float> ll(n, 0.0F);
  std::vector<float> out(n);
  const auto sums = tacmap::detail::weight_by_likelihood(v.data(), ll.data(), 0.0F, out.data(), ni);
  CHECK(std::abs(sums.posterior - ref) < 1e-6);
  CHECK(std::abs(sums.likelihood - static_cast<double>(n)) < 1e-6 * static_cast<double>(n));
  const auto sse2 = tacmap::detail::weight_by_likelihood_simd<xsimd::sse2>(v.data(), ll.data(),
                                                                           0.0F, out.data(), ni);
  CHECK(std::abs(sse2.posterior - ref) < 1e-6);
}

TEST_CASE("a 16-million-state filter: a flat update, a prediction and the entropy stay exact") {
  // 4000 x 4000 positions (a 4002 x 4002 px map with a 3 x 3 px window), 1 mm apart.
  using tacmap_test::table_filter;
  using tacmap_test::table_grid;
  table_filter f(table_grid({.width = 4002, .height = 4002}, 1.0, {.width = 3, .height = 3}),
                 tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}), {});
  const Eigen::Index n = f.grid().size();
  REQUIRE(n == 4000 * 4000);
  const auto prior = mass_values<float>(static_cast<std::size_t>(n), 1.0);
  f.set_prior(Eigen::Map<const Eigen::ArrayXf>(prior.data(), n));
  const auto mass = [&] { return double_sum(f.belief().data(), static_cast<std::size_t>(n)); };
  CHECK(std::abs(mass() - 1.0) <= 1e-6);
  // A flat update: the posterior is the prior, the evidence exactly 1.
  const Eigen::ArrayXf flat = Eigen::ArrayXf::Zero(n);
  const tacmap::update_report r = f.update(flat);
  CHECK(std::abs(mass() - 1.0) <= 1e-6);
  CHECK(std::abs(r.log_evidence) <= 1e-6);
  // A prediction that keeps (nearly) every state's mass on the grid.
  const tacmap::prediction_report p = f.predict({.dx_mm = 0.4, .dy_mm = -0.3});
  CHECK(std::abs(mass() - 1.0) <= 1e-6);
  CHECK(p.mass_lost >= 0.0);
  CHECK(p.mass_lost < 1e-3);
  // The entropy of a nearly uniform belief: just below log N, never above it.
  const double log_n = std::log(static_cast<double>(n));
  const double h = f.estimate().entropy_nats;
  CHECK(h <= log_n);
  CHECK(h > log_n - 0.05);
  // ... and the entropy of the belief's values in double, normalised (the reference).
  double m = 0.0, plogp = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto q = static_cast<double>(f.belief()(i));
    m += q;
    if (q > 0.0) plogp += q * std::log(q);
  }
  CHECK(h == doctest::Approx(-plogp / m + std::log(m)).epsilon(1e-6));
}

}  // namespace test_mass_sum
