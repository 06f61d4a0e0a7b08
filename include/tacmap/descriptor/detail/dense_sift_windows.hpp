// tacmap: the pooled orientation channels of chosen patches of EVERY window of a map, from
// intermediates the windows share (issue 14): what dense_sift::compute gives on each window cut
// from the map, before its normalisation, without cutting a single window.
//
// Why it can be shared. Cut a window of H x W px from the map and describe it (dense_sift.hpp's
// pipeline). Then:
//  * Step 1 divides by the window's peak. Gradients and pooling are linear in the image and the
//    orientation (theta) does not change with a positive scale, so the window's pooled values
//    are (map peak / window peak) x those computed from map / (map peak). Only that factor is
//    per window; the normalise-and-clamp step comes after it (dense_sift::describe_windows).
//  * Step 2's filters reach R = 2 px (sigma_edge <= 1: 5 taps), exactly the 2 mirrored pixels.
//    A window pixel 2 px or more inside the window reads only window pixels, no padding: its
//    gradient is the map's there (the padded image's mean only adds mean x (sum of a derivative
//    kernel) = 0). A pixel in the 2 px frame reads mirrored pixels; WHICH pixels depends only
//    on its class along each axis (first, second, inner, second-to-last, last pixel of the
//    window line): `first` reads rows +1, 0, 0, +1, +2 around itself, and so on. So each of the
//    5 x 5 class pairs is one fixed 5 x 5 stencil over the map, the same for every window:
//    its gradients and channels are computed once, at the map pixels where some window has a
//    pixel of that class pair.
//  * Step 5 pools with channels zero outside the window. Bin (u, v) of the window (u, v its
//    sample point inside the window, the same for every window) sums w(i - u) w(j - v) C(i, j)
//    over the window pixels (i, j) its taps reach. Split its rows into the inner ones (a
//    contiguous tap range tau(u), fixed per u) and the frame rows it reaches, its columns
//    likewise (sigma(v)): the inner x inner part is the map's channels pooled with the taps
//    tau(u) x sigma(v), read at (r0 + u, c0 + v) - one dense field per distinct (tau, sigma),
//    shared by all windows; the frame x inner parts are a frame class's channels pooled along
//    the other axis (again dense fields), and frame x frame is single pixels. Each bin of window
//    (r0, c0) is then a handful of terms read at fixed offsets from (r0, c0): a whole row of
//    windows is one `weighted_sum` per bin.
// The pooling taps are the descriptor's own (`make_pooling_taps`: SIFT-lite's bins reaching 7 px
// above/left of a patch, the kernel's last tap cut off), so those semantics carry over as they are.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstddef>
#include <span>
#include <utility>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/descriptor/detail/dense_sift_kernels.hpp"
#include "tacmap/detail/weighted_sum.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"

namespace tacmap::detail::dsift {

/// NumAngles values per point of a rectangle [y0, y0 + rows) x [x0, x0 + cols) of an index
/// space (map pixels, or window top-left rows/columns), row-major, angles innermost.
template <int NumAngles, class T>
struct angle_block {
  Eigen::Array<T, Eigen::Dynamic, 1> data;
  Eigen::Index y0 = 0, x0 = 0, rows = 0, cols = 0;

