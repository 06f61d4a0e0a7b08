// tacmap: the whole-image kernels behind dense_sift (gradients, orientation channels, pooling).
//
// Every stage works on whole rows of the image (Eigen maps over contiguous memory), never on one
// patch at a time: the cost is O(pixels x channels x taps) whatever the number of patches
// (reference/dense-sift.md, "Cost structure"). The semantics are Lazebnik's dense SIFT; see
// dense_sift.hpp for the user-facing description.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "tacmap/detail/huge_pages.hpp"
#include "tacmap/detail/weighted_sum.hpp"
#include "tacmap/image.hpp"
#include "tacmap/simd.hpp"

namespace tacmap::detail::dsift {

/// Resizes `a` to n elements (unspecified values), with huge pages asked for when that maps new
/// memory: at camera resolution each shared field is ~10 MB, mapped fresh per preparation, and
/// its 4 KB page faults cost more than computing it (bench/camera_bench.cpp, build rows).
template <class T>
void resize_fresh(Eigen::Array<T, Eigen::Dynamic, 1>& a, Eigen::Index n) {
  if (a.size() == n) return;
  a.resize(n);
  advise_huge_pages(a.data(), static_cast<std::size_t>(n) * sizeof(T));
}

/// Lazebnik pads the image with 2 mirrored pixels on each side ([I(2) I(1) I ... I(end)
/// I(end-1)] in MATLAB): index -1 reads 0, -2 reads 1, n reads n-1, n+1 reads n-2.
inline constexpr Eigen::Index mirror_pad = 2;

/// Index of the pixel that the symmetric (edge-duplicating) mirror puts at `i` for a line of
/// `n >= 2` pixels; valid for -2 <= i < n + 2.
inline Eigen::Index mirror(Eigen::Index i, Eigen::Index n) {
  if (i < 0) return -i - 1;
  if (i >= n) return 2 * n - 1 - i;
  return i;
}

/// Separable derivative-of-Gaussian filters in correlation form:
/// out(x) = sum_{b=-radius}^{radius} taps[b + radius] * in(x + b).
///
/// Lazebnik's gen_dgauss samples a 2-D Gaussian on 4*ceil(sigma)+1 pixels, normalises it to
/// sum 1, differentiates it with MATLAB's `gradient` (central differences inside, one-sided at
/// the two ends) and rescales each derivative kernel to absolute sum 2. The 2-D Gaussian is the
/// outer product of the normalised 1-D one, so each derivative kernel is (1-D Gaussian along one
/// axis) x (1-D differentiated Gaussian along the other), with the same absolute sum.
template <class T>
struct gradient_taps {
  Eigen::Index radius = 0;
  Eigen::Array<T, Eigen::Dynamic, 1> smooth;      ///< normalised 1-D Gaussian (symmetric)
  Eigen::Array<T, Eigen::Dynamic, 1> derivative;  ///< grows to the right: positive for b > 0
};

template <class T>
gradient_taps<T> make_gradient_taps(double sigma) {
  gradient_taps<T> taps;
  taps.radius = 2 * static_cast<Eigen::Index>(std::ceil(sigma));
  const Eigen::Index n = 2 * taps.radius + 1;
  Eigen::ArrayXd g(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto x = static_cast<double>(i - taps.radius);
    g(i) = std::exp(-x * x / (2.0 * sigma * sigma));
  }
  g /= g.sum();
  // MATLAB gradient of the sampled Gaussian.
  Eigen::ArrayXd dg(n);
  dg(0) = g(1) - g(0);
  dg(n - 1) = g(n - 1) - g(n - 2);
  for (Eigen::Index i = 1; i + 1 < n; ++i) dg(i) = 0.5 * (g(i + 1) - g(i - 1));
  dg *= 2.0 / dg.abs().sum();
  // We *convolve* with the kernel (MATLAB's filter2 correlates): the gradient then points
  // towards brighter pixels. Convolution is correlation with the reversed taps.
  taps.smooth = g.cast<T>();
  taps.derivative = dg.reverse().cast<T>();
  return taps;
}

/// One non-zero tap of the spatial pooling kernel: pooled(y) += weight * channel(y + offset).
template <class T>
struct pooling_tap {
  Eigen::Index offset = 0;
  T weight = 0;
};

/// The triangular pooling kernel of Lazebnik's dense SIFT, as offsets from the sample point.
///
/// MATLAB: weight_x(j) = max(0, 1 - |j - (patch/2 - 0.5)| / bin) for j = 1..patch, applied with
/// conv2(..., 'same'), which for an even length p reads channel(i + p/2 + 1 - j). In offsets
/// d = p/2 + 1 - j in [1 - p/2, p/2] the weight is max(0, 1 - |d - 1.5| / bin): a triangle of
/// half-width `bin` centred 1.5 px after the sample point, cut to the kernel's p taps.
template <class T>
std::vector<pooling_tap<T>> make_pooling_taps(Eigen::Index patch, Eigen::Index bin) {
  std::vector<pooling_tap<T>> taps;
  for (Eigen::Index d = 1 - patch / 2; d <= patch / 2; ++d) {
    const double w = 1.0 - std::abs(static_cast<double>(d) - 1.5) / static_cast<double>(bin);
    if (w > 0.0) taps.push_back({d, static_cast<T>(w)});
  }
  return taps;
}

/// Calls f(std::integral_constant<unsigned, e>) when 1 <= e <= 16 and returns true, so that a
/// pixel loop can be compiled for the exponent; returns false for any other e.
template <class F, unsigned... E>
bool with_static_exponent(unsigned e, F&& f, std::integer_sequence<unsigned, E...>) {
  return ((e == E + 1U ? (f(std::integral_constant<unsigned, E + 1U>{}), true) : false) || ...);
}
template <class F>
bool with_static_exponent(unsigned e, F&& f) {
  return with_static_exponent(e, std::forward<F>(f), std::make_integer_sequence<unsigned, 16>{});
}

/// c^alpha, in place, for c in [0, 1] (one Eigen fixed-size array of channels): alpha an
/// integer known at compile time (left-to-right binary powering, fully unrolled: alpha = 9 is 3
/// squarings and a product), an integer known at run time, or any other positive value.
template <unsigned Exponent>
struct static_power {
  template <class A>
  void operator()(A& c) const {
    static_assert(Exponent >= 1U);
    const A base = c;
    constexpr int top = std::bit_width(Exponent) - 1;
    for (int bit = top - 1; bit >= 0; --bit) {  // unrolled: the bounds are constants
      c = c.square();
      if (((Exponent >> static_cast<unsigned>(bit)) & 1U) != 0U) c *= base;
    }
  }
};
struct integral_power {
  unsigned exponent;
  template <class A>
  void operator()(A& c) const {
    A result = A::Ones();
    A base = c;
    for (unsigned e = exponent; e != 0U; e >>= 1U) {
      if ((e & 1U) != 0U) result *= base;
      base = base.square();
    }
    c = result;
  }
};
template <class T>
struct real_power {
  T exponent;
  template <class A>
  void operator()(A& c) const {
    c = c.pow(exponent);
  }
};

/// The image divided by `scale`, mirrored by `mirror_pad` pixels, its mean subtracted and
/// surrounded by zeros to `radius` pixels per side: (h + 2 radius) rows of w + 2 radius,
/// followed by `extra` zeros (room for readers that overrun the last row).
template <class T>
void padded_image(const image_view<T>& img, T scale, Eigen::Index radius, Eigen::Index extra,
                  Eigen::Array<T, Eigen::Dynamic, 1>& padded) {
  using row_map = Eigen::Map<Eigen::Array<T, Eigen::Dynamic, 1>>;
  const Eigen::Index h = img.rows();
  const Eigen::Index w = img.cols();
  const Eigen::Index r = radius;
  const Eigen::Index wp = w + 2 * r;
  const Eigen::Index m = mirror_pad;
  padded = Eigen::Array<T, Eigen::Dynamic, 1>::Zero((h + 2 * r) * wp + extra);
  double sum = 0.0;
  for (Eigen::Index y = -m; y < h + m; ++y) {
    T* out = padded.data() + (y + r) * wp + r;
    row_map(out, w) = img.row(mirror(y, h)).transpose() / scale;
    for (Eigen::Index x = 1; x <= m; ++x) {
      out[-x] = out[x - 1];
      out[w - 1 + x] = out[w - x];
    }
    sum += static_cast<double>(row_map(out - m, w + 2 * m).sum());
  }
  // The kernels sum to zero, so the mean only matters where a wide kernel reaches the zeros
  // beyond the mirrored pixels; subtracting it there acts as padding with the mean.
  const auto mean = static_cast<T>(sum / static_cast<double>((h + 2 * m) * (w + 2 * m)));
  for (Eigen::Index y = -m; y < h + m; ++y) {
    row_map(padded.data() + (y + r) * wp + r - m, w + 2 * m) -= mean;
  }
}

/// Columns [begin, end) of one image row; empty when begin >= end.
struct column_span {
  Eigen::Index begin = 0;
  Eigen::Index end = 0;
};

/// The buffers `gradients` works in, kept by a caller that describes many images (no
/// allocation once they have seen an image of the size).
template <class T>
struct span_gradient_scratch {
  Eigen::Array<T, Eigen::Dynamic, 1> padded, dx, sx;
  std::vector<column_span> out_span, pad_span;
  std::vector<const T*> src, src_x;
};

/// Gradients (gx along columns, gy along rows, y downwards) of `img / scale` with Lazebnik's
/// border handling: 2 mirrored pixels, the mean of that padded image subtracted, zero beyond
/// (which only a kernel wider than 5 px, sigma_edge > 1, reaches).
///
/// Both passes run over the padded image as one flat array (a row's last 2 * radius outputs
/// are scratch), so a short tactile row costs no per-row call. Pixel (y, x) of the result is at
/// y * stride + x with the returned stride = cols + 2 * radius; columns >= cols are scratch.
/// Its buffers are `scratch`'s.
template <class T>
Eigen::Index gradients(const image_view<T>& img, T scale, const gradient_taps<T>& taps,
                       Eigen::Array<T, Eigen::Dynamic, 1>& gx,
                       Eigen::Array<T, Eigen::Dynamic, 1>& gy, span_gradient_scratch<T>& scratch) {
  const Eigen::Index h = img.rows();
  const Eigen::Index w = img.cols();
  const Eigen::Index r = taps.radius;
  const Eigen::Index hp = h + 2 * r;
  const Eigen::Index wp = w + 2 * r;
  Eigen::Array<T, Eigen::Dynamic, 1>& padded = scratch.padded;
  padded_image(img, scale, r, 0, padded);

  const auto n_taps = static_cast<std::size_t>(2 * r + 1);
  std::vector<const T*>& src = scratch.src;
  std::vector<const T*>& src_x = scratch.src_x;
  src.resize(n_taps);
  src_x.resize(n_taps);
  // Horizontal pass: derivative (for gx) and smoothing (for gy). Output i reads padded
  // i .. i + 2r; the last 2r entries would read past the end and are only scratch: zeroed.
  Eigen::Array<T, Eigen::Dynamic, 1>& dx = scratch.dx;
  Eigen::Array<T, Eigen::Dynamic, 1>& sx = scratch.sx;
  dx.resize(hp * wp);
  sx.resize(hp * wp);
  for (std::size_t t = 0; t < n_taps; ++t) src[t] = padded.data() + static_cast<Eigen::Index>(t);
  weighted_sum(src.data(), taps.derivative.data(), n_taps, dx.data(), hp * wp - 2 * r);
  weighted_sum(src.data(), taps.smooth.data(), n_taps, sx.data(), hp * wp - 2 * r);
  dx.tail(2 * r).setZero();
  sx.tail(2 * r).setZero();
  // Vertical pass: smoothing (gx) and derivative (gy); output row y reads rows y .. y + 2r.
  gx.resize(h * wp);
  gy.resize(h * wp);
  for (std::size_t t = 0; t < n_taps; ++t) {
    src_x[t] = dx.data() + static_cast<Eigen::Index>(t) * wp;
    src[t] = sx.data() + static_cast<Eigen::Index>(t) * wp;
  }
  weighted_sum(src_x.data(), taps.smooth.data(), n_taps, gx.data(), h * wp);
  weighted_sum(src.data(), taps.derivative.data(), n_taps, gy.data(), h * wp);
  return wp;
}

/// `gradients` in buffers of its own.
template <class T>
Eigen::Index gradients(const image_view<T>& img, T scale, const gradient_taps<T>& taps,
                       Eigen::Array<T, Eigen::Dynamic, 1>& gx,
                       Eigen::Array<T, Eigen::Dynamic, 1>& gy) {
  span_gradient_scratch<T> scratch;
  return gradients(img, scale, taps, gx, gy, scratch);
}

/// `gradients`, valid only at columns [spans[y].begin, spans[y].end) of each image row y (one
/// span per row; other pixels of gx and gy are unspecified): the same padded image and the same
/// sums, for the pixels a few patches need instead of all of them. Each pass runs row by row
/// over the span, widened to whole registers (the widened columns land in the next row or the
/// scratch columns and are never read as results) so that short spans have no scalar tail.
template <class T>
Eigen::Index gradients(const image_view<T>& img, T scale, const gradient_taps<T>& taps,
                       const std::vector<column_span>& spans,
                       Eigen::Array<T, Eigen::Dynamic, 1>& gx,
                       Eigen::Array<T, Eigen::Dynamic, 1>& gy, span_gradient_scratch<T>& scratch) {
  constexpr Eigen::Index lane = 32 / static_cast<Eigen::Index>(sizeof(T));
  const Eigen::Index h = img.rows();
  const Eigen::Index w = img.cols();
  const Eigen::Index r = taps.radius;
  const Eigen::Index hp = h + 2 * r;
  const Eigen::Index wp = w + 2 * r;
  // A widened span reads at most lane - 1 + 2r past a row's last pixel.
  const Eigen::Index overrun = lane + 2 * r;
  Eigen::Array<T, Eigen::Dynamic, 1>& padded = scratch.padded;
  padded_image(img, scale, r, overrun, padded);

  // Output row y's widened span, and each padded row's: the hull of the output rows it feeds
  // (padded row yp is tap yp - y of output row y, for yp - 2r <= y <= yp).
  std::vector<column_span>& out_span = scratch.out_span;
  std::vector<column_span>& pad_span = scratch.pad_span;
  out_span.assign(static_cast<std::size_t>(h), {});
  pad_span.assign(static_cast<std::size_t>(hp), {wp, 0});
  for (Eigen::Index y = 0; y < h; ++y) {
    column_span sp = spans[static_cast<std::size_t>(y)];
    if (sp.begin >= sp.end) continue;
    sp.end = sp.begin + (sp.end - sp.begin + lane - 1) / lane * lane;
    out_span[static_cast<std::size_t>(y)] = sp;
    for (Eigen::Index yp = y; yp <= y + 2 * r; ++yp) {
      column_span& p = pad_span[static_cast<std::size_t>(yp)];
      p.begin = std::min(p.begin, sp.begin);
      p.end = std::max(p.end, sp.end);
    }
  }

  const auto n_taps = static_cast<std::size_t>(2 * r + 1);
  std::vector<const T*>& src = scratch.src;
  src.resize(n_taps);
  Eigen::Array<T, Eigen::Dynamic, 1>& dx = scratch.dx;
  Eigen::Array<T, Eigen::Dynamic, 1>& sx = scratch.sx;
  dx.resize(hp * wp + overrun);
  sx.resize(hp * wp + overrun);
  for (Eigen::Index yp = 0; yp < hp; ++yp) {
    const column_span sp = pad_span[static_cast<std::size_t>(yp)];
    if (sp.begin >= sp.end) continue;
    const Eigen::Index at = yp * wp + sp.begin;
    for (std::size_t t = 0; t < n_taps; ++t) {
      src[t] = padded.data() + at + static_cast<Eigen::Index>(t);
    }
    weighted_sum(src.data(), taps.derivative.data(), n_taps, dx.data() + at, sp.end - sp.begin);
    weighted_sum(src.data(), taps.smooth.data(), n_taps, sx.data() + at, sp.end - sp.begin);
  }
  gx.resize(h * wp + overrun);
  gy.resize(h * wp + overrun);
  for (Eigen::Index y = 0; y < h; ++y) {
    const column_span sp = out_span[static_cast<std::size_t>(y)];
    if (sp.begin >= sp.end) continue;
    const Eigen::Index at = y * wp + sp.begin;
    for (std::size_t t = 0; t < n_taps; ++t) {
      src[t] = dx.data() + at + static_cast<Eigen::Index>(t) * wp;
    }
    weighted_sum(src.data(), taps.smooth.data(), n_taps, gx.data() + at, sp.end - sp.begin);
    for (std::size_t t = 0; t < n_taps; ++t) {
      src[t] = sx.data() + at + static_cast<Eigen::Index>(t) * wp;
    }
    weighted_sum(src.data(), taps.derivative.data(), n_taps, gy.data() + at, sp.end - sp.begin);
  }
  return wp;
}

/// The channel loop for one choice of power (see `orientation_channels`).
template <int NumAngles, class T, class Power>
T orientation_channels_with(const Power& power, const Eigen::Array<T, Eigen::Dynamic, 1>& gx,
                            const Eigen::Array<T, Eigen::Dynamic, 1>& gy, Eigen::Index h,
                            Eigen::Index w, Eigen::Index stride, Eigen::Index margin,
                            const Eigen::Array<T, NumAngles, 1>& cos_a,
                            const Eigen::Array<T, NumAngles, 1>& sin_a, const column_span* spans,
                            T* channels) {
  using vec = Eigen::Array<T, NumAngles, 1>;
  using array = Eigen::Array<T, Eigen::Dynamic, 1>;
  const Eigen::Index row_size = (w + 2 * margin) * NumAngles;
  array mag(w);
  array ux(w);
  array uy(w);
  vec top = vec::Zero();  // the largest value of each channel (box_pooler's scale)
  for (Eigen::Index y = 0; y < h; ++y) {
    const Eigen::Index x0 = spans == nullptr ? 0 : spans[y].begin;
    const Eigen::Index n = spans == nullptr ? w : spans[y].end - x0;
    if (n <= 0) continue;
    // Magnitude and unit gradient for the whole row (vectorised) ...
    const Eigen::Map<const array> rx(gx.data() + y * stride + x0, n);
    const Eigen::Map<const array> ry(gy.data() + y * stride + x0, n);
    mag.head(n) = (rx.square() + ry.square()).sqrt();
    // 1 / max(mag, smallest normal) stays finite, and a zero gradient gives 0 * finite = 0.
    // (Eigen 3.4's select() is not vectorised; this is.)
    uy.head(n) = mag.head(n).max(std::numeric_limits<T>::min()).inverse();
    ux.head(n) = rx * uy.head(n);
    uy.head(n) *= ry;
    // ... then all channels of a pixel at once (one register for 8 float channels). A zero
    // gradient has ux = uy = 0, so every channel is 0; the cosine is clamped to [0, 1] as
    // rounding may put it a hair above 1.
    T* row = channels + (y + margin) * row_size + (x0 + margin) * NumAngles;
    for (Eigen::Index x = 0; x < n; ++x) {
      vec c = (ux(x) * cos_a + uy(x) * sin_a).max(T(0)).min(T(1));
      power(c);
      const vec value = mag(x) * c;
      top = top.max(value);
      Eigen::Map<vec>(row + x * NumAngles) = value;
    }
  }
  return top.maxCoeff();
}

/// Orientation channels of an h x w image whose gradients have row stride `stride`:
/// magnitude * max(0, cos(theta - 2 pi k / NumAngles))^alpha. cos(theta - a_k) is evaluated as
/// (gx cos a_k + gy sin a_k) / magnitude, so no atan2 is needed; a zero gradient gives zero
/// channels (Lazebnik sets theta = 0 there, which also gives zero: magnitude 0).
///
/// Layout: pixel-major with `margin` zero pixels on every side, channel k of pixel (y, x) at
/// ((y + margin) * (w + 2 margin) + x + margin) * NumAngles + k. The zeros are the "outside the
/// image" of the pooling filter, so it needs no bounds checks.
///
/// With `spans` (one per image row), only the pixels in row y's span are computed (the gradients
/// need only be valid there); the others are left unspecified, the margins are still zero.
/// `margins_zero`: `channels` already has this size and zero margins (a workspace reused for an
/// image of the same size: nothing here writes the margins), so they are not cleared again.
/// Returns the largest value computed (0 for none): `box_pooler`'s scale, found here where every
/// value passes through a register instead of in a pass of its own (4 % of the dense field).
template <int NumAngles, class T>
T orientation_channels(const Eigen::Array<T, Eigen::Dynamic, 1>& gx,
                       const Eigen::Array<T, Eigen::Dynamic, 1>& gy, Eigen::Index h, Eigen::Index w,
                       Eigen::Index stride, Eigen::Index margin,
                       const Eigen::Array<T, NumAngles, 1>& cos_a,
                       const Eigen::Array<T, NumAngles, 1>& sin_a, double alpha,
                       Eigen::Array<T, Eigen::Dynamic, 1>& channels,
                       const column_span* spans = nullptr, bool margins_zero = false) {
  using array = Eigen::Array<T, Eigen::Dynamic, 1>;
  const Eigen::Index row_size = (w + 2 * margin) * NumAngles;
  resize_fresh(channels, (h + 2 * margin) * row_size);
  if (!margins_zero) {
    channels.head(margin * row_size).setZero();
    channels.tail(margin * row_size).setZero();
    for (Eigen::Index y = 0; y < h; ++y) {
      T* row = channels.data() + (y + margin) * row_size;
      Eigen::Map<array>(row, margin * NumAngles).setZero();
      Eigen::Map<array>(row + (w + margin) * NumAngles, margin * NumAngles).setZero();
    }
  }
  // An integral alpha takes the squaring path (unrolled for alpha <= 16, the default 9
  // included); anything else uses pow.
  const bool integral = alpha == std::floor(alpha) && alpha <= 1048576.0;
  const auto exponent = integral ? static_cast<unsigned>(alpha) : 0U;
  T top = 0;
  auto run = [&](const auto& power) {
    top = orientation_channels_with<NumAngles, T>(power, gx, gy, h, w, stride, margin, cos_a, sin_a,
                                                  spans, channels.data());
  };
  if (integral &&
      with_static_exponent(exponent, [&](auto e) { run(static_power<decltype(e)::value>{}); })) {
    return top;
  }
  if (integral) {
    run(integral_power{exponent});
  } else {
    run(real_power<T>{static_cast<T>(alpha)});
  }
  return top;
}

/// Pools orientation channels (layout of `orientation_channels`, `margin` >= every tap's
/// |offset|) with the separable triangular kernel, at columns [x0, x0 + nx) of one image row
/// per call: the pooled row holds column x0 + ix's channels at out[ix * NumAngles ...].
///
/// Vertical pass into a scratch row with zero margins (the channels' margin rows are zero, so
/// rows outside the image need no test), then the horizontal pass straight out of it: each a
/// single weighted sum over a whole row.
template <int NumAngles, class T>
class row_pooler {
 public:
  row_pooler(const std::vector<pooling_tap<T>>& taps, const T* channels, Eigen::Index w,
             Eigen::Index margin, Eigen::Index x0, Eigen::Index nx)
      : channels_(channels),
        w_(w),
        row_size_((w + 2 * margin) * NumAngles),
        margin_(margin),
        nx_(nx),
        weight_(taps.size()),
        offset_(taps.size()),
        src_(taps.size()),
        src_x_(taps.size()),
        vertical_(Eigen::Array<T, Eigen::Dynamic, 1>::Zero(row_size_)) {
    for (std::size_t t = 0; t < taps.size(); ++t) {
      weight_[t] = taps[t].weight;
      offset_[t] = taps[t].offset;
      src_x_[t] = vertical_.data() + (x0 + taps[t].offset + margin) * NumAngles;
    }
  }

