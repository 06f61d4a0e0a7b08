// tacmap: `rotated_descriptor_likelihood` — the paper's feature measurement model (Sec. III-C)
// over (x, y, theta) pose grids.
//
// The map is described ONCE, densely at stride 1 (the descriptor field F, as `shared_dense`
// features); it is never recomputed per heading. What turns is the tactile image: for heading
// theta_a the sensor's image is rotated into the map frame (a square canvas around the sensor
// centre, bilinear, sampling tables built once per heading), and the tactile patch m, whose
// centre c_m sits in the window as in the planar model, lands at R(theta_a) c_m. The canvas is
// described there (an axis-aligned patch, like every map patch), giving g_{a,m}; window x's
// patch m at heading a is the map's dense patch at x + round(R(theta_a) c_m). Then eq. (1)
// and the likelihood shape exactly as in `descriptor_likelihood`:
//   all_pairs:  d(x, a, z) = sum_m sum_n || F(x + o_{a,m}) - g_{a,n} ||
//   aligned:    d(x, a, z) = sum_m       || F(x + o_{a,m}) - g_{a,m} ||
// All M x A tactile descriptors meet the field in one pass (detail::distances_each), band of
// positions by band, and each band's distances are added, shifted by o_{a,m}, to every layer
// while they are in cache (see `distances`).
//
// Conventions: pose_grid.hpp (headings, layer order). Outside the tactile image the canvas
// repeats its edge pixels (so an edge of the footprint is not mistaken for an edge in the
// object). Near the map's edge a turned patch can fall off the map (positions are those where
// the *unrotated* window fits); such a patch is uninformative: it contributes its mean distance
// over the poses where it does land, so edge poses are neither favoured nor ruled out. (Ruling
// them out lost the true pose whenever a touch near the edge was turned: 4 of 22 sequences on
// the coins photograph at random orientations.)
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <span>
#include <sstream>
#include <utility>
#include <vector>

#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/detail/state_ranges.hpp"

namespace tacmap {

/// Configuration of `rotated_descriptor_likelihood`: the planar model's knobs (same meaning,
/// same defaults) without `features` — the map's features are always its dense field.
struct rotated_likelihood_params {
  Eigen::Index spacing = descriptor_likelihood_params{}.spacing;  ///< px between patches
  pairing pairs = descriptor_likelihood_params{}.pairs;
  likelihood_shape shape = descriptor_likelihood_params{}.shape;
  double epsilon = descriptor_likelihood_params{}.epsilon;
  /// Exponential shape's temperature: the planar model's calibrated 0.15 (README,
  /// "Confidence"; the same descriptor distances). Before calibration 0.25 was the best
  /// measured: gecko 81 of 88 sequences localized with 0.25, 81 with 0.5, 78 with 1.
  double tau = 0.15;
  double tempering = descriptor_likelihood_params{}.tempering;
  /// A patch turned off the map counts its mean distance over the poses where it lands (file
  /// comment). Maps of up to this many field positions take that mean exactly; larger ones
  /// over a fixed lattice of about `off_map_sample` field positions (every s-th row and
  /// column), so that a tracked touch near the map's edge costs a few hundred distances per
  /// patch instead of a pass over the whole field (a descriptor with its own distance always
  /// takes the exact mean). 0 (the default): every map takes the lattice. Measured: exact means
  /// up to 128 x 128 px made a tracked 36-heading touch on the paper's grid cost as much as
  /// the whole grid (13.5 against 13.1 ms, camera_bench), since the tracked sample's rows reach
  /// the edges of every heading. The lattice's mean is an estimate of the same uninformative
  /// value, within a few percent of the exact one (test_pose_tracking.cpp); the
  /// whole grid then adds the lattice's distances (about 3 % of an untracked touch there).
  Eigen::Index off_map_exact_positions = 0;
  /// Positions of the lattice (about), >= 1. 512: 441 of the paper's map's 10,609 positions;
  /// each off-map patch of a tracked touch costs that many distances.
  Eigen::Index off_map_sample = 512;

  void validate() const {
    if (off_map_exact_positions < 0 || off_map_sample < 1)
      detail::fail("rotated_likelihood_params: off_map_exact_positions = ", off_map_exact_positions,
                   ", off_map_sample = ", off_map_sample,
                   "; expected >= 0 and >= 1 (the defaults are 16384 and 4096)");
    descriptor_likelihood_params p;
    p.spacing = spacing;
    p.epsilon = epsilon;
    p.tau = tau;
    p.tempering = tempering;
    p.validate();
  }
};

/// Descriptors that can describe a few arbitrary patches of an image without computing the
/// whole dense field (dense_sift::describe_at). Optional: others go through compute().
template <class D>
concept describes_at = descriptor<D> &&
    requires(const D& d, const image<typename D::scalar_type>& img,
             std::span<const grid_cell> cells) {
  {
    d.describe_at(img, cells)
    } -> std::convertible_to<Eigen::Array<typename D::scalar_type, Eigen::Dynamic, Eigen::Dynamic>>;
};

/// ... and that can reuse scratch memory between such calls (`typename D::workspace`).
template <class D>
concept describes_at_reusing = describes_at<D> &&
    requires(const D& d, const image<typename D::scalar_type>& img,
             std::span<const grid_cell> cells, typename D::workspace& ws) {
  {
    d.describe_at(img, cells, ws)
    } -> std::convertible_to<Eigen::Array<typename D::scalar_type, Eigen::Dynamic, Eigen::Dynamic>>;
};

/// The scratch a model keeps for `D::describe_at`: `D::workspace` when `D` models
/// `describes_at_reusing`, an empty struct otherwise.
template <class D>
struct descriptor_workspace {
  struct type {};
};
template <describes_at_reusing D>
struct descriptor_workspace<D> {
  using type = typename D::workspace;
};

/// The feature measurement model over a `pose_grid` (x, y, theta), for any `descriptor`.
template <descriptor Descriptor>
class rotated_descriptor_likelihood {
 public:
  using scalar_type = typename Descriptor::scalar_type;
  using measurement_type = image<float>;  ///< preprocessed tactile image at map scale

  /// Describes `map` once. `window`: the tactile image's size in map pixels; `angle_count`:
  /// the pose grid's headings. Throws std::invalid_argument when the map is smaller than the
  /// window, the patch and spacing do not fit the window, the map holds NaN, or angle_count < 1.
  rotated_descriptor_likelihood(Descriptor descriptor, const image<float>& map, pixel_size window,
                                int angle_count, rotated_likelihood_params params = {})
      : descriptor_(std::move(descriptor)), params_(params), window_(window), angles_(angle_count) {
    params.validate();
    const Eigen::Index p = descriptor_.patch_size();
    if (angle_count < 1)
      detail::fail("rotated_descriptor_likelihood: angle_count = ", angle_count,
                   "; expected >= 1 (the pose grid's number of headings)");
    const std::vector<grid_cell> offsets = detail::checked_patch_offsets(
        "rotated_descriptor_likelihood", map, window, p, params.spacing);
    m_count_ = static_cast<Eigen::Index>(offsets.size());
    {
      // Refused before allocating (issue 14, "Bad input"), as descriptor_likelihood: the dense
      // field and its tiled copy, whatever the number of headings (the tactile image turns, the
      // map's features do not) — about 300 MB for classic SIFT on 640 x 480.
      const auto dim = static_cast<std::uint64_t>(descriptor_.dimension());
      const auto field_count = detail::saturating_product(map.rows() - p + 1, map.cols() - p + 1);
      std::ostringstream what;
      what << "the map's dense descriptors (" << field_count << " x " << dim << " values, twice)";
      detail::check_memory("rotated_descriptor_likelihood", what.str(),
                           detail::saturating_product(2, field_count, dim, sizeof(scalar_type)),
                           "use a coarser map (fewer mm per px means more states) or a machine "
                           "with more memory");
    }

    const image<scalar_type> map_t = map.template cast<scalar_type>();
    const descriptor_field<scalar_type> field = descriptor_.compute(map_t);
    detail::check_field_shape(descriptor_, field, map.rows(), map.cols(), "the map");
    field_rows_ = field.rows;
    field_cols_ = field.cols;
    field_tiles_ = detail::descriptor_tiles<scalar_type>(field.values);
    // A position's squared norm is NaN or infinite when one of its values is (or when finite
    // values overflow the square): the field is scanned for the value to name only then, not
    // read a second time (that read was 7 % of preparing the paper's map at 36 headings).
    const Eigen::Map<const Eigen::Array<scalar_type, Eigen::Dynamic, 1>> norms(
        field_tiles_.squared_norms_from(0), field_tiles_.positions());
    if (!std::isfinite(static_cast<double>(norms.sum())))
      detail::check_field(descriptor_, field, map.rows(), map.cols(), "the map");
    build_mean_sample(field);
    rows_ = map.rows() - window.height + 1;
    cols_ = map.cols() - window.width + 1;
    build_headings(offsets);
  }