  /// The rectangle becomes [top, top + n_rows) x [left, left + n_cols); values unspecified. The
  /// storage only grows (a band of rows reuses it: no fresh pages per band).
  void reshape(Eigen::Index top, Eigen::Index left, Eigen::Index n_rows, Eigen::Index n_cols) {
    y0 = top;
    x0 = left;
    rows = std::max<Eigen::Index>(n_rows, 0);
    cols = std::max<Eigen::Index>(n_cols, 0);
    if (data.size() < rows * cols * NumAngles) resize_fresh(data, rows * cols * NumAngles);
  }
  /// Moves the rectangle down to rows [top, end) (top >= y0, same columns), keeping the values
  /// of the rows it already has there (moved to the front of the storage). Returns the first
  /// row whose values are unspecified (`end` when every row was kept).
  Eigen::Index slide(Eigen::Index top, Eigen::Index end, Eigen::Index left, Eigen::Index n_cols) {
    Eigen::Index first = top;
    const Eigen::Index had_end = y0 + rows;
    if (!empty() && x0 == left && cols == n_cols && top >= y0 && top < had_end) {
      const Eigen::Index kept = std::min(had_end, end) - top;
      if (top > y0) {
        T* d = data.data();
        std::copy(d + (top - y0) * row_stride(), d + (top - y0 + kept) * row_stride(), d);
      }
      first = top + kept;
      const Eigen::Index n = (end - top) * n_cols * NumAngles;
      if (data.size() < n) data.conservativeResize(n);  // keeps the moved rows
    }
    reshape(top, left, end - top, n_cols);
    return first;
  }
  [[nodiscard]] bool empty() const { return rows == 0 || cols == 0; }
  [[nodiscard]] Eigen::Index row_stride() const { return cols * NumAngles; }
  /// The point (y, x) (no bounds check: callers read inside the rectangle).
  [[nodiscard]] const T* at(Eigen::Index y, Eigen::Index x) const {
    return data.data() + ((y - y0) * cols + (x - x0)) * NumAngles;
  }
  [[nodiscard]] T* at(Eigen::Index y, Eigen::Index x) {
    return data.data() + ((y - y0) * cols + (x - x0)) * NumAngles;
  }
};

/// Classes of the pixels of a window line (a row or column of n >= 2 mirror_pad pixels) for the
/// gradient filters: the first mirror_pad pixels, the inner ones, the last mirror_pad.
inline constexpr int frame_width = static_cast<int>(mirror_pad);
inline constexpr int line_classes = 2 * frame_width + 1;
inline constexpr int inner_class = frame_width;

/// The class of pixel i of a window line of n pixels: 0 .. frame_width - 1 for the first pixels,
/// inner_class, then inner_class + 1 .. for the last ones (the last pixel is line_classes - 1).
inline int line_class(Eigen::Index i, Eigen::Index n) {
  if (i < frame_width) return static_cast<int>(i);
  if (i >= n - frame_width) return line_classes - static_cast<int>(n - i);
  return inner_class;
}

/// The pixel of a window line that represents a frame class (its position in the window line).
inline Eigen::Index class_pixel(int cls, Eigen::Index n) {
  return cls < inner_class ? cls : n - (line_classes - cls);
}

/// Where the 2 radius + 1 gradient taps of a pixel of class `cls` read, relative to the pixel,
/// in a window line of n pixels: the mirrored padding of `padded_image` as source offsets.
inline std::vector<Eigen::Index> class_sources(int cls, Eigen::Index n, Eigen::Index radius) {
  std::vector<Eigen::Index> d(static_cast<std::size_t>(2 * radius + 1));
  for (Eigen::Index a = -radius; a <= radius; ++a) {
    Eigen::Index off = a;
    if (cls != inner_class) {
      const Eigen::Index i = class_pixel(cls, n);
      off = mirror(i + a, n) - i;
    }
    d[static_cast<std::size_t>(a + radius)] = off;
  }
  return d;
}

/// Whether the derivative taps are antisymmetric about a zero centre (D(-b) = -D(b), D(0) = 0),
/// as `make_gradient_taps` builds them: `window_pooler` applies them as paired differences.
template <class T>
bool antisymmetric(const gradient_taps<T>& taps) {
  const Eigen::Index r = taps.radius;
  if (taps.derivative.size() != 2 * r + 1 || taps.derivative(r) != T(0)) return false;
  for (Eigen::Index b = 1; b <= r; ++b)
    if (taps.derivative(r - b) != -taps.derivative(r + b)) return false;
  return true;
}

/// The peak (largest magnitude) of every window of `map`: rows x cols, entry (r, c) the window
/// with top-left (r, c). Two separable running maxima.
template <class T>
image<T> window_peaks(const image_view<T>& map, pixel_size window) {
  const Eigen::Index rows = map.rows() - window.height + 1;
  const Eigen::Index cols = map.cols() - window.width + 1;
  const image<T> magnitude = map.abs();
  image<T> across = magnitude.leftCols(cols);
  for (Eigen::Index j = 1; j < window.width; ++j)
    across = across.max(magnitude.middleCols(j, cols));
  image<T> peaks = across.topRows(rows);
  for (Eigen::Index i = 1; i < window.height; ++i) peaks = peaks.max(across.middleRows(i, rows));
  return peaks;
}

/// The bins of every window along one axis (rows or columns): the distinct sample positions u of
/// the bins inside the window, the inner taps and frame pixels each one pools, and the groups of
/// positions that pool the same inner taps (one dense pooled field per group).
template <class T>
struct axis_plan {
  struct frame_pixel {
    int cls;   ///< line class of the frame pixel
    T weight;  ///< w(i - u)
  };
  struct position {
    Eigen::Index u = 0;
    int group = -1;  ///< inner tap group, -1 when the bin reaches no inner pixel
    std::vector<frame_pixel> frame;
  };
  struct group {
    Eigen::Index lo = 0, hi = 0;       ///< inner tap offsets [lo, hi]
    Eigen::Index begin = 0, end = 0;   ///< sample points it is read at: [begin, end)
    std::vector<pooling_tap<T>> taps;  ///< taps lo .. hi
  };
  std::vector<position> positions;
  std::vector<group> groups;
  std::array<bool, line_classes> frame_used{};  ///< frame classes some bin reaches