  // The source pointers point into vertical_: not copyable.
  row_pooler(const row_pooler&) = delete;
  row_pooler& operator=(const row_pooler&) = delete;

  /// Pools image row y into out[0, nx * NumAngles).
  void operator()(Eigen::Index y, T* out) {
    for (std::size_t t = 0; t < weight_.size(); ++t) {
      src_[t] = channels_ + (y + offset_[t] + margin_) * row_size_ + margin_ * NumAngles;
    }
    weighted_sum(src_.data(), weight_.data(), weight_.size(),
                 vertical_.data() + margin_ * NumAngles, w_ * NumAngles);
    weighted_sum(src_x_.data(), weight_.data(), weight_.size(), out, nx_ * NumAngles);
  }

 private:
  const T* channels_;
  Eigen::Index w_;
  Eigen::Index row_size_;
  Eigen::Index margin_;
  Eigen::Index nx_;
  std::vector<T> weight_;
  std::vector<Eigen::Index> offset_;
  std::vector<const T*> src_;
  std::vector<const T*> src_x_;
  Eigen::Array<T, Eigen::Dynamic, 1> vertical_;  ///< one row, zero margins
};

/// `row_pooler`'s result by running box sums in exact integer arithmetic, for float channels
/// whose kernel is Lazebnik's triangle (`make_pooling_taps`): O(1) work per value whatever the
/// bin size, where the weighted sums take one multiply-add per tap (17 per pass for sift_lite,
/// half of `compute`'s time).
///
/// Why integers: the triangle of half-width b centred 1.5 px after the sample has integer weights
/// W(d) = 2b - |2d - 3| in units of 1 / (2b), and is a box of b taps, a second box of b taps and
/// a pair [1, 1] (taps cut by the patch border are subtracted again). Running box sums in float
/// drift: each step rounds at the scale of the largest sum seen, and a strong edge leaves a
/// residue in the flat area after it. In int32 every sum is exact, so nothing drifts however
/// long the row. The channels are quantised once to q = round(c * s) with s chosen so that the
/// vertical sum of the largest channel value fits in 31 bits; the vertical sums are shifted right
/// by `shift_` bits (rounded) so that the horizontal sums fit as well. Both roundings are
/// absolute errors of at most 2^-23 of the image's largest pooled value, what float pooling
/// rounds to at that scale (the tests compare with the scalar reference at 1e-5, and at the
/// extremes: large images, one saturated edge beside flat areas).
///
/// Rows are pooled in increasing order (each call continues the running sums; rows may be
/// skipped, their vertical sums are still taken). Channels: `orientation_channels`' layout.
///
/// Bounds: the running sums read b + 1 rows and columns ahead of the value pooled, which the
/// channels' zero margin (patch / 2: b with two bins per side, 1 px for a 2 px patch) does not
/// always cover. So the passes never read the channels outside the image: a row below it is
/// quantised from `zero_row_`, and the row of vertical sums `t_` has its own zero pixels, b + 1
/// before the image and after it up to the last column the horizontal pass reads. Any h, w,
/// nx >= 1 and rows y >= 0 pool as the per-tap kernel does, with zeros outside the image.
template <int NumAngles>
class box_pooler {
  using batch = xsimd::batch<float, kernel_arch<float>>;
  using ibatch = xsimd::batch<std::int32_t, kernel_arch<float>>;
  static constexpr auto width = static_cast<Eigen::Index>(batch::size);
  static constexpr std::size_t regs = static_cast<std::size_t>(NumAngles / width);  // per pixel