  /// The same, with the window and headings taken from `grid`.
  template <class T>
  rotated_descriptor_likelihood(Descriptor descriptor, const image<float>& map,
                                const pose_grid<T>& grid, rotated_likelihood_params params = {})
      : rotated_descriptor_likelihood(std::move(descriptor), map, grid.window_size(),
                                      grid.angle_count(), params) {}

  [[nodiscard]] int angle_count() const { return angles_; }
  /// Number of tactile patches M per window (the paper: 3).
  [[nodiscard]] Eigen::Index patches_per_window() const { return m_count_; }
  [[nodiscard]] const rotated_likelihood_params& params() const { return params_; }
  [[nodiscard]] const Descriptor& descriptor() const { return descriptor_; }
  /// Side lengths of the square-ish canvas a tactile image is rotated into (rows x cols).
  [[nodiscard]] pixel_size canvas_size() const { return {canvas_cols_, canvas_rows_}; }
  /// Map-field offset (rows, cols) of patch m at heading `layer`, relative to the window's
  /// top-left cell: the state's patch is the dense map patch at cell + offset.
  [[nodiscard]] grid_cell patch_offset(Eigen::Index layer, Eigen::Index m) const {
    return heading_[static_cast<std::size_t>(layer)].field_offset[static_cast<std::size_t>(m)];
  }

  /// The tactile image rotated into the map frame for heading `layer` (canvas_size()).
  [[nodiscard]] image<scalar_type> rotated_tactile(const measurement_type& z,
                                                   Eigen::Index layer) const {
    check_measurement(z);
    TACMAP_ASSERT(layer >= 0 && layer < angles_, "heading layer out of range");
    image<scalar_type> canvas(canvas_rows_, canvas_cols_);
    image<scalar_type> extended;
    extend(z, extended);
    render(extended, heading_[static_cast<std::size_t>(layer)], canvas);
    return canvas;
  }

  /// All tactile descriptors: dimension x (M * angle_count), column a * M + m is patch m at
  /// heading a.
  [[nodiscard]] Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> tactile_descriptors(
      const measurement_type& z) const {
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> g;
    describe_tactile(z, g, false);
    return g;
  }

  /// The distance d(x, a, z) for every pose (layer after layer); a patch off the map counts
  /// its mean distance (see the file comment).
  ///
  /// The field is processed in bands of positions: all M x A distances of one band (a few
  /// hundred KB, in L2), then at once their share of every layer. Computing every distance
  /// first and adding them to the layers afterwards wrote and re-read M x A whole-field columns
  /// (4.6 MB for 120 px, 36 headings) through L3 or memory.
  template <class G>
  void distances(const G& grid, const measurement_type& z, belief_array<G>& out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    check_grid(grid);
    const bool summed = params_.pairs == pairing::all_pairs;
    // Into the model's workspace, in the kernel's order (aligned: patch by patch, column
    // m A + a; see build_needed).
    auto& g = tactile_;
    describe_tactile(z, g, !summed);
    constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
    const Eigen::Index positions = field_rows_ * field_cols_;
    const Eigen::Index tiles = (positions + width - 1) / width;
    // All pairs: a heading's layer needs only the sum over its M tactile descriptors
    // (sum_m sum_n D_n(x + o_m) = sum_m S(x + o_m), S = sum_n D_n), so the band keeps one
    // column per heading, summed as it is computed; aligned: one column per descriptor.
    const Eigen::Index group = summed ? m_count_ : 1;
    auto& band = workspace_;  // band position p - first x column (descriptor j, or heading a)
    // 512 positions: each column starts on a cache line, so the kernel's register-wide stores
    // never straddle two lines.
    band.resize(band_tiles * width, g.cols() / group);
    if constexpr (euclidean_descriptor<Descriptor>) detail::squared_norms(g, g_norms_);
    out.setZero();
    // Per patch m of heading a (a * M + m): the sum of its distances where it lands on the map.
    sums_.assign(static_cast<std::size_t>(m_count_ * angles_), 0.0);
    Eigen::Array<scalar_type, Eigen::Dynamic, 1> column;  // a user's distance: one map patch
    if constexpr (!euclidean_descriptor<Descriptor>) column.resize(field_tiles_.dimension());
    for (Eigen::Index t0 = 0; t0 < tiles; t0 += band_tiles) {
      const Eigen::Index t1 = std::min(t0 + band_tiles, tiles);
      const Eigen::Index first = t0 * width;
      const Eigen::Index last = std::min(t1 * width, positions);
      if constexpr (euclidean_descriptor<Descriptor>) {
        detail::distances_each(field_tiles_, g, g_norms_.data(), band.data(), band.rows(),
                               needed_.data(), {t0, t1}, group);
      } else {  // a user's distance, called once per pair
        band.topRows(last - first).setZero();
        for (Eigen::Index q = first; q < last; ++q) {
          for (Eigen::Index k = 0; k < field_tiles_.dimension(); ++k)
            column(k) = field_tiles_.at(q, k);
          for (Eigen::Index j = 0; j < g.cols(); ++j)
            band(q - first, j / group) += descriptor_.distance(column, g.col(j));
        }
      }
      add_band(band, first, last, out);
    }
    // A patch that falls off the map says nothing about the pose: it contributes its mean
    // distance over the states where it lands on the map (uninformative, neither favouring nor
    // excluding edge poses).
    const Eigen::Index plane = rows_ * cols_;
    if (sampled_means()) {  // a large map: every patch's mean over the lattice sample
      off_.assign(static_cast<std::size_t>(angles_ * m_count_), 0);
      for (Eigen::Index a = 0; a < angles_; ++a)
        for (Eigen::Index m = 0; m < m_count_; ++m)
          off_[static_cast<std::size_t>(a * m_count_ + m)] = off_somewhere(a, m) ? 1 : 0;
      norms_ = g_norms_;
      sample_means([&](Eigen::Index a, Eigen::Index m) {
        return summed ? a * m_count_ + m : m * angles_ + a;
      });
    }
    for (Eigen::Index a = 0; a < angles_; ++a) {
      Eigen::Map<image<scalar_type>> layer(out.data() + a * plane, rows_, cols_);
      const heading_tables& h = heading_[static_cast<std::size_t>(a)];
      for (Eigen::Index m = 0; m < m_count_; ++m) {
        const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
        if (r.rows <= 0 || r.cols <= 0) continue;  // never on the map: no information at all
        if (sampled_means()) {
          if (off_somewhere(a, m))
            add_outside(layer, r, means_[static_cast<std::size_t>(a * m_count_ + m)]);
          continue;
        }
        const double total = sums_[static_cast<std::size_t>(a * m_count_ + m)];
        add_outside(layer, r,
                    static_cast<scalar_type>(total / static_cast<double>(r.rows * r.cols)));
      }
    }
  }