  /// n: window pixels along the axis; count: window positions along it (map - n + 1).
  axis_plan(std::vector<Eigen::Index> us, Eigen::Index n, Eigen::Index count,
            const std::vector<pooling_tap<T>>& taps) {
    std::sort(us.begin(), us.end());
    us.erase(std::unique(us.begin(), us.end()), us.end());
    const Eigen::Index inner_lo = frame_width;
    const Eigen::Index inner_hi = n - frame_width - 1;  // last inner pixel
    for (const Eigen::Index u : us) {
      position p;
      p.u = u;
      Eigen::Index lo = inner_lo - u;
      Eigen::Index hi = inner_hi - u;
      std::vector<pooling_tap<T>> inner;
      for (const pooling_tap<T>& t : taps) {
        const Eigen::Index i = u + t.offset;
        if (i < 0 || i >= n) continue;  // zero outside the window
        const int cls = line_class(i, n);
        if (cls == inner_class) {
          inner.push_back(t);
        } else {
          p.frame.push_back({cls, t.weight});
          frame_used[static_cast<std::size_t>(cls)] = true;
        }
      }
      if (!inner.empty()) {
        lo = inner.front().offset;
        hi = inner.back().offset;
        auto same = std::find_if(groups.begin(), groups.end(),
                                 [&](const group& g) { return g.lo == lo && g.hi == hi; });
        if (same == groups.end()) {
          groups.push_back({lo, hi, u, u + count, inner});
          same = groups.end() - 1;
        }
        same->begin = std::min(same->begin, u);
        same->end = std::max(same->end, u + count);
        p.group = static_cast<int>(same - groups.begin());
      }
      positions.push_back(std::move(p));
    }
  }

  [[nodiscard]] int index_of(Eigen::Index u) const {
    for (std::size_t k = 0; k < positions.size(); ++k)
      if (positions[k].u == u) return static_cast<int>(k);
    return -1;
  }
};

/// The pooled orientation channels (dense_sift's pipeline steps 2-5, before its normalisation) of
/// the patches at `offsets` of every window of a map, each as `compute` on the window cut from
/// the map gives them, in units of `scaled_map` (the caller multiplies by that map's scale over
/// the window's peak, see the file comment). Needs taps.radius == mirror_pad and a window of at
/// least 2 mirror_pad px on each side (dense_sift::describe_windows checks).
template <int NumBins, int NumAngles, class T>
class window_pooler {
 public:
  using array = Eigen::Array<T, Eigen::Dynamic, 1>;
  using block = angle_block<NumAngles, T>;

  window_pooler(const image<T>& scaled_map, pixel_size window, std::span<const grid_cell> offsets,
                Eigen::Index bin, const gradient_taps<T>& gradient,
                const std::vector<pooling_tap<T>>& pooling,
                const Eigen::Array<T, NumAngles, 1>& cos_a,
                const Eigen::Array<T, NumAngles, 1>& sin_a, double alpha,
                Eigen::Index band_rows = default_band_rows)
      : map_(scaled_map),
        h_(window.height),
        w_(window.width),
        rows_(scaled_map.rows() - window.height + 1),
        cols_(scaled_map.cols() - window.width + 1),
        m_count_(static_cast<Eigen::Index>(offsets.size())),
        gradient_(gradient),
        cos_a_(cos_a),
        sin_a_(sin_a),
        alpha_(alpha),
        rows_plan_(bin_positions(offsets, bin, true), h_, rows_, pooling),
        cols_plan_(bin_positions(offsets, bin, false), w_, cols_, pooling),
        band_(std::clamp<Eigen::Index>(band_rows, 1, std::max<Eigen::Index>(rows_, 1))) {
    TACMAP_ASSERT(gradient.radius == mirror_pad && antisymmetric(gradient),
                  "window_pooler: gradient taps of radius mirror_pad, antisymmetric");
    TACMAP_ASSERT(h_ >= 2 * mirror_pad && w_ >= 2 * mirror_pad, "window_pooler: window too small");
    size_fields();
    build_bins(offsets, bin);
  }