 public:
  /// A tap cut from the full triangle: pooled -= weight * q(y + offset).
  struct cut_tap {
    Eigen::Index offset = 0;
    std::int32_t weight = 0;
  };

  /// Whether the integer path serves these taps: float registers that hold whole pixels, the
  /// full triangle of half-width `bin` minus taps cut on its far side only, bins of at most
  /// 11 px (2 bin^2 < 256: the shift between the passes keeps 23 bits), and `margin` >= bin.
  /// Otherwise `row_pooler` runs.
  static bool applies(const std::vector<pooling_tap<float>>& taps, Eigen::Index bin,
                      Eigen::Index margin) {
    if constexpr (NumAngles % width != 0) {
      return false;
    } else {
      if (bin < 1 || bin > 11 || margin < bin) return false;
      std::vector<cut_tap> cut;
      return decompose(taps, bin, cut);
    }
  }

  /// `top`: the largest channel value (`orientation_channels` returns it).
  box_pooler(const std::vector<pooling_tap<float>>& taps, const float* channels, Eigen::Index h,
             Eigen::Index w, Eigen::Index margin, Eigen::Index bin, Eigen::Index nx, float top)
      : channels_(channels),
        h_(h),
        w_(w),
        margin_(margin),
        bin_(bin),
        nx_(nx),
        n_(w * NumAngles),
        slots_(bin + 1) {
    static_cast<void>(decompose(taps, bin, cut_));
    const Eigen::Index full = 2 * bin * bin;  // sum of the integer weights of one pass
    shift_ = static_cast<int>(std::bit_width(static_cast<unsigned>(full)));
    // Largest q: the vertical sum (<= full * q) plus the shift's rounding fits in 31 bits.
    const std::int64_t qmax =
        ((std::int64_t{1} << 31) - (std::int64_t{1} << shift_)) / static_cast<std::int64_t>(full);
    // A hair below qmax: c * s may round up.
    // Capped at the largest float: for a largest value below about 1e-31 (only a subnormal
    // could be) the scale would overflow to infinity and 0 * inf is NaN.
    const double s = top > 0.0F ? static_cast<double>(qmax) * (1.0 - 1e-6) / top : 1.0;
    scale_ =
        static_cast<float>(std::min(s, static_cast<double>(std::numeric_limits<float>::max())));
    // pooled = sum of (W_v / 2b) (W_h / 2b) c, and the horizontal sums count 2^shift_ per unit;
    // the float scale the quantisation used, not the double it was rounded from.
    const auto unit = static_cast<double>(2 * bin);
    unscale_ = static_cast<float>(static_cast<double>(std::int64_t{1} << shift_) /
                                  (static_cast<double>(scale_) * unit * unit));
    q_.assign(static_cast<std::size_t>(slots_ * n_), 0);
    b_.assign(static_cast<std::size_t>(slots_ * n_), 0);
    bb_.assign(static_cast<std::size_t>(n_), 0);
    // t_ spans pixels [-lead_, max(w, nx + b + 1)): the horizontal pass reads t(x + 1) from
    // x = -b - 1 and t(x + b + 1) (the newest value, and the far cut) up to x = nx - 1.
    lead_ = bin + 1;
    const Eigen::Index end = std::max(w, nx + bin + 1);
    t_.assign(static_cast<std::size_t>((lead_ + end) * NumAngles), 0);
    zero_row_.assign(static_cast<std::size_t>(n_), 0.0F);
    hb_.assign(static_cast<std::size_t>((nx + 3 * bin + 2) * NumAngles), 0);
    y_ = -bin - 2;  // every sum is zero this far above the image
  }