  /// log p(z | x, theta) for every pose: eq. (1), then eq. (2) or the exponential, tempered.
  template <class G>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    distances(grid, z, out);
    if (!(static_cast<scalar_type>(params_.tempering) > scalar_type(0))) {  // a flat likelihood
      out.setZero();
      return;
    }
    to_log_likelihood(out);
  }

  /// Tracking hook (measurement/concept.hpp): an upper bound on log p(z | x, theta) for every
  /// pose and touch. Distances are >= 0 (so is an off-map patch's mean distance), so the
  /// exponential shape's -tempering d / tau is <= 0 and eq. (2)'s -tempering log(d + epsilon)
  /// is <= -tempering log(epsilon) — returned a hair higher, so that the float logarithm (and
  /// epsilon rounded to float) of the model itself cannot exceed it. As descriptor_likelihood.
  [[nodiscard]] double log_likelihood_bound() const {
    return detail::log_likelihood_bound(params_);
  }

  /// Tracking hook: log p(z | x, theta) at (at least) the poses of `states` (sorted, disjoint
  /// ranges of pose indices a * rows * cols + row * cols + col), bit for bit what
  /// `log_likelihood` writes there; other entries unspecified.
  ///
  /// Only the headings the ranges touch are rendered and described, and the distance kernel
  /// runs only on the field tiles their patches read (x + o_{a,m} for the requested x; the same
  /// kernel, register by register, so the same values). Each pose then adds its patches'
  /// distances in the order `distances` adds them (band of the field position, then patch) and
  /// takes the same log or scale on whole chunks of 16 poses (the vectorised logarithm splits a
  /// chunk as it splits the whole grid). Cost: proportional to the support — except that a
  /// requested pose whose patch m falls off the map needs that patch's mean distance over the
  /// whole layer (see the file comment), i.e. its distances over every field row it reaches:
  /// one descriptor's (all pairs: one heading's) pass over the field, summed in `distances`'
  /// exact order. A descriptor with its own distance (not euclidean) takes the whole grid.
  template <class G>
  void log_likelihood_on(const G& grid, const measurement_type& z, belief_array<G>& out,
                         std::span<const state_range> states)
      const requires std::same_as<typename G::scalar_type, scalar_type> {
    if constexpr (!euclidean_descriptor<Descriptor>) {
      log_likelihood(grid, z, out);
    } else {
      check_grid(grid);
      check_measurement(z);
      const Eigen::Index n = grid.size();
      detail::covering_tiles(states, chunk_states, n, chunks_);
      if (!(static_cast<scalar_type>(params_.tempering) > scalar_type(0))) {
        for (const detail::tile_range& t : chunks_) {
          const state_range p = detail::tile_positions(t, chunk_states, n);
          out.segment(p.begin, p.end - p.begin).setZero();
        }
        return;
      }
      split_into_rows(n);
      // Only the headings asked for: rendered, described, their norms taken in `distances`'
      // column layout (the same columns, so the same reductions).
      const bool summed = params_.pairs == pairing::all_pairs;
      std::vector<char> wanted(static_cast<std::size_t>(angles_), 0);
      for (const row_segment& s : segments_) wanted[static_cast<std::size_t>(s.layer)] = 1;
      describe_tactile(z, tactile_, !summed, &wanted);
      const auto& described = tactile_;  // const: the same reductions as squared_norms(g)
      const Eigen::Index dim = described.rows();
      const auto column = [&](Eigen::Index a, Eigen::Index m) {
        return summed ? a * m_count_ + m : m * angles_ + a;
      };
      // The wanted descriptors' squared norms, in `distances`' column layout.
      norms_.assign(static_cast<std::size_t>(described.cols()), scalar_type(0));
      for (Eigen::Index a = 0; a < angles_; ++a)
        if (wanted[static_cast<std::size_t>(a)] != 0)
          for (Eigen::Index m = 0; m < m_count_; ++m)
            norms_[static_cast<std::size_t>(column(a, m))] =
                described.col(column(a, m)).square().sum();
      // Which patches of which headings fall off the map for a requested pose: their layer
      // means, all in one pass over the field (off_map_means).
      off_.assign(static_cast<std::size_t>(angles_ * m_count_), 0);
      for_each_heading(
          [&](Eigen::Index a, std::span<const row_segment> rows) { mark_off_map(a, rows); });
      if (sampled_means())
        sample_means(column);
      else
        off_map_means(column);
      for_each_heading([&](Eigen::Index a, std::span<const row_segment> rows) {
        // The descriptors of heading a: all pairs one group (its M columns summed by the
        // kernel into S = sum_n D_n), aligned M single descriptors.
        Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> g(dim, m_count_);
        std::vector<scalar_type> norms(static_cast<std::size_t>(m_count_));
        for (Eigen::Index m = 0; m < m_count_; ++m) {
          g.col(m) = described.col(column(a, m));
          norms[static_cast<std::size_t>(m)] = norms_[static_cast<std::size_t>(column(a, m))];
        }
        heading_on(a, rows, g, norms, out);
      });
      for (const detail::tile_range& t : chunks_) {
        const state_range p = detail::tile_positions(t, chunk_states, n);
        auto segment = out.segment(p.begin, p.end - p.begin);
        to_log_likelihood(segment);
      }
    }
  }

 private:
  // Per heading: where each patch lands on the map and on the canvas, the rectangle of states
  // whose patches all land on the map, and the canvas's bilinear sampling table.
  // The rectangle of states (in one layer) whose patch lands on the map.
  struct patch_reach {
    Eigen::Index first_row = 0, first_col = 0, rows = 0, cols = 0;
  };
  struct heading_tables {
    std::vector<grid_cell> field_offset;     // per patch, relative to the state's cell
    std::vector<grid_cell> canvas_top_left;  // per patch, on the canvas
    std::vector<patch_reach> reach;          // per patch
    // Bilinear sampling: canvas px -> top-left px of its 2 x 2 sample in the edge-extended
    // tactile image (extend()), and the fractions (fx, fy) towards the right and lower pixels.
    // 12 bytes per canvas pixel: 0.9 MB for 36 headings of a 46 x 46 canvas, streamed once per
    // touch (the four bilinear weights and two neighbour steps took 28 bytes, 2.1 MB).
    std::vector<std::int32_t> source;
    std::vector<std::array<float, 2>> fraction;
  };

