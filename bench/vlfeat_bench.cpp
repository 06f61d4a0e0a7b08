// tacmap's dense SIFT-lite field against VLFeat's `vl_dsift` on the same image, in one run
// (issue 14, item 4): 2 x 2 spatial bins x 8 orientations, bins of 9 px, a descriptor at every
// pixel position (step 1), VLFeat with its fast flat window (a per-bin constant instead of the
// per-pixel Gaussian, integral images: its fastest setting) and with its default Gaussian window.
// Both produce (rows - 17) x (cols - 17) descriptors of 32 floats: sift_lite's patch is 18 px,
// vl_dsift's descriptor spans 2 bins x 9 px = 18 px. The methods differ (reference/dense-sift.md:
// VLFeat splits each gradient linearly between two orientation bins and uses central
// differences; sift_lite uses alpha = 9 soft orientation channels and Gaussian derivatives), so
// this compares the cost of the same output size, not the same numbers.
//
// VLFeat is a benchmark-only dependency (Debian libvlfeat-dev): this bench is built only where
// it is found (bench/CMakeLists.txt). Ratio to quote: vl_dsift_flat / tacmap_sift_lite at the
// same size, both medians of one run (--benchmark_repetitions=N
// --benchmark_report_aggregates_only=true); `tacmap_sift_lite_reused` is the like-for-like one
// (buffers kept between calls, as the VLFeat filter keeps its own), `tacmap_sift_lite` returns a
// new field each call.
#include <benchmark/benchmark.h>

extern "C" {
#include <vl/dsift.h>
}

#include <cmath>
#include <memory>
#include <random>

#include "tacmap/descriptor/dense_sift.hpp"

namespace {

/// A map-like image (the same as descriptor_bench's): smooth blobs plus a little texture.
tacmap::image<float> map_image(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  tacmap::image<float> img(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      img(r, c) = static_cast<float>(0.5 +
                                     0.3 * std::sin(static_cast<double>(c) / 7.0) *
                                         std::cos(static_cast<double>(r) / 5.0) +
                                     0.2 * u(gen));
  return img;
}

struct vl_dsift_deleter {
  void operator()(VlDsiftFilter* f) const { vl_dsift_delete(f); }
};

// Arguments: image width, height (px).
void tacmap_sift_lite(benchmark::State& state) {
  const tacmap::sift_lite d;
  const auto img = map_image(state.range(1), state.range(0), 1);
  Eigen::Index count = 0;
  for (auto _ : state) {
    auto field = d.compute(img);
    count = field.values.cols();
    benchmark::DoNotOptimize(field.values.data());
    benchmark::ClobberMemory();
  }
  state.counters["descriptors"] = static_cast<double>(count);
}

// The same into one field and workspace kept across calls, as the VLFeat filter below keeps its
// buffers (`dense_sift::compute(img, field, scratch)`): no fresh pages to fault in and zero.
void tacmap_sift_lite_reused(benchmark::State& state) {
  const tacmap::sift_lite d;
  const auto img = map_image(state.range(1), state.range(0), 1);
  tacmap::descriptor_field<float> field;
  tacmap::sift_lite::workspace scratch;
  for (auto _ : state) {
    d.compute(img, field, scratch);
    benchmark::DoNotOptimize(field.values.data());
    benchmark::ClobberMemory();
  }
  state.counters["descriptors"] = static_cast<double>(field.values.cols());
}

// Arguments: image width, height (px), flat window (1) or Gaussian (0).
void vl_dsift_2x2x8(benchmark::State& state) {
  const auto width = static_cast<int>(state.range(0));
  const auto height = static_cast<int>(state.range(1));
  const auto img = map_image(height, width, 1);  // row-major: x fastest, as VLFeat reads it
  // The filter is built once, as a caller processing many images of one size would.
  const std::unique_ptr<VlDsiftFilter, vl_dsift_deleter> f(
      vl_dsift_new_basic(width, height, /*step=*/1, /*binSize=*/9));
  VlDsiftDescriptorGeometry geometry = *vl_dsift_get_geometry(f.get());
  geometry.numBinT = 8;
  geometry.numBinX = 2;
  geometry.numBinY = 2;
  geometry.binSizeX = 9;
  geometry.binSizeY = 9;
  vl_dsift_set_geometry(f.get(), &geometry);
  vl_dsift_set_flat_window(f.get(), state.range(2) != 0);
  for (auto _ : state) {
    vl_dsift_process(f.get(), img.data());
    benchmark::DoNotOptimize(vl_dsift_get_descriptors(f.get()));
    benchmark::ClobberMemory();
  }
  state.counters["descriptors"] = vl_dsift_get_keypoint_num(f.get());
}

}  // namespace

BENCHMARK(tacmap_sift_lite)
    ->Name("dense_field/tacmap_sift_lite")
    ->Args({120, 120})
    ->Args({640, 480})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(tacmap_sift_lite_reused)
    ->Name("dense_field/tacmap_sift_lite_reused")
    ->Args({120, 120})
    ->Args({640, 480})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(vl_dsift_2x2x8)
    ->Name("dense_field/vl_dsift_flat")
    ->Args({120, 120, 1})
    ->Args({640, 480, 1})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(vl_dsift_2x2x8)
    ->Name("dense_field/vl_dsift_gaussian")
    ->Args({120, 120, 0})
    ->Args({640, 480, 0})
    ->Unit(benchmark::kMicrosecond);