  box_pooler(const box_pooler&) = delete;
  box_pooler& operator=(const box_pooler&) = delete;

  /// Pools image row y (>= every earlier call's) into out[0, nx * NumAngles).
  void operator()(Eigen::Index y, float* out) {
    while (y_ < y) vertical();
    horizontal(out);
  }

 private:
  static bool decompose(const std::vector<pooling_tap<float>>& taps, Eigen::Index bin,
                        std::vector<cut_tap>& cut) {
    cut.clear();
    std::size_t t = 0;
    for (Eigen::Index d = 2 - bin; d <= bin + 1; ++d) {
      const auto weight = static_cast<std::int32_t>(2 * bin - std::abs(2 * d - 3));
      if (t < taps.size() && taps[t].offset == d) {
        if (std::abs(static_cast<double>(taps[t].weight) * static_cast<double>(2 * bin) -
                     static_cast<double>(weight)) > 1e-4) {
          return false;
        }
        ++t;
      } else {
        if (d < 1) return false;  // a cut on the near side: not read from the ring
        cut.push_back({d, weight});
      }
    }
    return t == taps.size();
  }

  [[nodiscard]] Eigen::Index slot(Eigen::Index r) const { return ((r % slots_) + slots_) % slots_; }
  std::int32_t* q_row(Eigen::Index r) { return q_.data() + slot(r) * n_; }
  std::int32_t* b_row(Eigen::Index r) { return b_.data() + slot(r) * n_; }