  // Every tactile descriptor into g (dimension x M A): column a M + m is patch m at heading a,
  // or with `by_patch` column m A + a (the aligned kernel's order). g is resized, so a reused
  // workspace costs no allocation.
  // `only` (optional, one flag per heading): describe those headings only, the other columns
  // are left as they were (the tracking hook's headings).
  void describe_tactile(const measurement_type& z,
                        Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic>& g, bool by_patch,
                        const std::vector<char>* only = nullptr) const {
    check_measurement(z);
    image<scalar_type>& zt = extended_;  // reused, like the canvas
    extend(z, zt);
    g.resize(descriptor_.dimension(), m_count_ * angles_);
    const auto column = [&](Eigen::Index a, Eigen::Index m) {
      return by_patch ? m * angles_ + a : a * m_count_ + m;
    };
    image<scalar_type>& canvas = canvas_;  // reused: one touch renders 36 canvases
    canvas.resize(canvas_rows_, canvas_cols_);
    for (Eigen::Index a = 0; a < angles_; ++a) {
      if (only != nullptr && (*only)[static_cast<std::size_t>(a)] == 0) continue;
      const heading_tables& h = heading_[static_cast<std::size_t>(a)];
      render(zt, h, canvas);
      const std::span<const grid_cell> cells(h.canvas_top_left.data(), h.canvas_top_left.size());
      const auto store = [&](const auto& described) {  // dimension x M, patch m in column m
        for (Eigen::Index m = 0; m < m_count_; ++m) g.col(column(a, m)) = described.col(m);
      };
      if constexpr (describes_at_reusing<Descriptor>) {
        store(descriptor_.describe_at(canvas, cells, scratch_));
      } else if constexpr (describes_at<Descriptor>) {
        store(descriptor_.describe_at(canvas, cells));
      } else {
        const auto f = descriptor_.compute(canvas);
        detail::check_field(descriptor_, f, canvas.rows(), canvas.cols(),
                            "a tactile image turned to a heading");
        for (Eigen::Index m = 0; m < m_count_; ++m) {
          const grid_cell c = h.canvas_top_left[static_cast<std::size_t>(m)];
          g.col(column(a, m)) = f.at(c.row, c.col);
        }
      }
    }
  }

  void build_headings(const std::vector<grid_cell>& offsets) {
    const double p = static_cast<double>(descriptor_.patch_size());
    const double w = static_cast<double>(window_.width);
    const double h = static_cast<double>(window_.height);
    // Patch centres relative to the window centre (x right, y down), px.
    std::vector<std::array<double, 2>> centre;
    double reach = 0.0;
    for (const grid_cell& o : offsets) {
      const double cx = static_cast<double>(o.col) + 0.5 * p - 0.5 * w;
      const double cy = static_cast<double>(o.row) + 0.5 * p - 0.5 * h;
      centre.push_back({cx, cy});
      reach = std::max(reach, std::hypot(cx, cy));
    }
    // The canvas holds the whole rotated footprint and every rotated patch (rounded) with a
    // pixel to spare; same parity as the window so that the sensor centre has the same
    // sub-pixel phase on the canvas as on the map (then the rounding below agrees on both).
    const auto side =
        static_cast<Eigen::Index>(std::ceil(std::max(std::hypot(w, h), 2.0 * reach + p + 2.0)));
    canvas_rows_ = side + ((side - window_.height) % 2 != 0 ? 1 : 0);
    canvas_cols_ = side + ((side - window_.width) % 2 != 0 ? 1 : 0);
    const Eigen::Index pad_rows = (canvas_rows_ - window_.height) / 2;
    const Eigen::Index pad_cols = (canvas_cols_ - window_.width) / 2;
    const Eigen::Index pi = descriptor_.patch_size();

    heading_.resize(static_cast<std::size_t>(angles_));
    for (Eigen::Index a = 0; a < angles_; ++a) {
      heading_tables& t = heading_[static_cast<std::size_t>(a)];
      const double theta = detail::layer_heading(a, angles_);
      const double cs = std::cos(theta);
      const double sn = std::sin(theta);
      for (const auto& c : centre) {
        // Top-left of the rotated patch relative to the window's top-left cell, rounded.
        const double x = cs * c[0] - sn * c[1];
        const double y = sn * c[0] + cs * c[1];
        const auto dr = static_cast<Eigen::Index>(std::floor(0.5 * h + y - 0.5 * p + 0.5));
        const auto dc = static_cast<Eigen::Index>(std::floor(0.5 * w + x - 0.5 * p + 0.5));
        t.field_offset.push_back({dr, dc});
        t.canvas_top_left.push_back({pad_rows + dr, pad_cols + dc});
        TACMAP_ASSERT(pad_rows + dr >= 0 && pad_rows + dr + pi <= canvas_rows_ &&
                          pad_cols + dc >= 0 && pad_cols + dc + pi <= canvas_cols_,
                      "a rotated patch left the canvas");
        patch_reach r;
        r.first_row = std::max<Eigen::Index>(0, -dr);
        r.first_col = std::max<Eigen::Index>(0, -dc);
        r.rows = std::max<Eigen::Index>(0, std::min(rows_, field_rows_ - dr) - r.first_row);
        r.cols = std::max<Eigen::Index>(0, std::min(cols_, field_cols_ - dc) - r.first_col);
        t.reach.push_back(r);
      }

      // Canvas pixel centre -> offset from the sensor centre (map frame) -> sensor frame
      // R(-theta) -> tactile pixel coordinates, clamped to the image (edge pixels repeat).
      const auto n = static_cast<std::size_t>(canvas_rows_ * canvas_cols_);
      t.source.resize(n);
      t.fraction.resize(n);
      for (Eigen::Index r = 0; r < canvas_rows_; ++r)
        for (Eigen::Index c = 0; c < canvas_cols_; ++c) {
          const double x = static_cast<double>(c) + 0.5 - 0.5 * static_cast<double>(canvas_cols_);
          const double y = static_cast<double>(r) + 0.5 - 0.5 * static_cast<double>(canvas_rows_);
          const double u = cs * x + sn * y;
          const double v = -sn * x + cs * y;
          const double col = std::clamp(u + 0.5 * w - 0.5, 0.0, w - 1.0);
          const double row = std::clamp(v + 0.5 * h - 0.5, 0.0, h - 1.0);
          const double c0 = std::floor(col);
          const double r0 = std::floor(row);
          const double fx = col - c0;
          const double fy = row - r0;
          const auto k = static_cast<std::size_t>(r * canvas_cols_ + c);
          t.source[k] = static_cast<std::int32_t>(r0 * (w + 1.0) + c0);  // in extend()'s image
          t.fraction[k] = {static_cast<float>(fx), static_cast<float>(fy)};
        }
    }
    build_needed();
  }

  // The dense-field positions (whole field rows) each tactile descriptor needs, in the kernel's
  // descriptor order: the distance kernel skips blocks of positions that none of the
  // descriptors it handles together needs, and computes nothing for patches that never land on
  // the map. All pairs (descriptor a M + m, handled a heading's group at a time): the group's
  // sum S reads what any of its patches reads. Aligned (blocks of three descriptors): each
  // descriptor only its own patch's rows, about 79 of the field's 103 for the paper's window on 120
  // px — and as its columns are ordered patch by patch (descriptor m A + a), a block of three holds
  // one patch at three neighbouring headings, whose rows nearly coincide, so about a fifth of the
  // kernel's work is skipped.
  void build_needed() {
    const auto rows_of = [this](const heading_tables& t, std::size_t m) {
      const patch_reach& r = t.reach[m];
      if (r.rows <= 0 || r.cols <= 0) return detail::position_range{0, 0};
      const Eigen::Index lo = r.first_row + t.field_offset[m].row;
      return detail::position_range{lo * field_cols_, (lo + r.rows) * field_cols_};
    };
    needed_.clear();
    if (params_.pairs == pairing::all_pairs) {
      for (const heading_tables& t : heading_) {
        detail::position_range u{0, 0};
        for (std::size_t m = 0; m < t.reach.size(); ++m) {
          const detail::position_range r = rows_of(t, m);
          if (r.end <= r.begin) continue;
          u = u.end <= u.begin
                  ? r
                  : detail::position_range{std::min(u.begin, r.begin), std::max(u.end, r.end)};
        }
        for (Eigen::Index m = 0; m < m_count_; ++m) needed_.push_back(u);
      }
    } else {
      for (Eigen::Index m = 0; m < m_count_; ++m)
        for (const heading_tables& t : heading_)
          needed_.push_back(rows_of(t, static_cast<std::size_t>(m)));
    }
  }

