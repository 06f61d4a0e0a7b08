// Benchmarks of tacmap::dense_sift: dense descriptors of the paper's 120 x 120 map (Sec. IV-A),
// the three descriptors of one 42 x 18 tactile image, three arbitrary patches of a 46 x 46
// rotation canvas (describe_at, next to compute on the same canvas), and the scalar reference
// for scale.
//
// Build (Release, one core):
//   g++ -O3 -DNDEBUG -march=x86-64-v3 -std=c++20 -Iinclude -isystem /usr/include/eigen3
//       bench/descriptor_bench.cpp -lbenchmark -lbenchmark_main -lpthread  (one line)
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "../tests/descriptor/dense_sift_reference.hpp"
#include "tacmap/descriptor/dense_sift.hpp"

namespace {

/// A map-like image: smooth blobs plus a little texture, values in [0, 1].
tacmap::image<float> map_image(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  tacmap::image<float> img(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (Eigen::Index c = 0; c < cols; ++c) {
      const double x = static_cast<double>(c);
      const double y = static_cast<double>(r);
      img(r, c) =
          static_cast<float>(0.5 + 0.3 * std::sin(x / 7.0) * std::cos(y / 5.0) + 0.2 * u(gen));
    }
  }
  return img;
}

template <class D>
void dense_map(benchmark::State& state) {
  using T = typename D::scalar_type;
  const D d;
  const tacmap::image<T> img = map_image(120, 120, 1).cast<T>();
  for (auto _ : state) {
    auto field = d.compute(img);
    benchmark::DoNotOptimize(field.values.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * (120 - d.patch_size() + 1) *
                          (120 - d.patch_size() + 1));
}

template <class D>
void tactile_samples(benchmark::State& state) {
  const D d;
  const auto img = map_image(42, 18, 2);
  for (auto _ : state) {
    auto samples = d.sample(img);
    benchmark::DoNotOptimize(samples.values.data());
    benchmark::ClobberMemory();
  }
}

/// The same with a kept workspace and output (what the descriptor models do per touch).
template <class D>
void tactile_samples_reused(benchmark::State& state) {
  const D d;
  const auto img = map_image(42, 18, 2);
  typename D::workspace scratch;
  tacmap::descriptor_samples<typename D::scalar_type> samples;
  for (auto _ : state) {
    d.sample(img, scratch, samples);
    benchmark::DoNotOptimize(samples.values.data());
    benchmark::ClobberMemory();
  }
}

/// A 42 x 18 tactile-like image rotated by 30 degrees onto a zero 46 x 46 canvas (nearest
/// neighbour), as a rotation-search measurement model builds one per candidate angle.
tacmap::image<float> rotation_canvas() {
  const auto tactile = map_image(42, 18, 3);
  tacmap::image<float> canvas = tacmap::image<float>::Zero(46, 46);
  const double c = std::cos(0.5236);
  const double s = std::sin(0.5236);
  for (Eigen::Index r = 0; r < 46; ++r) {
    for (Eigen::Index k = 0; k < 46; ++k) {
      const double x = static_cast<double>(k) - 22.5;
      const double y = static_cast<double>(r) - 22.5;
      const auto tr = static_cast<Eigen::Index>(std::lround(-s * x + c * y + 20.5));
      const auto tc = static_cast<Eigen::Index>(std::lround(c * x + s * y + 8.5));
      if (tr >= 0 && tr < 42 && tc >= 0 && tc < 18) canvas(r, k) = tactile(tr, tc);
    }
  }
  return canvas;
}

/// Three patches off any regular grid (the rotated tactile image's three sub-images).
template <class D>
std::vector<tacmap::grid_cell> canvas_patches(const D& d) {
  const Eigen::Index last = 46 - d.patch_size();
  return {{3, last - 5}, {last / 2 + 1, last / 2 - 2}, {last - 4, 6}};
}

template <class D>
void canvas_describe_at(benchmark::State& state) {
  const D d;
  const auto img = rotation_canvas();
  const auto patches = canvas_patches(d);
  for (auto _ : state) {
    auto out = d.describe_at(img, patches);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
}

template <class D>
void canvas_compute(benchmark::State& state) {
  const D d;
  const auto img = rotation_canvas();
  for (auto _ : state) {
    auto field = d.compute(img);
    benchmark::DoNotOptimize(field.values.data());
    benchmark::ClobberMemory();
  }
}

void reference_sift_lite_map(benchmark::State& state) {
  const auto img = map_image(120, 120, 1);
  dsift_reference::mat m(120, 120);
  for (Eigen::Index r = 0; r < 120; ++r) {
    for (Eigen::Index c = 0; c < 120; ++c) m(r + 1, c + 1) = static_cast<double>(img(r, c));
  }
  const dsift_reference::params prm;  // sift_lite: 2 x 2 x 8, patch 18
  for (auto _ : state) {
    auto out = dsift_reference::compute(m, prm);
    benchmark::DoNotOptimize(out.d.data());
    benchmark::ClobberMemory();
  }
}

}  // namespace

BENCHMARK_TEMPLATE(dense_map, tacmap::sift_lite)
    ->Name("dense_sift/sift_lite/map_120x120")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(dense_map, tacmap::classic_sift)
    ->Name("dense_sift/classic_sift/map_120x120")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(dense_map, tacmap::dense_sift<2, 8, double>)
    ->Name("dense_sift/sift_lite_double/map_120x120")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(tactile_samples, tacmap::sift_lite)
    ->Name("dense_sift/sift_lite/tactile_42x18_3_descriptors")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(tactile_samples, tacmap::classic_sift)
    ->Name("dense_sift/classic_sift/tactile_42x18_3_descriptors")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(tactile_samples_reused, tacmap::classic_sift)
    ->Name("dense_sift/classic_sift/tactile_42x18_3_descriptors_reused")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(canvas_describe_at, tacmap::sift_lite)
    ->Name("dense_sift/sift_lite/canvas_46x46_describe_at_3")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(canvas_compute, tacmap::sift_lite)
    ->Name("dense_sift/sift_lite/canvas_46x46_compute")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(canvas_describe_at, tacmap::classic_sift)
    ->Name("dense_sift/classic_sift/canvas_46x46_describe_at_3")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(canvas_compute, tacmap::classic_sift)
    ->Name("dense_sift/classic_sift/canvas_46x46_compute")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(reference_sift_lite_map)
    ->Name("dense_sift/scalar_reference_sift_lite/map_120x120")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
