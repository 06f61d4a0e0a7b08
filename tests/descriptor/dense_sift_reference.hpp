// A plain scalar reference for tacmap::dense_sift, for tests and the benchmark.
//
// Written to be checked by eye against reference/dense-sift.md and the MATLAB code it describes
// (Lazebnik's sp_dense_sift): double precision, 1-based indices, a full 2-D derivative kernel
// built from the 2-D Gaussian, conv2 'same' written out as a sum, and every descriptor pooled
// patch by patch with direct double sums. No separability, no shared sums, no Eigen tricks.
// The one documented difference from the MATLAB code is the sign convention of the gradient
// (convolution instead of filter2's correlation), which tacmap documents in dense_sift.hpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace dsift_reference {

struct params {
  int num_bins = 2;
  int num_angles = 8;
  long patch = 18;
  long spacing = 9;
  double sigma_edge = 1.0;
  double alpha = 9.0;
  double threshold = 1.0;
  double clamp = 0.2;
};

/// A matrix with MATLAB's 1-based (row, column) indexing.
struct mat {
  long rows = 0;
  long cols = 0;
  std::vector<double> v;
  mat(long r, long c, double init = 0.0)
      : rows(r), cols(c), v(static_cast<std::size_t>(r * c), init) {}
  double& operator()(long i, long j) { return v[static_cast<std::size_t>((i - 1) * cols + j - 1)]; }
  double operator()(long i, long j) const {
    return v[static_cast<std::size_t>((i - 1) * cols + j - 1)];
  }
};

/// conv2(P, K, 'same') for an odd square kernel: zero outside P.
inline mat conv2_same(const mat& p, const mat& k) {
  const long f = k.rows;
  const long c = (f + 1) / 2;
  mat out(p.rows, p.cols);
  for (long i = 1; i <= p.rows; ++i) {
    for (long j = 1; j <= p.cols; ++j) {
      double s = 0.0;
      for (long a = 1; a <= f; ++a) {
        for (long b = 1; b <= f; ++b) {
          const long pi = i + c - a;
          const long pj = j + c - b;
          if (pi >= 1 && pi <= p.rows && pj >= 1 && pj <= p.cols) s += k(a, b) * p(pi, pj);
        }
      }
      out(i, j) = s;
    }
  }
  return out;
}

/// Orientation images O_k (k = 1..num_angles), each H x W, of a row-major image.
inline std::vector<mat> orientation_images(const mat& image, const params& prm) {
  const long h = image.rows;
  const long w = image.cols;
  // 1. Divide by the maximum (by the largest magnitude; all zero stays zero).
  double mx = 0.0;
  for (double x : image.v) mx = std::max(mx, std::abs(x));
  mat img = image;
  if (mx > 0.0) {
    for (double& x : img.v) x /= mx;
  }
  // 2. Pad by 2 mirrored pixels: I = [I(2:-1:1,:); I; I(end:-1:end-1,:)], same for columns.
  auto pad_index = [](long k, long n) {
    if (k == 1) return 2L;
    if (k == 2) return 1L;
    if (k == n + 3) return n;
    if (k == n + 4) return n - 1;
    return k - 2;
  };
  mat padded(h + 4, w + 4);
  for (long i = 1; i <= h + 4; ++i) {
    for (long j = 1; j <= w + 4; ++j) padded(i, j) = img(pad_index(i, h), pad_index(j, w));
  }
  double mean = 0.0;
  for (double x : padded.v) mean += x;
  mean /= static_cast<double>(padded.v.size());
  for (double& x : padded.v) x -= mean;

  // Derivative-of-Gaussian kernels: fspecial('gaussian', 4*ceil(sigma)+1, sigma), MATLAB
  // gradient (central differences, one-sided at the ends), each scaled to absolute sum 2.
  const double sigma = prm.sigma_edge;
  const long f = 4 * static_cast<long>(std::ceil(sigma)) + 1;
  const long c = (f + 1) / 2;
  mat g(f, f);
  double gsum = 0.0;
  for (long a = 1; a <= f; ++a) {
    for (long b = 1; b <= f; ++b) {
      const double r2 = static_cast<double>((a - c) * (a - c) + (b - c) * (b - c));
      g(a, b) = std::exp(-r2 / (2.0 * sigma * sigma));
      gsum += g(a, b);
    }
  }
  for (double& x : g.v) x /= gsum;
  mat gx(f, f);  // d/d(column)
  mat gy(f, f);  // d/d(row)
  for (long a = 1; a <= f; ++a) {
    for (long b = 1; b <= f; ++b) {
      gx(a, b) = b == 1   ? g(a, 2) - g(a, 1)
                 : b == f ? g(a, f) - g(a, f - 1)
                          : (g(a, b + 1) - g(a, b - 1)) / 2.0;
      gy(a, b) = a == 1   ? g(2, b) - g(1, b)
                 : a == f ? g(f, b) - g(f - 1, b)
                          : (g(a + 1, b) - g(a - 1, b)) / 2.0;
    }
  }
  double sx = 0.0;
  double sy = 0.0;
  for (double x : gx.v) sx += std::abs(x);
  for (double x : gy.v) sy += std::abs(x);
  for (double& x : gx.v) x *= 2.0 / sx;
  for (double& x : gy.v) x *= 2.0 / sy;

  // Gradients by convolution (tacmap's sign convention), cropped back to H x W.
  const mat ix = conv2_same(padded, gx);
  const mat iy = conv2_same(padded, gy);

  std::vector<mat> out(static_cast<std::size_t>(prm.num_angles), mat(h, w));
  for (long i = 1; i <= h; ++i) {
    for (long j = 1; j <= w; ++j) {
      const double dx = ix(i + 2, j + 2);
      const double dy = iy(i + 2, j + 2);
      const double mag = std::sqrt(dx * dx + dy * dy);
      const double theta = std::atan2(dy, dx);
      for (int k = 1; k <= prm.num_angles; ++k) {
        const double a = 2.0 * std::numbers::pi * (k - 1) / prm.num_angles;
        const double cs = std::max(0.0, std::cos(theta - a));
        out[static_cast<std::size_t>(k - 1)](i, j) = mag * std::pow(cs, prm.alpha);
      }
    }
  }
  return out;
}