  // layer += value at the states outside r's rectangle.
  template <class Layer>
  void add_outside(Layer& layer, const patch_reach& r, scalar_type value) const {
    const Eigen::Index below = rows_ - r.first_row - r.rows;
    const Eigen::Index right = cols_ - r.first_col - r.cols;
    if (r.first_row > 0) layer.topRows(r.first_row) += value;
    if (below > 0) layer.bottomRows(below) += value;
    if (r.first_col > 0) layer.block(r.first_row, 0, r.rows, r.first_col) += value;
    if (right > 0) layer.block(r.first_row, r.first_col + r.cols, r.rows, right) += value;
  }

  // Field positions per band of `distances`: 64 tiles = 512 float positions, x 36 headings
  // (all pairs: 74 KB) or x 108 descriptors (aligned, 3 patches x 36 headings: 221 KB).
  static constexpr Eigen::Index band_tiles = 64;

  // The distances of band positions [first, last) (band row p - first, column `d`) that patch
  // reach r at field offset o reads, added row by row by add_row into dest(field row, first
  // column) and summed: in float within the band (a few hundred values), returned in double
  // (the bands are summed in double). One routine for the whole grid's pass and the tracking
  // hook's off-map means, so that both sum in the same order.
  template <class Dest>
  double add_reach(const scalar_type* d, const patch_reach& r, grid_cell o, Eigen::Index first,
                   Eigen::Index last, Dest dest) const {
    const Eigen::Index fc = field_cols_;
    // Field rows of this band that the reach reads, and its columns.
    const Eigen::Index row_lo = std::max(first / fc, r.first_row + o.row);
    const Eigen::Index row_hi = std::min((last - 1) / fc + 1, r.first_row + r.rows + o.row);
    const Eigen::Index col_lo = r.first_col + o.col;
    const Eigen::Index col_hi = col_lo + r.cols;
    xsimd::batch<scalar_type> acc(scalar_type(0));
    scalar_type tails = 0;
    for (Eigen::Index fr = row_lo; fr < row_hi; ++fr) {
      const Eigen::Index c0 = std::max(col_lo, first - fr * fc);
      const Eigen::Index c1 = std::min(col_hi, last - fr * fc);
      if (c1 <= c0) continue;
      tails += detail::add_row(d + fr * fc + c0 - first, dest(fr, c0), c1 - c0, acc);
    }
    return static_cast<double>(xsimd::hadd(acc)) + static_cast<double>(tails);
  }

  // Adds the distances of field positions [first, last) (band row p - first) to every layer:
  // patch m of heading a at state x reads position x + o_{a,m}, for the states of its reach.
  template <class Out>
  void add_band(const Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic>& band,
                Eigen::Index first, Eigen::Index last, Out& out) const {
    const Eigen::Index plane = rows_ * cols_;
    for (Eigen::Index a = 0; a < angles_; ++a) {
      const heading_tables& h = heading_[static_cast<std::size_t>(a)];
      scalar_type* layer = out.data() + a * plane;
      for (Eigen::Index m = 0; m < m_count_; ++m) {
        const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
        if (r.rows <= 0 || r.cols <= 0) continue;
        const grid_cell o = h.field_offset[static_cast<std::size_t>(m)];
        // All pairs: heading a's column holds S = sum_n D_n; aligned: D_m in column m A + a.
        const scalar_type* d = &band(0, params_.pairs == pairing::all_pairs ? a : m * angles_ + a);
        sums_[static_cast<std::size_t>(a * m_count_ + m)] +=
            add_reach(d, r, o, first, last, [&](Eigen::Index fr, Eigen::Index c0) {
              return layer + (fr - o.row) * cols_ + (c0 - o.col);
            });
      }
    }
  }

  // Eq. (2) or the exponential, tempered (tempering > 0), in place: one expression for the
  // whole grid and for the tracking hook's chunks, so that both evaluate it alike.
  template <class X>
  void to_log_likelihood(X& x) const {
    const auto temper = static_cast<scalar_type>(params_.tempering);
    if (params_.shape == likelihood_shape::inverse)
      x = -temper * (x + static_cast<scalar_type>(params_.epsilon)).log();
    else
      x *= -temper / static_cast<scalar_type>(params_.tau);
  }

  // The tracking hook's unit of poses: 16 floats (64 bytes) hold whole SIMD packets of every
  // x86 level up to AVX-512, so Eigen's vectorised logarithm takes the same packets (and the
  // same scalar tail at the grid's end) on a chunk as on the whole grid.
  static constexpr Eigen::Index chunk_states = 16;

  // Poses [col_begin, col_end) of row `row` in layer `layer` (tracking hook).
  struct row_segment {
    Eigen::Index layer = 0, row = 0, col_begin = 0, col_end = 0;
  };

  // chunks_ (ranges of chunk_states poses) as row segments, layer by layer, into segments_.
  void split_into_rows(Eigen::Index n) const {
    const Eigen::Index plane = rows_ * cols_;
    segments_.clear();
    for (const detail::tile_range& t : chunks_) {
      const state_range p = detail::tile_positions(t, chunk_states, n);
      for (Eigen::Index i = p.begin; i < p.end;) {
        const Eigen::Index a = i / plane;
        const Eigen::Index within = i - a * plane;
        const Eigen::Index row = within / cols_;
        const Eigen::Index col = within - row * cols_;
        const Eigen::Index end = std::min(cols_, col + (p.end - i));
        segments_.push_back({a, row, col, end});
        i += end - col;
      }
    }
  }

  // f(a, rows) for each heading a with requested poses, `rows` its row segments.
  template <class F>
  void for_each_heading(F&& f) const {
    std::size_t s0 = 0;
    while (s0 < segments_.size()) {
      const Eigen::Index a = segments_[s0].layer;
      std::size_t s1 = s0;
      while (s1 < segments_.size() && segments_[s1].layer == a) ++s1;
      f(a, std::span<const row_segment>(segments_.data() + s0, s1 - s0));
      s0 = s1;
    }
  }

  // True when pose (row, col) of heading h's layer has patch m on the map.
  static bool lands(const heading_tables& h, Eigen::Index m, Eigen::Index row, Eigen::Index col) {
    const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
    return row >= r.first_row && row < r.first_row + r.rows && col >= r.first_col &&
           col < r.first_col + r.cols;
  }

  // --- Off-map means on large maps (issue 14, tracking at camera resolution) ---
  // A patch off the map contributes its mean distance over the poses where it lands (file
  // comment). On a map of more than `off_map_exact_positions` field positions that mean is
  // taken over a fixed lattice of the field (every s-th row and column, s chosen for about
  // `off_map_sample` of them) instead of every position, in the whole grid's pass and
  // in the tracking hook alike: the hook then needs the distances of a few thousand positions,
  // not a pass over the field (30 ms per tracked touch on 640 x 480 at 36 headings whenever a
  // requested pose had a patch off the map). The value is an estimate of the same
  // uninformative mean (distances vary by tens of percent over a map; the lattice's mean of
  // 4,096 of them is within a percent or so), and maps up to about 128 x 128 px keep the exact
  // mean.
  [[nodiscard]] bool sampled_means() const {
    if constexpr (!euclidean_descriptor<Descriptor>)
      return false;
    else
      return sample_tiles_.positions() > 0;
  }