  /// Window rows whose shared fields are built at a time (`band_rows`' default): the fields
  /// then take (band + window height) rows instead of the whole map's, reused band after band.
  /// At 640 x 480 the whole-map fields were ~40 blocks of ~10 MB, and faulting in that fresh
  /// memory cost more than computing it (bench/camera_bench.cpp, build rows).
  static constexpr Eigen::Index default_band_rows = 32;

  window_pooler(const window_pooler&) = delete;
  window_pooler& operator=(const window_pooler&) = delete;

  [[nodiscard]] Eigen::Index rows() const { return rows_; }
  [[nodiscard]] Eigen::Index cols() const { return cols_; }

  /// The pooled values of the windows with top-left (r0, c0), c0 = 0 .. cols() - 1, times
  /// factor[c0]: patch m of window c0 in column c0 * M + m of `out` (NumBins^2 * NumAngles
  /// rows, column-major), in dense_sift's element order, unnormalised.
  /// Fastest called with r0 = 0, 1, 2, ... (the fields are built a band of rows at a time, each
  /// row once); any order gives the same values.
  void operator()(Eigen::Index r0, const T* factor, T* out) {
    TACMAP_ASSERT(r0 >= 0 && r0 < rows_, "window_pooler: window row outside the map");
    if (r0 < band_lo_ || r0 >= band_hi_) build_band(r0, std::min(rows_, r0 + band_));
    const Eigen::Index n = cols_ * NumAngles;
    for (std::size_t b = 0; b < bins_.size(); ++b) {
      const bin_terms& terms = bins_[b];
      T* row = rows_buffer_.data() + static_cast<Eigen::Index>(b) * n;
      if (terms.source.empty()) {
        std::fill(row, row + n, T(0));
        row_of_[b] = row;
        continue;
      }
      if (terms.source.size() == 1 && terms.weight[0] == T(1)) {  // one dense field: read it
        row_of_[b] = terms.source[0]->at(r0 + terms.dy[0], terms.dx[0]);
        continue;
      }
      for (std::size_t t = 0; t < terms.source.size(); ++t)
        sources_[t] = terms.source[t]->at(r0 + terms.dy[t], terms.dx[t]);
      weighted_sum(sources_.data(), terms.weight.data(), terms.source.size(), row, n);
      row_of_[b] = row;
    }
    using angles = Eigen::Array<T, NumAngles, 1>;
    constexpr Eigen::Index dim = NumBins * NumBins * NumAngles;
    for (Eigen::Index c = 0; c < cols_; ++c) {
      const T f = factor[c];
      for (Eigen::Index m = 0; m < m_count_; ++m) {
        T* col = out + (c * m_count_ + m) * dim;
        for (Eigen::Index e = 0; e < NumBins * NumBins; ++e) {
          const T* src = row_of_[static_cast<std::size_t>(
                             bin_of_[static_cast<std::size_t>(m * NumBins * NumBins + e)])] +
                         c * NumAngles;
          Eigen::Map<angles>(col + e * NumAngles) = f * Eigen::Map<const angles>(src);
        }
      }
    }
  }

 private:
  struct bin_terms {
    std::vector<const block*> source;  ///< the term's field, read at (r0 + dy, dx)
    std::vector<Eigen::Index> dy, dx;
    std::vector<T> weight;
    void add(const block& s, Eigen::Index y, Eigen::Index x, T w) {
      source.push_back(&s);
      dy.push_back(y);
      dx.push_back(x);
      weight.push_back(w);
    }
  };

  // Sample positions (inside the window) of every bin of every patch along one axis.
  static std::vector<Eigen::Index> bin_positions(std::span<const grid_cell> offsets,
                                                 Eigen::Index bin, bool along_rows) {
    std::vector<Eigen::Index> us;
    for (const grid_cell& o : offsets)
      for (Eigen::Index b = 0; b < NumBins; ++b)
        us.push_back((along_rows ? o.row : o.col) + b * bin);
    return us;
  }