/// Normalisation respecting flat areas: only descriptors with norm > threshold are scaled to
/// unit length, clamped and renormalised.
inline void normalise(std::vector<double>& d, const params& prm) {
  double n = 0.0;
  for (double x : d) n += x * x;
  n = std::sqrt(n);
  if (!(n > prm.threshold)) return;
  for (double& x : d) x = std::min(x / n, prm.clamp);
  double m = 0.0;
  for (double x : d) m += x * x;
  m = std::sqrt(m);
  for (double& x : d) x /= m;
}

/// The descriptor whose grid point is (gy, gx), 1-based, as in the MATLAB grid.
inline std::vector<double> descriptor_at_grid_point(const std::vector<mat>& o, long gy, long gx,
                                                    const params& prm) {
  const long p = prm.patch;
  const long nb = prm.num_bins;
  const long h = o[0].rows;
  const long w = o[0].cols;
  // weight_x(j) = max(0, 1 - |j - (p/2 - 0.5)| / (p/nb)), j = 1..p.
  std::vector<double> weight(static_cast<std::size_t>(p + 1), 0.0);
  for (long j = 1; j <= p; ++j) {
    const double t = std::abs(static_cast<double>(j) - (static_cast<double>(p) / 2.0 - 0.5)) /
                     (static_cast<double>(p) / static_cast<double>(nb));
    weight[static_cast<std::size_t>(j)] = t <= 1.0 ? 1.0 - t : 0.0;
  }
  // linspace(1, p+1, nb+1)(1..nb) - p/2.
  std::vector<long> offset(static_cast<std::size_t>(nb + 1));
  for (long k = 1; k <= nb; ++k) offset[static_cast<std::size_t>(k)] = 1 + (k - 1) * p / nb - p / 2;

  std::vector<double> d(static_cast<std::size_t>(nb * nb * prm.num_angles), 0.0);
  for (long n = 1; n <= nb * nb; ++n) {
    // [sample_x, sample_y] = meshgrid(...); (:) runs down the columns: the row index first.
    const long row = (n - 1) % nb + 1;
    const long col = (n - 1) / nb + 1;
    const long y = gy + offset[static_cast<std::size_t>(row)];
    const long x = gx + offset[static_cast<std::size_t>(col)];
    for (int k = 0; k < prm.num_angles; ++k) {
      // conv2(weight_x, weight_x', O, 'same') at (y, x): full(y + p/2, x + p/2).
      double s = 0.0;
      for (long j1 = 1; j1 <= p; ++j1) {
        for (long j2 = 1; j2 <= p; ++j2) {
          const long yy = y + p / 2 + 1 - j1;
          const long xx = x + p / 2 + 1 - j2;
          if (yy < 1 || yy > h || xx < 1 || xx > w) continue;
          s += weight[static_cast<std::size_t>(j1)] * weight[static_cast<std::size_t>(j2)] *
               o[static_cast<std::size_t>(k)](yy, xx);
        }
      }
      d[static_cast<std::size_t>((n - 1) * prm.num_angles + k)] = s;
    }
  }
  normalise(d, prm);
  return d;
}

/// Descriptors of every patch position, row-major over top-left (r, c) (0-based): Lazebnik's
/// grid point of top-left (r, c) is (r + p/2, c + p/2), 1-based.
struct dense_result {
  long rows = 0;
  long cols = 0;
  std::vector<std::vector<double>> d;  ///< index r * cols + c
};

inline dense_result compute(const mat& image, const params& prm) {
  const auto o = orientation_images(image, prm);
  dense_result out;
  out.rows = image.rows - prm.patch + 1;
  out.cols = image.cols - prm.patch + 1;
  for (long r = 0; r < out.rows; ++r) {
    for (long c = 0; c < out.cols; ++c) {
      out.d.push_back(descriptor_at_grid_point(o, r + prm.patch / 2, c + prm.patch / 2, prm));
    }
  }
  return out;
}

/// Lazebnik's grid, patch/2 : spacing : size - patch/2 + 1 (1-based), without the points whose
/// patch would overhang the image; row-major over the grid. Top-left = grid point - patch/2.
struct sample_result {
  std::vector<long> top_rows;
  std::vector<long> top_cols;
  std::vector<std::vector<double>> d;  ///< index i * top_cols.size() + j
};

inline sample_result sample(const mat& image, const params& prm) {
  const auto o = orientation_images(image, prm);
  sample_result out;
  const long p = prm.patch;
  for (long g = p / 2; g <= image.rows - p / 2 + 1; g += prm.spacing) {
    if (g + p / 2 <= image.rows) out.top_rows.push_back(g - p / 2);
  }
  for (long g = p / 2; g <= image.cols - p / 2 + 1; g += prm.spacing) {
    if (g + p / 2 <= image.cols) out.top_cols.push_back(g - p / 2);
  }
  for (long r : out.top_rows) {
    for (long c : out.top_cols)
      out.d.push_back(descriptor_at_grid_point(o, r + p / 2, c + p / 2, prm));
  }
  return out;
}

}  // namespace dsift_reference