  void build_mean_sample(const descriptor_field<scalar_type>& field) {
    const Eigen::Index positions = field.rows * field.cols;
    if (!euclidean_descriptor<Descriptor> || positions <= params_.off_map_exact_positions) return;
    const auto stride = std::max<Eigen::Index>(
        1, static_cast<Eigen::Index>(std::ceil(std::sqrt(
               static_cast<double>(positions) / static_cast<double>(params_.off_map_sample)))));
    sample_at_.clear();
    for (Eigen::Index r = 0; r < field.rows; r += stride)
      for (Eigen::Index c = 0; c < field.cols; c += stride) sample_at_.push_back({r, c});
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> values(
        field.values.rows(), static_cast<Eigen::Index>(sample_at_.size()));
    for (std::size_t k = 0; k < sample_at_.size(); ++k)
      values.col(static_cast<Eigen::Index>(k)) = field.at(sample_at_[k].row, sample_at_[k].col);
    sample_tiles_ = detail::descriptor_tiles<scalar_type>(values);
  }

  // True when some pose of heading a has patch m off the map (and the patch lands somewhere).
  [[nodiscard]] bool off_somewhere(Eigen::Index a, Eigen::Index m) const {
    const patch_reach& r = heading_[static_cast<std::size_t>(a)].reach[static_cast<std::size_t>(m)];
    return r.rows > 0 && r.cols > 0 && (r.rows < rows_ || r.cols < cols_);
  }

  // tactile_'s columns `columns` (and their norms_) side by side, in that order: the
  // descriptors an off-map pass meets the field with.
  void gather_columns(const std::vector<Eigen::Index>& columns,
                      Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic>& g,
                      std::vector<scalar_type>& norms) const {
    const auto count = static_cast<Eigen::Index>(columns.size());
    g.resize(tactile_.rows(), count);
    norms.resize(static_cast<std::size_t>(count));
    for (Eigen::Index j = 0; j < count; ++j) {
      const auto c = static_cast<std::size_t>(columns[static_cast<std::size_t>(j)]);
      g.col(j) = tactile_.col(static_cast<Eigen::Index>(c));
      norms[static_cast<std::size_t>(j)] = norms_[c];
    }
  }

  // means_[a M + m] for every off_ patch, over the lattice sample: the patch's distances (all
  // pairs: its heading's summed distance) at the sample positions inside the field rectangle
  // it reads, averaged in double; a rectangle holding no sample position takes the mean over
  // the whole sample. The same computation whichever patches are asked for (the kernel gives
  // each descriptor the same values whatever its neighbours), so the hook's means equal the
  // whole grid's. Reads tactile_ and norms_ in the kernel's column layout (`column`).
  template <class Column>
  void sample_means(const Column& column) const {
    const bool summed = params_.pairs == pairing::all_pairs;
    means_.assign(off_.size(), scalar_type(0));
    struct item {
      Eigen::Index a, m, out;
    };
    std::vector<item> items;
    std::vector<Eigen::Index> columns;
    const Eigen::Index group = summed ? m_count_ : 1;
    for (Eigen::Index a = 0; a < angles_; ++a) {
      bool any = false;
      for (Eigen::Index m = 0; m < m_count_; ++m) {
        if (off_[static_cast<std::size_t>(a * m_count_ + m)] == 0) continue;
        any = true;
        items.push_back({a, m,
                         summed ? static_cast<Eigen::Index>(columns.size()) / group
                                : static_cast<Eigen::Index>(columns.size())});
        if (!summed) columns.push_back(column(a, m));
      }
      if (summed && any)
        for (Eigen::Index m = 0; m < m_count_; ++m) columns.push_back(column(a, m));
    }
    if (items.empty()) return;
    const auto count = static_cast<Eigen::Index>(columns.size());
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> g;
    std::vector<scalar_type> norms;
    gather_columns(columns, g, norms);
    constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
    const Eigen::Index k_count = sample_tiles_.positions();
    const Eigen::Index padded = (k_count + width - 1) / width * width;
    auto& d = sample_buffer_;
    d.resize(padded, count / group);
    detail::distances_each(sample_tiles_, g, norms.data(), d.data(), d.rows(), nullptr, {}, group);
    for (const item& it : items) {
      const heading_tables& h = heading_[static_cast<std::size_t>(it.a)];
      const patch_reach& r = h.reach[static_cast<std::size_t>(it.m)];
      const grid_cell o = h.field_offset[static_cast<std::size_t>(it.m)];
      const Eigen::Index r0 = r.first_row + o.row, c0 = r.first_col + o.col;
      double sum = 0.0, all = 0.0;
      Eigen::Index n = 0;
      for (Eigen::Index k = 0; k < k_count; ++k) {
        const grid_cell at = sample_at_[static_cast<std::size_t>(k)];
        const auto v = static_cast<double>(d(k, it.out));
        all += v;
        if (at.row >= r0 && at.row < r0 + r.rows && at.col >= c0 && at.col < c0 + r.cols) {
          sum += v;
          ++n;
        }
      }
      means_[static_cast<std::size_t>(it.a * m_count_ + it.m)] = static_cast<scalar_type>(
          n > 0 ? sum / static_cast<double>(n) : all / static_cast<double>(k_count));
    }
  }

  // off_[a M + m] = 1 when a pose of `rows` (heading a) has patch m off the map, and the patch
  // lands somewhere (a patch that never does adds nothing, see `distances`).
  void mark_off_map(Eigen::Index a, std::span<const row_segment> rows) const {
    const heading_tables& h = heading_[static_cast<std::size_t>(a)];
    for (Eigen::Index m = 0; m < m_count_; ++m) {
      const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
      if (r.rows <= 0 || r.cols <= 0) continue;
      for (const row_segment& s : rows) {
        const bool row_in = s.row >= r.first_row && s.row < r.first_row + r.rows;
        if (!row_in || s.col_begin < r.first_col || s.col_end > r.first_col + r.cols) {
          off_[static_cast<std::size_t>(a * m_count_ + m)] = 1;
          break;
        }
      }
    }
  }