  // Gradients and orientation channels at index points (y, x), y in [y0, y0 + nr), x in
  // [x0, x0 + nc), each at map pixel (y + sy, x + sx) and reading map rows y + sy + dy[a] and
  // columns x + sx + dx[b] (a, b = 0 .. 2 radius): one class pair's stencil.
  void class_channels(Eigen::Index y0, Eigen::Index nr, Eigen::Index sy,
                      const std::vector<Eigen::Index>& dy, Eigen::Index x0, Eigen::Index nc,
                      Eigen::Index sx, const std::vector<Eigen::Index>& dx, block& out) {
    out.reshape(y0, x0, nr, nc);
    if (out.empty()) return;
    const auto taps = static_cast<std::size_t>(2 * gradient_.radius + 1);
    const auto [dy_lo, dy_hi] = std::minmax_element(dy.begin(), dy.end());
    const Eigen::Index top = y0 + sy + *dy_lo;  // first map row read
    const Eigen::Index n_src = (nr - 1) + (*dy_hi - *dy_lo) + 1;
    // Horizontal pass over the map rows read: derivative (for gx) and smoothing (for gy).
    grow(hd_, n_src * nc);
    grow(hs_, n_src * nc);
    sources_.resize(std::max(sources_.size(), taps));
    const Eigen::Index stride = map_.cols();
    for (Eigen::Index k = 0; k < n_src; ++k) {
      const T* row = map_.data() + (top + k) * stride + x0 + sx;
      for (std::size_t b = 0; b < taps; ++b) sources_[b] = row + dx[b];
      derivative(sources_.data(), hd_.data() + k * nc, nc);
      weighted_sum(sources_.data(), gradient_.smooth.data(), taps, hs_.data() + k * nc, nc);
    }
    // Vertical pass: every output row reads the same row offsets, so it is one flat sum.
    grow(gx_, nr * nc);
    grow(gy_, nr * nc);
    for (std::size_t a = 0; a < taps; ++a) sources_[a] = hd_.data() + (dy[a] - *dy_lo) * nc;
    weighted_sum(sources_.data(), gradient_.smooth.data(), taps, gx_.data(), nr * nc);
    for (std::size_t a = 0; a < taps; ++a) sources_[a] = hs_.data() + (dy[a] - *dy_lo) * nc;
    derivative(sources_.data(), gy_.data(), nr * nc);
    orientation_channels<NumAngles>(gx_, gy_, nr, nc, nc, 0, cos_a_, sin_a_, alpha_, out.data);
  }

  // Scratch of at least n elements: it only grows, so that the calls of band after band (each
  // its own size) reuse it rather than free and map it again (brk churn: 5x the page faults).
  static void grow(array& a, Eigen::Index n) {
    if (a.size() < n) resize_fresh(a, n);
  }

  // out[i] = sum_{b = 1..radius} D(b) (src[radius + b][i] - src[radius - b][i]): the derivative
  // filter as differences of the pixels its antisymmetric taps pair (D(-b) = -D(b), D(0) = 0;
  // `antisymmetric`). A flat stretch then has exactly zero gradient, as `compute` gives on a
  // constant window (whose padded image is exactly zero after the mean), and the rounding
  // error is relative to the gradient, not to the pixel values: with the taps applied one by
  // one, a constant map left ~1e-7 of gradient at every pixel, ~7e-6 after SIFT-lite's pooling.
  void derivative(const T* const* src, T* out, Eigen::Index n) const {
    using map_t = Eigen::Map<const array>;
    const Eigen::Index r = gradient_.radius;
    Eigen::Map<array> o(out, n);
    for (Eigen::Index b = 1; b <= r; ++b) {
      const auto diff = map_t(src[r + b], n) - map_t(src[r - b], n);
      if (b == 1)
        o = gradient_.derivative(r + b) * diff;
      else
        o += gradient_.derivative(r + b) * diff;
    }
  }

