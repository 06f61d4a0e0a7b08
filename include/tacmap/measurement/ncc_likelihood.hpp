// tacmap: `ncc_likelihood` — normalised cross-correlation between the tactile image and every
// map window. The paper tried this first and found it performed poorly (Sec. III-C), which is why
// it moved to SIFT descriptors; tacmap keeps it as the baseline to compare against.
//
// For window x with map pixels m and tactile image z (both h x w):
//   ncc(x) = sum (m - mean m)(z - mean z) / (h w std(m) std(z))  in [-1, 1],
//   log p(z | x) = tempering * ncc(x) / tau        (an exponential likelihood in the NCC).
// A flat window or a flat tactile image has no correlation to speak of: ncc = 0 there.
//
// Per map, once: box sums of m and m^2 for every window (integral images). Per measurement: the
// cross-correlation of the zero-mean tactile image with the map, as one whole-grid
// multiply-add per tactile pixel (h w block operations over the grid, no per-window loop).
#pragma once

#include <cmath>
#include <span>
#include <stdexcept>

#include "tacmap/detail/setting_ranges.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/concept.hpp"

namespace tacmap {

/// Configuration of `ncc_likelihood`.
struct ncc_params {
  double tau = 0.1;        ///< temperature: log p = ncc / tau (smaller = more decisive)
  double tempering = 1.0;  ///< exponent on the likelihood (multiplies the log-likelihood)

  void validate() const {
    // The ranges keep the float log-likelihood tempering ncc / tau finite (setting_ranges.hpp).
    detail::check_range("ncc_params", "tau", tau, detail::min_tau, detail::max_tau, "",
                        "a temperature", "smaller is more decisive; the default is 0.1");
    detail::check_range("ncc_params", "tempering", tempering, 0.0, detail::max_tempering, "",
                        "an exponent on the likelihood",
                        "1 is the likelihood itself, 0 ignores the touches");
  }
};

/// The NCC baseline measurement model over a `planar_grid`.
template <belief_scalar T = float>
class ncc_likelihood {
 public:
  using measurement_type = image<float>;  ///< preprocessed tactile image at map scale

  /// `map`: the visual map (any range; NCC is invariant to gain and offset); `window`: the
  /// tactile image's size in map pixels (must equal the grid's window).
  ncc_likelihood(const image<float>& map, pixel_size window, ncc_params params = {})
      : params_(params), window_(window) {
    params.validate();
    if (!detail::all_finite(map))
      detail::fail(
          "ncc_likelihood: the map contains NaN or infinite pixels; expected a finite "
          "image");
    if (window.width <= 0 || window.height <= 0 || map.cols() < window.width ||
        map.rows() < window.height)
      detail::fail("ncc_likelihood: the map is ", map.cols(), " x ", map.rows(),
                   " px (width x height) and the window ", window.width, " x ", window.height,
                   "; expected a positive window no larger than the map");
    map_ = map.template cast<T>();
    const Eigen::Index rows = map.rows() - window.height + 1;
    const Eigen::Index cols = map.cols() - window.width + 1;
    // Integral images in double: window sums of m and m^2 without cancellation trouble.
    Eigen::ArrayXXd sum = Eigen::ArrayXXd::Zero(map.rows() + 1, map.cols() + 1);
    Eigen::ArrayXXd sq = Eigen::ArrayXXd::Zero(map.rows() + 1, map.cols() + 1);
    for (Eigen::Index r = 0; r < map.rows(); ++r)
      for (Eigen::Index c = 0; c < map.cols(); ++c) {
        const double v = map(r, c);
        sum(r + 1, c + 1) = v + sum(r, c + 1) + sum(r + 1, c) - sum(r, c);
        sq(r + 1, c + 1) = v * v + sq(r, c + 1) + sq(r + 1, c) - sq(r, c);
      }
    const double n = static_cast<double>(window.width * window.height);
    inv_norm_.resize(rows, cols);
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        const auto box = [&](const Eigen::ArrayXXd& s) {
          return s(r + window.height, c + window.width) - s(r, c + window.width) -
                 s(r + window.height, c) + s(r, c);
        };
        const double s1 = box(sum);
        const double var_n = box(sq) - s1 * s1 / n;  // n * variance of the window
        // Flat windows (variance ~ 0 relative to the map's range) get no correlation.
        inv_norm_(r, c) = var_n > 1e-9 * n ? static_cast<T>(1.0 / std::sqrt(var_n)) : T(0);
      }
  }