  // means_[a M + m] for every off_ patch: its distances' mean over the poses where it lands,
  // summed exactly as `distances` sums it (add_band: per band of the field, whole registers
  // into one accumulator and the rest apart, the bands in double). Those patches' descriptors
  // (all pairs: their headings' groups) meet the field in one banded pass, as in `distances`,
  // so the field is read once however many patches fall off (one pass per patch measured
  // 94 ms for a tracked touch on 640 x 480, 36 headings, six such patches).
  template <class Column>
  void off_map_means(const Column& column) const {
    const bool summed = params_.pairs == pairing::all_pairs;
    means_.assign(off_.size(), scalar_type(0));
    // The descriptors to compute, and per output column the patches it serves.
    struct item {
      Eigen::Index a, m, out;  // heading, patch, output column
    };
    std::vector<item> items;
    std::vector<Eigen::Index> columns;           // tactile_ columns, kernel order
    std::vector<detail::position_range> ranges;  // per descriptor: the reach rows it serves
    const Eigen::Index group = summed ? m_count_ : 1;
    const Eigen::Index fc = field_cols_;
    const auto reach_rows = [&](Eigen::Index a, Eigen::Index m) {
      const heading_tables& h = heading_[static_cast<std::size_t>(a)];
      const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
      const Eigen::Index lo = r.first_row + h.field_offset[static_cast<std::size_t>(m)].row;
      return detail::position_range{lo * fc, (lo + r.rows) * fc};
    };
    for (Eigen::Index a = 0; a < angles_; ++a) {
      if (summed) {
        detail::position_range u{0, 0};
        for (Eigen::Index m = 0; m < m_count_; ++m) {
          if (off_[static_cast<std::size_t>(a * m_count_ + m)] == 0) continue;
          const detail::position_range r = reach_rows(a, m);
          u = u.end <= u.begin
                  ? r
                  : detail::position_range{std::min(u.begin, r.begin), std::max(u.end, r.end)};
          items.push_back({a, m, static_cast<Eigen::Index>(columns.size()) / group});
        }
        if (u.end <= u.begin) continue;
        for (Eigen::Index m = 0; m < m_count_; ++m) {
          columns.push_back(column(a, m));
          ranges.push_back(u);
        }
      } else {
        for (Eigen::Index m = 0; m < m_count_; ++m) {
          if (off_[static_cast<std::size_t>(a * m_count_ + m)] == 0) continue;
          items.push_back({a, m, static_cast<Eigen::Index>(columns.size())});
          columns.push_back(column(a, m));
          ranges.push_back(reach_rows(a, m));
        }
      }
    }
    if (items.empty()) return;
    const auto count = static_cast<Eigen::Index>(columns.size());
    Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> g;
    std::vector<scalar_type> norms;
    gather_columns(columns, g, norms);
    constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
    const Eigen::Index positions = field_rows_ * field_cols_;
    Eigen::Index lo = positions, hi = 0;
    for (const detail::position_range& r : ranges) {
      lo = std::min(lo, r.begin);
      hi = std::max(hi, r.end);
    }
    std::vector<double> totals(items.size(), 0.0);
    auto& band = workspace_;  // as in distances(): band position p - first x output column
    band.resize(band_tiles * width, count / group);
    row_scratch_.resize(static_cast<std::size_t>(std::max<Eigen::Index>(cols_, 1)));
    const Eigen::Index tiles = (positions + width - 1) / width;
    for (Eigen::Index t0 = lo / width / band_tiles * band_tiles; t0 * width < hi;
         t0 += band_tiles) {
      const Eigen::Index t1 = std::min(t0 + band_tiles, tiles);
      const Eigen::Index first = t0 * width;
      const Eigen::Index last = std::min(t1 * width, positions);
      detail::distances_each(field_tiles_, g, norms.data(), band.data(), band.rows(), ranges.data(),
                             {t0, t1}, group);
      for (std::size_t i = 0; i < items.size(); ++i) {
        const item& it = items[i];
        const heading_tables& h = heading_[static_cast<std::size_t>(it.a)];
        const patch_reach& r = h.reach[static_cast<std::size_t>(it.m)];
        const grid_cell o = h.field_offset[static_cast<std::size_t>(it.m)];
        // The sums only (row_scratch_ takes the rows add_row writes): the layer means' order.
        totals[i] += add_reach(&band(0, it.out), r, o, first, last,
                               [&](Eigen::Index, Eigen::Index) { return row_scratch_.data(); });
      }
    }
    for (std::size_t i = 0; i < items.size(); ++i) {
      const item& it = items[i];
      const patch_reach& r =
          heading_[static_cast<std::size_t>(it.a)].reach[static_cast<std::size_t>(it.m)];
      means_[static_cast<std::size_t>(it.a * m_count_ + it.m)] =
          static_cast<scalar_type>(totals[i] / static_cast<double>(r.rows * r.cols));
    }
  }