  // out(y, x) = sum_t w_t in(y + d_t, x) for y in [begin, end), every column of `in`; `out`
  // holds those rows and in's columns.
  void pool_vertical(const block& in, const std::vector<pooling_tap<T>>& taps, Eigen::Index begin,
                     Eigen::Index end, block& out) {
    if (end <= begin || in.empty()) return;
    weights_.clear();
    sources_.resize(std::max(sources_.size(), taps.size()));
    for (std::size_t t = 0; t < taps.size(); ++t) {
      sources_[t] = in.at(begin + taps[t].offset, in.x0);
      weights_.push_back(taps[t].weight);
    }
    weighted_sum(sources_.data(), weights_.data(), taps.size(), out.at(begin, in.x0),
                 (end - begin) * in.row_stride());
  }

  // out(y, x) = sum_t w_t in(y, x + d_t) for x in [begin, end), every row of `in`; `out` holds
  // in's rows and those columns.
  void pool_horizontal(const block& in, const std::vector<pooling_tap<T>>& taps, Eigen::Index begin,
                       Eigen::Index end, block& out) {
    if (end <= begin || in.empty()) return;
    weights_.clear();
    for (const pooling_tap<T>& t : taps) weights_.push_back(t.weight);
    sources_.resize(std::max(sources_.size(), taps.size()));
    for (Eigen::Index y = in.y0; y < in.y0 + in.rows; ++y) {
      for (std::size_t t = 0; t < taps.size(); ++t) sources_[t] = in.at(y, begin + taps[t].offset);
      weighted_sum(sources_.data(), weights_.data(), taps.size(), out.at(y, begin),
                   (end - begin) * NumAngles);
    }
  }

  void size_fields() {
    inner_inner_.resize(rows_plan_.groups.size() * cols_plan_.groups.size());
    frame_inner_.resize(line_classes * cols_plan_.groups.size());
    inner_frame_.resize(line_classes * rows_plan_.groups.size());
    frame_frame_.resize(line_classes * line_classes);
  }

  // class_channels for index rows [first, end) into rows of `out` (which holds them).
  // `fresh`: the scratch (one per width, so that its storage keeps its size band after band).
  void channels_into(Eigen::Index first, Eigen::Index end, Eigen::Index sy,
                     const std::vector<Eigen::Index>& dy, Eigen::Index x0, Eigen::Index nc,
                     Eigen::Index sx, const std::vector<Eigen::Index>& dx, block& fresh,
                     block& out) {
    if (end <= first || nc <= 0) return;
    class_channels(first, end - first, sy, dy, x0, nc, sx, dx, fresh);
    std::copy(fresh.data.data(), fresh.data.data() + (end - first) * nc * NumAngles,
              out.at(first, x0));
  }