  /// log p(z | x) for every window (see the file comment). Throws std::invalid_argument when z
  /// is not the window's size or holds NaN, or when the grid is not the one the map was built for.
  template <class G>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out)
      const requires std::same_as<typename G::scalar_type, T> {
    if (grid.rows() != inv_norm_.rows() || grid.cols() != inv_norm_.cols())
      detail::fail("ncc_likelihood: the grid has ", grid.rows(), " x ", grid.cols(),
                   " states but the map and window give ", inv_norm_.rows(), " x ",
                   inv_norm_.cols(), "; build the grid and the model from the same map and window");
    if (z.rows() != window_.height || z.cols() != window_.width)
      detail::fail("ncc_likelihood: tactile image is ", z.rows(), " x ", z.cols(),
                   " px (rows x cols); expected ", window_.height, " x ", window_.width,
                   " (the sensor window at map scale — preprocess the frame first)");
    if (!detail::all_finite(z))
      detail::fail("ncc_likelihood: the tactile image contains NaN or infinite pixels");
    const double mean = static_cast<double>(z.mean());
    const double z_norm = std::sqrt((z.template cast<double>() - mean).square().sum());
    out.setZero();
    if (!(z_norm > 1e-9)) return;  // a flat tactile image carries no information
    Eigen::Map<image<T>> acc(out.data(), grid.rows(), grid.cols());
    // Cross-correlation with the zero-mean template: sum_ij z'(i,j) * m(r+i, c+j) for all (r, c).
    // (The window mean drops out because z' sums to zero.)
    for (Eigen::Index i = 0; i < z.rows(); ++i)
      for (Eigen::Index j = 0; j < z.cols(); ++j) {
        const auto w = static_cast<T>((static_cast<double>(z(i, j)) - mean) / z_norm);
        if (w != T(0)) acc += w * map_.block(i, j, acc.rows(), acc.cols());
      }
    acc *= inv_norm_ * static_cast<T>(params_.tempering / params_.tau);
  }

  [[nodiscard]] const ncc_params& params() const { return params_; }

  /// Next-touch hook (filter/next_touch.hpp): each of `states`' window (grid index), zero-mean
  /// and of unit norm (zero for a flat window), one column each: what a noiseless touch there
  /// gives the correlation.
  void window_descriptors(std::span<const Eigen::Index> states, Eigen::ArrayXXf& out) const {
    const Eigen::Index cols = inv_norm_.cols();
    out.resize(window_.width * window_.height, static_cast<Eigen::Index>(states.size()));
    for (std::size_t i = 0; i < states.size(); ++i) {
      const Eigen::Index q = states[i];
      const auto col = static_cast<Eigen::Index>(i);
      const image<T> w = map_.block(q / cols, q % cols, window_.height, window_.width);
      Eigen::ArrayXf v = Eigen::Map<const Eigen::Array<T, Eigen::Dynamic, 1>>(w.data(), w.size())
                             .template cast<float>();
      v -= v.mean();
      const float norm = std::sqrt(v.square().sum());
      out.col(col) = norm > 1e-6F ? (v / norm).eval() : Eigen::ArrayXf::Zero(v.size()).eval();
    }
  }
  /// Next-touch hook: out(a, b) = log p(z_a | b) = tempering ncc(a, b) / tau for the noiseless
  /// touch of column a of `touched` at the window of column b of `at`.
  void predicted_log_likelihoods(const Eigen::ArrayXXf& touched, const Eigen::ArrayXXf& at,
                                 Eigen::ArrayXXf& out) const {
    out = (touched.matrix().transpose() * at.matrix()).array() *
          static_cast<float>(params_.tempering / params_.tau);
  }

 private:
  ncc_params params_;
  pixel_size window_;
  image<T> map_;
  image<T> inv_norm_;  // 1 / sqrt(n var) per window, 0 for flat windows
};

}  // namespace tacmap
