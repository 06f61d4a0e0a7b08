// tacmap: `library_motion` — a motion model over a `library_grid`: the same motion applied to
// every object's block, on that object's own grid.
//
// The control update of Table 1 over the joint state (k, x), with the object static (the hand
// holds the object it closed on):
//
//   bel_bar(k, x) = sum_{x'} p(x | u, x', k) bel(k, x')
//
// The odometry u is the same for every object (it is the arm's motion); what differs is each
// object's grid (its size and scale), so the motion model moves each block on its own grid.
// Blocks keep their relative masses (`detail::predict_blocks`): moving does not change which
// object is held, except that mass carried off an object's map is lost from that object.
#pragma once

#include <algorithm>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/grid/library_grid.hpp"
#include "tacmap/motion/concept.hpp"
#include "tacmap/motion/detail/block_prediction.hpp"

namespace tacmap {

/// `Motion` (a motion model of the objects' grids) applied to every object of a
/// `library_grid`. Each object gets its own copy of `Motion` (made at the first prediction), so
/// models that keep per-grid workspaces keep one per object. Not reentrant: one filter per
/// thread.
template <class Motion>
class library_motion {
 public:
  using control_type = typename Motion::control_type;

  explicit library_motion(Motion motion) : motion_(std::move(motion)) {}

  /// The motion model every object's copy starts from.
  [[nodiscard]] const Motion& base() const { return motion_; }

  template <library_state_grid G>
  requires motion_model<Motion, typename G::object_grid_type> prediction_report
  predict(const G& grid, const belief_array<G>& in, belief_array<G>& out, const control_type& u)
  const {
    using T = typename G::scalar_type;
    const Eigen::Index objects = grid.objects();
    if (static_cast<Eigen::Index>(per_object_.size()) != objects)
      per_object_.assign(static_cast<std::size_t>(objects), motion_);
    auto& buffers = scratch<T>();
    buffers.resize(static_cast<std::size_t>(objects));
    const detail::block_masses m = detail::predict_blocks<T>(
        objects,
        [&](Eigen::Index k) {
          return std::pair{grid.object_offset(k), grid.object_size(k)};
        },
        [&](Eigen::Index k) {
          auto& b = buffers[static_cast<std::size_t>(k)];
          return std::tie(b.first, b.second);
        },
        [&](Eigen::Index k, const auto& block, auto& moved) {
          return per_object_[static_cast<std::size_t>(k)].predict(grid.object(k), block, moved, u);
        },
        in, out, kept_, "library_motion", "objects");
    out *= static_cast<T>(1.0 / detail::mass_sum(out));
    return {std::clamp(1.0 - m.kept / m.before, 0.0, 1.0)};
  }

 private:
  template <class T>
  using buffer_pair =
      std::pair<Eigen::Array<T, Eigen::Dynamic, 1>, Eigen::Array<T, Eigen::Dynamic, 1>>;
  template <class T>
  std::vector<buffer_pair<T>>& scratch() const {
    if constexpr (std::is_same_v<T, float>)
      return scratch_f_;
    else
      return scratch_d_;
  }

  Motion motion_;
  mutable std::vector<Motion> per_object_;
  // Per object: its block in and out, kept between calls (no allocation per predict).
  mutable std::vector<buffer_pair<float>> scratch_f_;
  mutable std::vector<buffer_pair<double>> scratch_d_;
  mutable std::vector<double> kept_;  // per object: the mass its block kept
};

}  // namespace tacmap