  // The shared fields (file comment) at the rows the windows of rows [r_lo, r_hi) read. Rows a
  // field already holds from the band before are kept, not recomputed: every field row is
  // computed once when the bands go down the map, as when the whole map was one band.
  void build_band(Eigen::Index r_lo, Eigen::Index r_hi) {
    if (band_hi_ == 0) {  // nothing built, or a build that threw: keep no rows
      inner_channels_.rows = 0;
      for (block& b : inner_frame_channels_) b.rows = 0;
      for (block& b : inner_inner_) b.rows = 0;
      for (block& b : inner_frame_) b.rows = 0;
    }
    band_lo_ = band_hi_ = 0;  // unknown while building (an exception leaves it unknown)
    const Eigen::Index r = gradient_.radius;
    const Eigen::Index wm = map_.cols();
    const bool row_inner = !rows_plan_.groups.empty();
    const bool col_inner = !cols_plan_.groups.empty();
    const auto inner = class_sources(inner_class, 0, r);
    std::array<std::vector<Eigen::Index>, line_classes> row_src, col_src;
    for (int k = 0; k < line_classes; ++k) {
      row_src[static_cast<std::size_t>(k)] = class_sources(k, h_, r);
      col_src[static_cast<std::size_t>(k)] = class_sources(k, w_, r);
    }
    const std::size_t n_row_groups = rows_plan_.groups.size();
    const std::size_t n_col_groups = cols_plan_.groups.size();
    // Inner map rows of the band's windows, and the rows [lo, hi) of row group g's fields: the
    // group's sample points u below the band's window rows.
    const Eigen::Index inner_lo = r_lo + r;
    const Eigen::Index inner_hi = r_hi - 1 + h_ - r;
    const auto group_rows = [&](std::size_t g) {
      const auto& rg = rows_plan_.groups[g];
      return std::pair<Eigen::Index, Eigen::Index>{r_lo + rg.begin, r_hi + (rg.end - rows_)};
    };
    // Inner x inner: the map's own channels (rows and columns frame_width .. size - frame_width),
    // pooled per (row group, column group).
    if (row_inner && col_inner) {
      const Eigen::Index first = inner_channels_.slide(inner_lo, inner_hi, r, wm - 2 * r);
      channels_into(first, inner_hi, 0, inner, r, wm - 2 * r, 0, inner, fresh_, inner_channels_);
      for (std::size_t g = 0; g < n_row_groups; ++g) {
        const auto& rg = rows_plan_.groups[g];
        const auto [lo, hi] = group_rows(g);
        Eigen::Index from = hi;
        for (std::size_t k = 0; k < n_col_groups; ++k) {
          const auto& cg = cols_plan_.groups[k];
          from = inner_inner_[g * n_col_groups + k].slide(lo, hi, cg.begin, cg.end - cg.begin);
        }
        if (from >= hi) continue;
        vertical_.reshape(from, inner_channels_.x0, hi - from, inner_channels_.cols);
        pool_vertical(inner_channels_, rg.taps, from, hi, vertical_);
        for (std::size_t k = 0; k < n_col_groups; ++k) {
          const auto& cg = cols_plan_.groups[k];
          pool_horizontal(vertical_, cg.taps, cg.begin, cg.end, inner_inner_[g * n_col_groups + k]);
        }
      }
    }
    // Frame row class x inner columns: index (r0, x), pooled along the row per column group.
    for (int k = 0; k < line_classes; ++k) {
      if (k == inner_class || !rows_plan_.frame_used[static_cast<std::size_t>(k)] || !col_inner)
        continue;
      class_channels(r_lo, r_hi - r_lo, class_pixel(k, h_), row_src[static_cast<std::size_t>(k)], r,
                     wm - 2 * r, 0, inner, fresh_);
      for (std::size_t g = 0; g < n_col_groups; ++g) {
        const auto& cg = cols_plan_.groups[g];
        block& out = frame_inner_[static_cast<std::size_t>(k) * n_col_groups + g];
        out.reshape(r_lo, cg.begin, r_hi - r_lo, cg.end - cg.begin);
        pool_horizontal(fresh_, cg.taps, cg.begin, cg.end, out);
      }
    }
    // Inner rows x frame column class: index (y, c0), pooled down the column per row group.
    for (int k = 0; k < line_classes; ++k) {
      if (k == inner_class || !cols_plan_.frame_used[static_cast<std::size_t>(k)] || !row_inner)
        continue;
      block& channels = inner_frame_channels_[static_cast<std::size_t>(k)];
      const Eigen::Index first = channels.slide(inner_lo, inner_hi, 0, cols_);
      channels_into(first, inner_hi, 0, inner, 0, cols_, class_pixel(k, w_),
                    col_src[static_cast<std::size_t>(k)], fresh_columns_, channels);
      for (std::size_t g = 0; g < n_row_groups; ++g) {
        const auto& rg = rows_plan_.groups[g];
        const auto [lo, hi] = group_rows(g);
        block& out = inner_frame_[static_cast<std::size_t>(k) * n_row_groups + g];
        const Eigen::Index from = out.slide(lo, hi, 0, cols_);
        pool_vertical(channels, rg.taps, from, hi, out);
      }
    }
    // Frame x frame: single pixels, index (r0, c0).
    for (int i = 0; i < line_classes; ++i)
      for (int j = 0; j < line_classes; ++j) {
        if (i == inner_class || j == inner_class ||
            !rows_plan_.frame_used[static_cast<std::size_t>(i)] ||
            !cols_plan_.frame_used[static_cast<std::size_t>(j)])
          continue;
        class_channels(r_lo, r_hi - r_lo, class_pixel(i, h_), row_src[static_cast<std::size_t>(i)],
                       0, cols_, class_pixel(j, w_), col_src[static_cast<std::size_t>(j)],
                       frame_frame_[static_cast<std::size_t>(i * line_classes + j)]);
      }
    band_lo_ = r_lo;
    band_hi_ = r_hi;
  }