  // Heading a's poses `rows` (row segments of layer a) into `out`, as distances() and
  // add_band() would write them (off-map patches: means_). g, norms: the heading's M tactile
  // descriptors (patch order).
  template <class Out>
  void heading_on(Eigen::Index a, std::span<const row_segment> rows,
                  const Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic>& g,
                  const std::vector<scalar_type>& norms, Out& out) const {
    constexpr Eigen::Index width = detail::descriptor_tiles<scalar_type>::width;
    const bool summed = params_.pairs == pairing::all_pairs;
    const Eigen::Index fc = field_cols_;
    const Eigen::Index positions = field_rows_ * field_cols_;
    const Eigen::Index tiles = (positions + width - 1) / width;
    const heading_tables& h = heading_[static_cast<std::size_t>(a)];
    const auto m_size = static_cast<std::size_t>(m_count_);
    // Distance columns: all pairs one (S, the group's sum), aligned one per patch; the field
    // tiles each column needs (the requested poses' patches on the map).
    const Eigen::Index columns = summed ? 1 : m_count_;
    field_buffer_.resize(tiles * width, columns);
    std::vector<std::vector<detail::tile_range>> need(static_cast<std::size_t>(columns));
    for (Eigen::Index m = 0; m < m_count_; ++m) {
      const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
      const grid_cell o = h.field_offset[static_cast<std::size_t>(m)];
      auto& tiles_of = need[static_cast<std::size_t>(summed ? 0 : m)];
      for (const row_segment& s : rows) {
        if (s.row < r.first_row || s.row >= r.first_row + r.rows) continue;
        const Eigen::Index c0 = std::max(s.col_begin, r.first_col);
        const Eigen::Index c1 = std::min(s.col_end, r.first_col + r.cols);
        if (c1 <= c0) continue;
        const Eigen::Index p = (s.row + o.row) * fc + o.col;
        tiles_of.push_back({(p + c0) / width, (p + c1 + width - 1) / width});
      }
    }
    // The distances on those tiles (merged), the same kernel as distances().
    for (Eigen::Index k = 0; k < columns; ++k) {
      auto& ranges = need[static_cast<std::size_t>(k)];
      detail::sort_and_merge(ranges);
      scalar_type* column = field_buffer_.data() + k * field_buffer_.rows();
      for (const detail::tile_range& t : ranges) {
        if (summed) {
          detail::distances_each(field_tiles_, g, norms.data(), column + t.begin * width,
                                 field_buffer_.rows(), nullptr, t, m_count_);
        } else {
          const Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> gm = g.col(k);
          detail::distances_each(field_tiles_, gm, norms.data() + k, column + t.begin * width,
                                 field_buffer_.rows(), nullptr, t, 1);
        }
      }
    }
    // Each pose: 0, plus its patches' distances in the order add_band adds them (the band of
    // the field position first, then the patch), then the off-map means in patch order. Along
    // a row segment that order changes only where a patch's field position crosses into the
    // next band or the patch starts or stops landing on the map: between those columns every
    // pose adds the same columns of field_buffer_ in the same order, done one whole run at a
    // time (the same float additions per pose, so the same values; a per-pose sort of its terms
    // was 9 % of a tracked touch at 36 headings).
    constexpr Eigen::Index band = band_tiles * width;
    struct term {
      Eigen::Index band, m;
    };
    std::vector<term> terms;
    terms.reserve(m_size);
    std::vector<Eigen::Index>& cuts = cuts_;
    scalar_type* layer = out.data() + a * rows_ * cols_;
    for (const row_segment& s : rows) {
      cuts.assign({s.col_begin, s.col_end});
      const auto cut = [&](Eigen::Index c) {
        if (c > s.col_begin && c < s.col_end) cuts.push_back(c);
      };
      for (Eigen::Index m = 0; m < m_count_; ++m) {
        const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
        if (s.row < r.first_row || s.row >= r.first_row + r.rows) continue;
        cut(r.first_col);
        cut(r.first_col + r.cols);
        const grid_cell o = h.field_offset[static_cast<std::size_t>(m)];
        const Eigen::Index p0 = (s.row + o.row) * fc + o.col;  // field position at column 0
        for (Eigen::Index b = (p0 + s.col_begin) / band + 1; b * band - p0 < s.col_end; ++b)
          cut(b * band - p0);
      }
      std::sort(cuts.begin(), cuts.end());
      cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
      scalar_type* row = layer + s.row * cols_;
      for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
        const Eigen::Index c0 = cuts[k], c1 = cuts[k + 1];
        terms.clear();
        for (Eigen::Index m = 0; m < m_count_; ++m) {
          if (!lands(h, m, s.row, c0)) continue;
          const grid_cell o = h.field_offset[static_cast<std::size_t>(m)];
          terms.push_back({((s.row + o.row) * fc + c0 + o.col) / band, m});
        }
        // Stable, by band: an insertion sort of the few terms.
        for (std::size_t i = 1; i < terms.size(); ++i)
          for (std::size_t j = i; j > 0 && terms[j - 1].band > terms[j].band; --j)
            std::swap(terms[j - 1], terms[j]);
        if (terms.empty()) std::fill(row + c0, row + c1, scalar_type(0));
        for (std::size_t i = 0; i < terms.size(); ++i) {
          const Eigen::Index m = terms[i].m;
          const grid_cell o = h.field_offset[static_cast<std::size_t>(m)];
          const scalar_type* d = field_buffer_.data() + (summed ? 0 : m) * field_buffer_.rows() +
                                 (s.row + o.row) * fc + o.col;
          if (i == 0)
            for (Eigen::Index c = c0; c < c1; ++c) row[c] = d[c];  // 0 + d: d
          else
            for (Eigen::Index c = c0; c < c1; ++c) row[c] += d[c];
        }
        for (Eigen::Index m = 0; m < m_count_; ++m) {
          const patch_reach& r = h.reach[static_cast<std::size_t>(m)];
          if (r.rows <= 0 || r.cols <= 0) continue;  // never on the map: nothing added
          if (lands(h, m, s.row, c0)) continue;
          const scalar_type mean = means_[static_cast<std::size_t>(a * m_count_ + m)];
          for (Eigen::Index c = c0; c < c1; ++c) row[c] += mean;
        }
      }
    }
  }

  // The tactile image with its last column and row repeated once more ((H + 1) x (W + 1)):
  // a bilinear sample whose coordinates are clamped to the image then always has its right and
  // lower neighbours, weighted 0 on the last column or row, with no test per pixel.
  void extend(const measurement_type& z, image<scalar_type>& out) const {
    const Eigen::Index h = z.rows();
    const Eigen::Index w = z.cols();
    out.resize(h + 1, w + 1);
    out.topLeftCorner(h, w) = z.template cast<scalar_type>();
    out.col(w).head(h) = out.col(w - 1).head(h);
    out.row(h) = out.row(h - 1);
  }

  void render(const image<scalar_type>& extended, const heading_tables& t,
              image<scalar_type>& canvas) const {
    const scalar_type* src = extended.data();  // row-major, W + 1 per row
    const Eigen::Index stride = extended.cols();
    scalar_type* dst = canvas.data();
    const auto n = static_cast<std::size_t>(canvas.size());
    for (std::size_t k = 0; k < n; ++k) {
      const scalar_type* s = src + t.source[k];
      const auto fx = static_cast<scalar_type>(t.fraction[k][0]);
      const auto fy = static_cast<scalar_type>(t.fraction[k][1]);
      const scalar_type top = s[0] + fx * (s[1] - s[0]);
      const scalar_type bottom = s[stride] + fx * (s[stride + 1] - s[stride]);
      dst[k] = top + fy * (bottom - top);
    }
  }

  void check_measurement(const measurement_type& z) const {
    detail::check_tactile_image("rotated_descriptor_likelihood", z, window_);
  }

  template <class G>
  void check_grid(const G& grid) const {
    if (grid.rows() != rows_ || grid.cols() != cols_ || grid.size() != rows_ * cols_ * angles_)
      detail::fail("rotated_descriptor_likelihood: the grid has ", grid.size(), " states (",
                   grid.rows(), " x ", grid.cols(), " per layer) but the map, window and ", angles_,
                   " headings give ", rows_ * cols_ * angles_, " (", rows_, " x ", cols_,
                   " per layer); build the pose grid and the model from the same map, window "
                   "and angle count");
  }

  Descriptor descriptor_;
  rotated_likelihood_params params_;
  pixel_size window_;
  int angles_;
  Eigen::Index m_count_ = 0;
  Eigen::Index rows_ = 0;  // states down one layer
  Eigen::Index cols_ = 0;  // states across one layer
  Eigen::Index field_rows_ = 0;
  Eigen::Index field_cols_ = 0;
  Eigen::Index canvas_rows_ = 0;
  Eigen::Index canvas_cols_ = 0;
  detail::descriptor_tiles<scalar_type> field_tiles_;
  std::vector<heading_tables> heading_;
  std::vector<detail::position_range> needed_;  // per descriptor, kernel order (build_needed)
  // Per-touch distances of one band (positions x M * angles, or x angles for all pairs) and the
  // tactile descriptors' squared norms, kept between calls: not reentrant, like
  // descriptor_likelihood. One filter per thread.
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> workspace_;
  mutable std::vector<scalar_type> g_norms_;
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> tactile_;  // g, kernel order
  mutable typename descriptor_workspace<Descriptor>::type scratch_;  // the descriptor's scratch
  mutable image<scalar_type> canvas_;    // the tactile image turned to one heading
  mutable image<scalar_type> extended_;  // the tactile image, edge-extended (extend())
  mutable std::vector<double> sums_;     // per tactile descriptor: its distances' sum
  // Tracking hook (log_likelihood_on): the chunks of poses asked for, as row segments, and one
  // heading's distances at the field positions they read (field positions x 1 or M; only the
  // tiles computed are meaningful).
  mutable std::vector<detail::tile_range> chunks_;
  mutable std::vector<row_segment> segments_;
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> field_buffer_;
  mutable std::vector<scalar_type> row_scratch_;  // add_row's destination, discarded
  mutable std::vector<Eigen::Index> cuts_;        // heading_on: one row segment's run limits
  mutable std::vector<scalar_type> norms_;        // the wanted descriptors' squared norms
  mutable std::vector<char> off_;                 // per a M + m: some requested pose off the map
  mutable std::vector<scalar_type> means_;        // per a M + m: its off-map mean (off_ only)
  // Large maps: the lattice sample of the field for the off-map means (empty: exact means),
  // its positions (field row, column), and its distances to the asked descriptors.
  detail::descriptor_tiles<scalar_type> sample_tiles_;
  std::vector<grid_cell> sample_at_;
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, Eigen::Dynamic> sample_buffer_;
};

}  // namespace tacmap

// Compiled once in tacmap::precompiled where it is linked (tacmap/precompiled.hpp): the model with
// SIFT-lite and classic SIFT, and the (x, y, theta) filters of the Gaussian odometry model with
// them.
#include "tacmap/precompiled.hpp"
#ifdef TACMAP_EXTERN_TEMPLATE
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
namespace tacmap {
TACMAP_EXTERN_TEMPLATE class rotated_descriptor_likelihood<sift_lite>;
TACMAP_EXTERN_TEMPLATE class rotated_descriptor_likelihood<classic_sift>;
TACMAP_EXTERN_FILTER_CORE(pose_grid<float>, pose_odometry_gaussian);
TACMAP_EXTERN_FILTER(pose_grid<float>, pose_odometry_gaussian,
                     rotated_descriptor_likelihood<sift_lite>);
TACMAP_EXTERN_FILTER(pose_grid<float>, pose_odometry_gaussian,
                     rotated_descriptor_likelihood<classic_sift>);
}  // namespace tacmap
#endif