  /// Vertical sums of the next row y into t_: B(z) = q(z) + ... + q(z + b - 1),
  /// BB(z) = B(z) + ... + B(z + b - 1), pooled(y) = BB(y + 2 - b) + BB(y + 3 - b) - cuts.
  void vertical() {
    const Eigen::Index y = ++y_;
    const Eigen::Index b = bin_;
    // Row y + b + 1 is quantised in this loop, as it is first read: one pass over the channels
    // instead of a separate one. Past the last image row it is zero (the channels' margin may
    // be shorter than b + 1 rows: patch / 2 >= b only).
    const Eigen::Index r = y + b + 1;
    std::int32_t* qn = q_row(r);
    const float* src = r < h_
                           ? channels_ + ((r + margin_) * (w_ + 2 * margin_) + margin_) * NumAngles
                           : zero_row_.data();
    const std::int32_t* qo = q_row(y + 1);
    const std::int32_t* bp = b_row(y + 1);
    const std::int32_t* bo = b_row(y + 2 - b);
    std::int32_t* bn = b_row(y + 2);
    std::int32_t* bb = bb_.data();
    std::int32_t* t = t_.data() + lead_ * NumAngles;
    cut_rows_.clear();
    for (const cut_tap& c : cut_) cut_rows_.push_back(q_row(y + c.offset));
    const auto run = [&](auto one_far_cut) {
      const ibatch half(std::int32_t{1} << (shift_ - 1));
      const batch scale(scale_);
      const Eigen::Index n = n_;
      for (Eigen::Index i = 0; i < n; i += width) {
        const ibatch q_new = xsimd::nearbyint_as_int(batch::load_unaligned(src + i) * scale);
        q_new.store_unaligned(qn + i);
        const ibatch b_new =
            ibatch::load_unaligned(bp + i) + q_new - ibatch::load_unaligned(qo + i);
        const ibatch bb_old = ibatch::load_unaligned(bb + i);
        const ibatch bb_new = bb_old + b_new - ibatch::load_unaligned(bo + i);
        ibatch sum = bb_old + bb_new;
        if constexpr (decltype(one_far_cut)::value) {
          sum -= q_new;
        } else {
          for (std::size_t c = 0; c < cut_.size(); ++c) {
            sum -= ibatch(cut_[c].weight) * ibatch::load_unaligned(cut_rows_[c] + i);
          }
        }
        b_new.store_unaligned(bn + i);
        bb_new.store_unaligned(bb + i);
        ((sum + half) >> shift_).store_unaligned(t + i);
      }
    };
    if (one_far_cut()) {
      run(std::true_type{});
    } else {
      run(std::false_type{});
    }
  }

  /// The cut of an even number of bins (sift_lite): one tap of weight 1 at offset b + 1, the
  /// newest value of each running sum, so no extra load or multiply.
  [[nodiscard]] bool one_far_cut() const {
    return cut_.size() == 1 && cut_[0].offset == bin_ + 1 && cut_[0].weight == 1;
  }