  void build_bins(std::span<const grid_cell> offsets, Eigen::Index bin) {
    const std::size_t n_col_groups = cols_plan_.groups.size();
    const std::size_t n_row_groups = rows_plan_.groups.size();
    std::vector<std::pair<int, int>> distinct;  // (row position, column position)
    // bin_of_[m * NumBins^2 + e], e = by + NumBins * bx (element order / NumAngles).
    bin_of_.assign(static_cast<std::size_t>(m_count_ * NumBins * NumBins), 0);
    for (Eigen::Index m = 0; m < m_count_; ++m) {
      const grid_cell o = offsets[static_cast<std::size_t>(m)];
      for (Eigen::Index bx = 0; bx < NumBins; ++bx)
        for (Eigen::Index by = 0; by < NumBins; ++by) {
          const std::pair<int, int> key{rows_plan_.index_of(o.row + by * bin),
                                        cols_plan_.index_of(o.col + bx * bin)};
          auto it = std::find(distinct.begin(), distinct.end(), key);
          if (it == distinct.end()) {
            distinct.push_back(key);
            it = distinct.end() - 1;
          }
          bin_of_[static_cast<std::size_t>(m * NumBins * NumBins + by + NumBins * bx)] =
              static_cast<int>(it - distinct.begin());
        }
    }
    bins_.assign(distinct.size(), {});
    std::size_t most = 1;
    for (std::size_t b = 0; b < distinct.size(); ++b) {
      const auto& py = rows_plan_.positions[static_cast<std::size_t>(distinct[b].first)];
      const auto& px = cols_plan_.positions[static_cast<std::size_t>(distinct[b].second)];
      bin_terms& terms = bins_[b];
      if (py.group >= 0 && px.group >= 0) {
        const block& f = inner_inner_[static_cast<std::size_t>(py.group) * n_col_groups +
                                      static_cast<std::size_t>(px.group)];
        terms.add(f, py.u, px.u, T(1));
      }
      if (px.group >= 0)
        for (const auto& fr : py.frame) {
          const block& f = frame_inner_[static_cast<std::size_t>(fr.cls) * n_col_groups +
                                        static_cast<std::size_t>(px.group)];
          terms.add(f, 0, px.u, fr.weight);
        }
      if (py.group >= 0)
        for (const auto& fc : px.frame) {
          const block& f = inner_frame_[static_cast<std::size_t>(fc.cls) * n_row_groups +
                                        static_cast<std::size_t>(py.group)];
          terms.add(f, py.u, 0, fc.weight);
        }
      for (const auto& fr : py.frame)
        for (const auto& fc : px.frame) {
          const block& f = frame_frame_[static_cast<std::size_t>(fr.cls * line_classes + fc.cls)];
          terms.add(f, 0, 0, fr.weight * fc.weight);
        }
      most = std::max(most, terms.source.size());
    }
    sources_.resize(std::max(sources_.size(), most));
    rows_buffer_.resize(static_cast<Eigen::Index>(bins_.size()) * cols_ * NumAngles);
    row_of_.assign(bins_.size(), nullptr);
  }

  const image<T>& map_;
  Eigen::Index h_, w_;        // window, px
  Eigen::Index rows_, cols_;  // window positions
  Eigen::Index m_count_;
  const gradient_taps<T>& gradient_;
  Eigen::Array<T, NumAngles, 1> cos_a_, sin_a_;
  double alpha_;
  axis_plan<T> rows_plan_, cols_plan_;
  Eigen::Index band_;                       // window rows per band
  Eigen::Index band_lo_ = 0, band_hi_ = 0;  // the band the fields hold: window rows [lo, hi)
  // The shared fields (see the file comment), indexed by class and tap group.
  std::vector<block> inner_inner_;  // [row group * column groups + column group], map (y, x)
  std::vector<block> frame_inner_;  // [row class * column groups + column group], (r0, x)
  std::vector<block> inner_frame_;  // [column class * row groups + row group], (y, c0)
  std::vector<block> frame_frame_;  // [row class * line_classes + column class], (r0, c0)
  // The channels the band's fields pool down the columns, kept from band to band.
  block inner_channels_;                                  // map (y, x), inner rows and columns
  std::array<block, line_classes> inner_frame_channels_;  // [column class], (y, c0)
  std::vector<bin_terms> bins_;                           // per distinct bin position (u, v)
  std::vector<int> bin_of_;  // patch m's element block e -> distinct bin
  // Scratch.
  array hd_, hs_, gx_, gy_;
  block fresh_, fresh_columns_, vertical_;
  array rows_buffer_;
  std::vector<const T*> row_of_;
  std::vector<const T*> sources_;
  std::vector<T> weights_;
};

}  // namespace tacmap::detail::dsift