  /// The same three steps along the row in t_ (pixel-major: a pixel's NumAngles values are
  /// `regs` registers, each its own running sum kept in registers along the row).
  void horizontal(float* out) {
    const Eigen::Index b = bin_;
    const Eigen::Index off = 2 * b;  // hb_ holds B(z) at (z + off) * NumAngles
    const std::int32_t* t = t_.data() + lead_ * NumAngles;
    std::int32_t* hb = hb_.data() + off * NumAngles;
    const batch unscale(unscale_);
    std::array<ibatch, regs> b_prev;
    std::array<ibatch, regs> bb;
    b_prev.fill(ibatch(0));
    bb.fill(ibatch(0));
    // One step of the running sums at pixel x; the output only from x = 0 on (the first b + 1
    // steps start the sums in the zero margin).
    const auto step = [&](Eigen::Index x, auto output, auto one_far_cut) {
      for (std::size_t k = 0; k < regs; ++k) {
        const Eigen::Index lane = static_cast<Eigen::Index>(k) * width;
        const ibatch t_new = ibatch::load_unaligned(t + (x + b + 1) * NumAngles + lane);
        const ibatch b_new =
            b_prev[k] + t_new - ibatch::load_unaligned(t + (x + 1) * NumAngles + lane);
        b_new.store_unaligned(hb + (x + 2) * NumAngles + lane);
        const ibatch bb_new =
            bb[k] + b_new - ibatch::load_unaligned(hb + (x + 2 - b) * NumAngles + lane);
        if constexpr (decltype(output)::value) {
          ibatch sum = bb[k] + bb_new;
          if constexpr (decltype(one_far_cut)::value) {
            sum -= t_new;
          } else {
            for (const cut_tap& c : cut_) {
              sum -=
                  ibatch(c.weight) * ibatch::load_unaligned(t + (x + c.offset) * NumAngles + lane);
            }
          }
          (xsimd::to_float(sum) * unscale).store_unaligned(out + x * NumAngles + lane);
        }
        bb[k] = bb_new;
        b_prev[k] = b_new;
      }
    };
    for (Eigen::Index x = -b - 1; x < 0; ++x) step(x, std::false_type{}, std::false_type{});
    if (one_far_cut()) {
      for (Eigen::Index x = 0; x < nx_; ++x) step(x, std::true_type{}, std::true_type{});
    } else {
      for (Eigen::Index x = 0; x < nx_; ++x) step(x, std::true_type{}, std::false_type{});
    }
  }

  const float* channels_;
  Eigen::Index h_;
  Eigen::Index w_;
  Eigen::Index margin_;
  Eigen::Index bin_;
  Eigen::Index nx_;
  Eigen::Index n_;      ///< values in one image row of channels
  Eigen::Index slots_;  ///< rows in each ring: b + 1
  int shift_ = 0;
  float scale_ = 1.0F;
  float unscale_ = 1.0F;
  Eigen::Index y_;
  std::vector<cut_tap> cut_;
  std::vector<const std::int32_t*> cut_rows_;  ///< the cut taps' quantised rows, this row
  std::vector<std::int32_t> q_;                ///< ring of quantised rows
  std::vector<std::int32_t> b_;                ///< ring of first box sums
  std::vector<std::int32_t> bb_;               ///< second box sums of the current row
  std::vector<std::int32_t> t_;   ///< the current row's vertical sums, shifted, zero margins
  Eigen::Index lead_ = 0;         ///< zero pixels in t_ before the image's first column
  std::vector<float> zero_row_;   ///< what the rows below the image read: zeros
  std::vector<std::int32_t> hb_;  ///< first horizontal box sums along the row
};

/// Pools the NumBins x NumBins bins of single patches straight from the orientation channels
/// (layout of `orientation_channels`, `margin` >= every tap's |offset|): what `row_pooler` gives
/// at the patch's bin positions, without pooling whole rows. Same arithmetic in the same order
/// (vertical sums over the taps first, then the horizontal sum of those), so the result is
/// `row_pooler`'s to the last bit up to the compiler's contraction choices.
///
/// Per bin row, the vertical sums are taken once over the columns that any bin of that row reads
/// ((NumBins - 1) * bin + the kernel's span); each bin then sums its taps out of that scratch
/// row. For sift_lite (17 taps) that is 2 x 26 x 17 + 4 x 17 vector FMAs per patch.
template <int NumBins, int NumAngles, class T>
class patch_pooler {
 public:
  patch_pooler(const std::vector<pooling_tap<T>>& taps, const T* channels, Eigen::Index w,
               Eigen::Index margin, Eigen::Index bin)
      : channels_(channels),
        row_size_((w + 2 * margin) * NumAngles),
        margin_(margin),
        bin_(bin),
        weight_(taps.size()),
        offset_(taps.size()),
        src_(taps.size()) {
    for (std::size_t t = 0; t < taps.size(); ++t) {
      weight_[t] = taps[t].weight;
      offset_[t] = taps[t].offset;
    }
    const auto [lo, hi] = std::minmax_element(offset_.begin(), offset_.end());
    first_ = taps.empty() ? 0 : *lo;
    span_ = taps.empty() ? 0 : (NumBins - 1) * bin + *hi - first_ + 1;
    vertical_.resize(static_cast<std::size_t>(span_ * NumAngles));
  }

  /// Writes the NumBins^2 * NumAngles pooled values of the patch with top-left (r, c) to `out`,
  /// element k + NumAngles * (by + NumBins * bx) (dense_sift's element order).
  void operator()(Eigen::Index r, Eigen::Index c, T* out) {
    using angles = Eigen::Array<T, NumAngles, 1>;
    const std::size_t taps = weight_.size();
    const Eigen::Index x0 = c + first_ + margin_;  // first column the bins read, in the layout
    for (Eigen::Index by = 0; by < NumBins; ++by) {
      const Eigen::Index y = r + by * bin_ + margin_;
      for (std::size_t t = 0; t < taps; ++t) {
        src_[t] = channels_ + (y + offset_[t]) * row_size_ + x0 * NumAngles;
      }
      weighted_sum(src_.data(), weight_.data(), taps, vertical_.data(), span_ * NumAngles);
      // Each bin: one orientation vector, its taps accumulated in registers (weighted_sum's
      // arithmetic for a row of NumAngles values).
      for (Eigen::Index bx = 0; bx < NumBins; ++bx) {
        const T* v = vertical_.data() + (bx * bin_ - first_) * NumAngles;
        angles acc = angles::Zero();
        for (std::size_t t = 0; t < taps; ++t) {
          acc += weight_[t] * Eigen::Map<const angles>(v + offset_[t] * NumAngles);
        }
        Eigen::Map<angles>(out + NumAngles * (by + NumBins * bx)) = acc;
      }
    }
  }

 private:
  const T* channels_;
  Eigen::Index row_size_;
  Eigen::Index margin_;
  Eigen::Index bin_;
  Eigen::Index first_ = 0;  ///< smallest tap offset
  Eigen::Index span_ = 0;   ///< columns one bin row's vertical sums cover
  std::vector<T> weight_;
  std::vector<Eigen::Index> offset_;
  std::vector<const T*> src_;
  std::vector<T> vertical_;
};

/// `normalise` with Eigen, for any `Size`: the norms of a whole block are computed together
/// (one descriptor at a time was a chain of dependent reductions, square roots and divisions
/// that took 40% of the dense run). `normalise` runs `normalise_simd` instead where a descriptor
/// is whole registers.
template <int Size, class T>
void normalise_eigen(T* data, Eigen::Index count, T threshold, T clamp) {
  using block = Eigen::Map<Eigen::Array<T, Size, Eigen::Dynamic>>;
  using row = Eigen::Array<T, 1, Eigen::Dynamic>;
  block v(data, Size, count);
  // Separate statements: sqrt and 1/x then vectorise across the block.
  row norm = v.square().colwise().sum();
  norm = norm.sqrt();
  const row inverse = norm.max(std::numeric_limits<T>::min()).inverse();  // finite, even for 0
  bool any = false;
  for (Eigen::Index i = 0; i < count; ++i) {
    if (norm(i) > threshold) {
      v.col(i) = (v.col(i) * inverse(i)).min(clamp);
      any = true;
    }
  }
  if (!any) return;
  // Non-zero: the elements of a unit vector that were > 0 are still > 0 after the clamp.
  row renorm = v.square().colwise().sum();
  renorm = renorm.sqrt().inverse();
  for (Eigen::Index i = 0; i < count; ++i) {
    if (norm(i) > threshold) v.col(i) *= renorm(i);
  }
}

}  // namespace tacmap::detail::dsift

namespace tacmap::detail::dsift {

/// Descriptors 0..count-1 of a chunk (count <= chunk_groups registers' width), normalised as
/// `normalise` does, written to out + j * Size: load(j, i) gives elements [i, i + width) of
/// descriptor j before normalisation, norm2[g] the squared norms of descriptors
/// [g width, (g + 1) width) (lane j). Weak descriptors (norm <= threshold) take the same path
/// with scale 1 and no clamp, which leaves them exactly as they are; the clamped norms'
/// horizontal sums are taken for a whole register at once (a transpose-and-add tree,
/// xsimd::haddp).
///
/// Why a chunk of registers, each step over all of them before the next: a register's two
/// sqrt-and-divide chains (first norm, then the clamped one) are about 60 cycles of latency
/// against some 40 of arithmetic per descriptor register; step by step over several registers
/// they overlap (perf at 120 px: the divisions and the compares waiting on them were a quarter
/// of the pass). The same operations on the same values as one register at a time: bit for bit.
template <class A, int Size, int ChunkGroups, class T, class Load>
inline void normalise_chunk(const Load& load, const xsimd::batch<T, A>* norm2, Eigen::Index count,
                            T threshold, T clamp, T* out) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  constexpr auto lanes = static_cast<std::size_t>(ChunkGroups) * batch::size;
  const Eigen::Index groups = (count + width - 1) / width;
  const batch one(T(1));
  alignas(batch) std::array<T, lanes> scale{};
  alignas(batch) std::array<T, lanes> limit{};
  alignas(batch) std::array<T, lanes> renorm{};
  alignas(batch) std::array<batch, batch::size> sums;
  for (Eigen::Index g = 0; g < groups; ++g) {
    const batch norm = xsimd::sqrt(norm2[g]);
    const auto strong = norm > batch(threshold);
    // 1 / max(norm, smallest normal) stays finite (as `normalise`).
    xsimd::select(strong, one / xsimd::max(norm, batch(std::numeric_limits<T>::min())), one)
        .store_aligned(scale.data() + g * width);
    xsimd::select(strong, batch(clamp), batch(std::numeric_limits<T>::infinity()))
        .store_aligned(limit.data() + g * width);
  }
  // The clamped norms first, then each element computed again and stored once, scaled: one
  // store per element instead of a store, a reload and a second store (the fused pass of
  // `compute` about 10 % faster by perf samples at 120 px; the same values bit for bit).
  for (Eigen::Index g = 0; g < groups; ++g) {
    const Eigen::Index first = g * width, group = std::min(width, count - first);
    for (Eigen::Index j = 0; j < group; ++j) {
      const auto k = static_cast<std::size_t>(first + j);
      const batch s(scale[k]);
      const batch l(limit[k]);
      batch acc(T(0));
      for (Eigen::Index i = 0; i < Size; i += width) {
        const batch v = xsimd::min(load(first + j, i) * s, l);
        acc = xsimd::fma(v, v, acc);
      }
      sums[static_cast<std::size_t>(j)] = acc;
    }
    for (Eigen::Index j = group; j < width; ++j) sums[static_cast<std::size_t>(j)] = one;
    xsimd::haddp(sums.data()).store_aligned(renorm.data() + first);
  }
  for (Eigen::Index g = 0; g < groups; ++g) {
    T* r = renorm.data() + g * width;
    const auto strong = xsimd::sqrt(norm2[g]) > batch(threshold);
    xsimd::select(strong, one / xsimd::sqrt(batch::load_aligned(r)), one).store_aligned(r);
  }
  // min(v s, l) n = min(v (s n), l n) for n > 0 (rounding is monotone), one multiply fewer per
  // register; v (s n) and (v s) n may differ in the last bit (weak descriptors: s = n = 1, exact).
  for (Eigen::Index j = 0; j < count; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const batch sn(scale[k] * renorm[k]);
    const batch ln(limit[k] * renorm[k]);
    T* d = out + j * Size;
    for (Eigen::Index i = 0; i < Size; i += width) {
      xsimd::min(load(j, i) * sn, ln).store_unaligned(d + i);
    }
  }
}

/// Registers of descriptors per `normalise_chunk`: enough to overlap the sqrt-and-divide
/// chains, few enough for its arrays to stay about 1 KB (8: 157 us for the 120 px field, 4: 159,
/// 2: 161, 1 (before): 173, one run).
inline constexpr int normalise_chunk_groups = 8;

/// Whether the hand-vectorised normalisation serves descriptors of `Size` elements of T on the
/// header's architecture (whole registers); otherwise the Eigen version runs.
template <int Size, class T>
inline constexpr bool simd_normalise =
    Size % static_cast<int>(xsimd::batch<T, kernel_arch<T>>::size) == 0;

/// `normalise` hand-vectorised (A's registers, Size a multiple of their width): a chunk of
/// `normalise_chunk_groups` registers' worth of descriptors at a time (`normalise_chunk`), each
/// register's squared norms reduced together with xsimd::haddp instead of one horizontal sum
/// per descriptor and pass (about 85 instructions per 32-float
/// descriptor before). Equal to `normalise_scalar` up to the order of the sums.
template <class A, int Size, class T>
void normalise_simd(T* data, Eigen::Index count, T threshold, T clamp) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  constexpr Eigen::Index chunk = normalise_chunk_groups * width;
  static_assert(Size % width == 0, "a descriptor must be whole registers");
  alignas(batch) std::array<batch, batch::size> sums;
  std::array<batch, normalise_chunk_groups> norm2;
  for (Eigen::Index c0 = 0; c0 < count; c0 += chunk) {
    const Eigen::Index n = std::min(chunk, count - c0);
    T* block = data + c0 * Size;
    for (Eigen::Index g = 0; g * width < n; ++g) {
      for (Eigen::Index j = 0; j < width; ++j) {
        const Eigen::Index at = g * width + j;
        batch acc(T(0));
        if (at < n) {
          for (Eigen::Index i = 0; i < Size; i += width) {
            const batch v = batch::load_unaligned(block + at * Size + i);
            acc = xsimd::fma(v, v, acc);
          }
        }
        sums[static_cast<std::size_t>(j)] = acc;
      }
      norm2[static_cast<std::size_t>(g)] = xsimd::haddp(sums.data());
    }
    normalise_chunk<A, Size, normalise_chunk_groups>(
        [block](Eigen::Index j, Eigen::Index i) {
          return batch::load_unaligned(block + j * Size + i);
        },
        norm2.data(), n, threshold, clamp, block);
  }
}

/// `normalise` one descriptor and element at a time, summing in double (the tests' reference
/// for the vectorised versions).
template <int Size, class T>
void normalise_scalar(T* data, Eigen::Index count, T threshold, T clamp) {
  for (Eigen::Index c = 0; c < count; ++c) {
    T* d = data + c * Size;
    double norm = 0.0;
    for (Eigen::Index i = 0; i < Size; ++i) norm += static_cast<double>(d[i]) * d[i];
    norm = std::sqrt(norm);
    if (!(norm > static_cast<double>(threshold))) continue;
    double renorm = 0.0;
    for (Eigen::Index i = 0; i < Size; ++i) {
      d[i] = static_cast<T>(std::min(static_cast<double>(d[i]) / norm, static_cast<double>(clamp)));
      renorm += static_cast<double>(d[i]) * d[i];
    }
    renorm = std::sqrt(renorm);
    for (Eigen::Index i = 0; i < Size; ++i) d[i] = static_cast<T>(d[i] / renorm);
  }
}

/// q[x] = the squared L2 norm of pixel x's NumAngles values in a pooled row (`row_pooler`'s
/// layout), x in [0, n). A descriptor's squared norm is the sum of its NumBins^2 bins' q, and
/// each pooled pixel is a bin of NumBins^2 descriptors: taken once per pooled row, these replace
/// one horizontal reduction per descriptor (`assemble_normalise_simd`).
template <class A, int NumAngles, class T>
void pixel_square_norms_simd(const T* row, Eigen::Index n, T* q) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  Eigen::Index x = 0;
  if constexpr (NumAngles % width == 0) {
    constexpr Eigen::Index regs = NumAngles / width;  // registers per pixel
    alignas(batch) std::array<batch, batch::size> sq;
    for (; x + width <= n; x += width) {
      for (Eigen::Index p = 0; p < width; ++p) {
        const T* px = row + (x + p) * NumAngles;
        batch s(T(0));
        for (Eigen::Index r = 0; r < regs; ++r) {
          const batch v = batch::load_unaligned(px + r * width);
          s = xsimd::fma(v, v, s);
        }
        sq[static_cast<std::size_t>(p)] = s;
      }
      xsimd::haddp(sq.data()).store_unaligned(q + x);
    }
  }
  for (; x < n; ++x) {
    T s = 0;
    for (int k = 0; k < NumAngles; ++k) s += row[x * NumAngles + k] * row[x * NumAngles + k];
    q[x] = s;
  }
}

/// `dense_sift::compute`'s descriptors of one patch row, assembled from the pooled rows and
/// normalised in one pass (what assembling followed by `normalise` gives, up to the order of the
/// sums): descriptor c in [0, count) is written to out + c * NumBins^2 * NumAngles, bin
/// (by, bx) read from rows[by] + (c + bx * bin) * NumAngles, its squared norm the sum of
/// squares[by][c + bx * bin] (`pixel_square_norms_simd`).
///
/// Why: assembling copied every descriptor and `normalise` read it twice more, reducing each one
/// horizontally in each pass; together about 110 instructions per 32-float descriptor, 40 % of
/// the dense field. Here the first norm costs NumBins^2 vector adds per register of descriptors.
/// `squares` rows must be readable (any finite value) up to index
/// (NumBins - 1) * bin + count + register width - 2. `assemble_normalise_scalar` is the tests'
/// reference.
template <class A, int NumBins, int NumAngles, class T>
void assemble_normalise_simd(const T* const* rows, const T* const* squares, Eigen::Index bin,
                             Eigen::Index count, T threshold, T clamp, T* out) {
  using batch = xsimd::batch<T, A>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  constexpr Eigen::Index size = NumBins * NumBins * NumAngles;
  static_assert(NumAngles % width == 0, "a bin must be whole registers");
  constexpr Eigen::Index chunk = normalise_chunk_groups * width;
  std::array<batch, normalise_chunk_groups> norm2;
  for (Eigen::Index c0 = 0; c0 < count; c0 += chunk) {
    const Eigen::Index n = std::min(chunk, count - c0);
    for (Eigen::Index g = 0; g * width < n; ++g) {
      batch sum(T(0));
      for (Eigen::Index bx = 0; bx < NumBins; ++bx) {
        for (Eigen::Index by = 0; by < NumBins; ++by) {
          sum += batch::load_unaligned(squares[by] + c0 + g * width + bx * bin);
        }
      }
      norm2[static_cast<std::size_t>(g)] = sum;
    }
    normalise_chunk<A, size, normalise_chunk_groups>(
        [rows, bin, c0](Eigen::Index j, Eigen::Index i) {
          const Eigen::Index b = i / NumAngles;  // bin b = by + NumBins * bx
          return batch::load_unaligned(rows[b % NumBins] +
                                       (c0 + j + (b / NumBins) * bin) * NumAngles + i % NumAngles);
        },
        norm2.data(), n, threshold, clamp, out + c0 * size);
  }
}

/// `assemble_normalise_simd` one descriptor and element at a time (the tests' reference).
template <int NumBins, int NumAngles, class T>
void assemble_normalise_scalar(const T* const* rows, Eigen::Index bin, Eigen::Index count,
                               T threshold, T clamp, T* out) {
  constexpr Eigen::Index size = NumBins * NumBins * NumAngles;
  for (Eigen::Index c = 0; c < count; ++c) {
    T* d = out + c * size;
    for (Eigen::Index bx = 0; bx < NumBins; ++bx) {
      for (Eigen::Index by = 0; by < NumBins; ++by) {
        for (Eigen::Index k = 0; k < NumAngles; ++k) {
          d[k + NumAngles * (by + NumBins * bx)] = rows[by][(c + bx * bin) * NumAngles + k];
        }
      }
    }
  }
  normalise_scalar<size>(out, count, threshold, clamp);
}

/// Whether `assemble_normalise_simd` serves this layout on the header's architecture (a bin must
/// be whole registers; otherwise `dense_sift::compute` assembles and normalises separately).
template <int NumAngles, class T>
inline constexpr bool simd_assemble = simd_normalise<NumAngles, T>;

/// Lazebnik's normalisation "that respects flat areas", for `count` consecutive descriptors of
/// `Size` elements: a descriptor whose L2 norm exceeds `threshold` is scaled to unit length,
/// clamped at `clamp` and renormalised (Lowe's illumination step); a weaker one (flat or
/// contact-free region) is left as it is. `normalise_simd` on the header's architecture where a
/// descriptor is whole registers, `normalise_eigen` otherwise.
template <int Size, class T>
void normalise(T* data, Eigen::Index count, T threshold, T clamp) {
  if constexpr (simd_normalise<Size, T>) {
    normalise_simd<kernel_arch<T>, Size>(data, count, threshold, clamp);
  } else {
    normalise_eigen<Size>(data, count, threshold, clamp);
  }
}

/// `tacmap::detail::advise_huge_pages` (tacmap/detail/huge_pages.hpp), under its old name.
using tacmap::detail::advise_huge_pages;

}  // namespace tacmap::detail::dsift
