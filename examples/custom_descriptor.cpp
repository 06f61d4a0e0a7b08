// custom_descriptor — your own descriptor through tacmap's front door.
//
// The problem: the paper matches tactile and visual images with SIFT-like descriptors. Suppose
// you want to try something else — here the simplest thing that could work: a patch's raw
// pixels, made zero-mean and unit-norm so that contact pressure and camera exposure cancel out.
// Anything that models `tacmap::descriptor` (a scalar type, dimension(), patch_size(), a dense
// compute() and a distance()) runs in `tacmap::descriptor_localizer<D>`, with everything the
// shipped models get: raw frames in, the latent appearance (the photograph's bright parts may be
// the raised ones or the sunken ones: nothing needs to be told), the robust motion, restarts and
// a verdict to act on. The user code is the descriptor (19 lines) and `main` (21), counting
// every line but blank ones and whole-line comments.
//
// The run: the simulated sensor presses a 120 x 120 px object twice along the same path — once
// with its bright parts raised, once with its dark parts raised — with 0.3 mm odometry noise.
// Exit status 0 when each run ends "localized" within 5 mm and finds the right appearance.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "tacmap/localizer.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace {

// ---- User code: a descriptor of your own. The zero-mean, unit-norm pixels of a 15 x 15 patch.
struct normalised_patch {
  using scalar_type = float;
  static constexpr bool euclidean_distance = true;  // opt into the matrix-product fast path
  Eigen::Index dimension() const { return 15 * 15; }
  Eigen::Index patch_size() const { return 15; }
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    if (img.rows() < 15 || img.cols() < 15 || !img.allFinite())
      throw std::invalid_argument("normalised_patch: a finite image of at least 15 x 15 px");
    tacmap::descriptor_field<float> f{{}, img.rows() - 14, img.cols() - 14};
    f.values.resize(dimension(), f.rows * f.cols);
    for (Eigen::Index i = 0; i < f.values.cols(); ++i) {  // patch i at (i / cols, i % cols)
      Eigen::ArrayXf v = img.block(i / f.cols, i % f.cols, 15, 15).reshaped<Eigen::RowMajor>();
      v -= v.mean();
      f.values.col(i) = v / std::max(std::sqrt(v.square().sum()), 1e-6F);  // a flat patch: 0
    }
    return f;
  }
  float distance(const auto& a, const auto& b) const { return std::sqrt((a - b).square().sum()); }
};

// ---- Not user code: the object's photograph and a simulated robot pressing it.
// The photograph: bright bars on a dark ground (0 and 1), 120 x 120 px at the paper's scale.
constexpr double mm_per_px = 3.4 / 3.0;
tacmap::image<float> make_object() {
  std::mt19937 rng(7);
  tacmap::image<float> map = tacmap::image<float>::Zero(120, 120);
  std::uniform_int_distribution<Eigen::Index> corner(0, 105), extent(4, 16);
  for (int bar = 0; bar < 24; ++bar)
    map.block(corner(rng), corner(rng), extent(rng), extent(rng)).setOnes();
  return map;
}

// The paper's 14 x 6 array pressed on the object whose raised parts are the photograph's bright
// parts (or its dark ones), moved along a path with 0.3 mm odometry noise.
struct simulated_robot {
  simulated_robot(const tacmap::image<float>& map, bool bright_raised)
      : sim(tacmap::relief_from_image(bright_raised ? map : tacmap::image<float>(1.0F - map)),
            {map.cols(), map.rows()}, mm_per_px) {}
  tacmap::tactile_frame frame() { return sim.render(at); }
  tacmap::odometry move(int t) {  // the move to touch t, and what the arm reports of it
    if (t == 0) return {};
    const tacmap::odometry step{.dx_mm = t % 2 ? -7.0 : 5.0, .dy_mm = t % 3 ? 6.0 : -4.0};
    at.x_mm += step.dx_mm;
    at.y_mm += step.dy_mm;
    return {step.dx_mm + noise(rng), step.dy_mm + noise(rng)};
  }
  double error(const Eigen::Vector2d& estimate_mm) const {
    return (estimate_mm - Eigen::Vector2d(at.x_mm, at.y_mm)).norm();
  }
  tacmap::tactile_simulator sim;
  tacmap::map_pose at{.x_mm = 80.0, .y_mm = 40.0};
  std::mt19937 rng{11};
  std::normal_distribution<double> noise{0.0, 0.3};
};

}  // namespace

// ---- User code: localize with the descriptor, act on the verdict.
int main() {
  // tau: the scale of this descriptor's distances (tacmap::fit_tau fits it on your
  // photographs, docs/concepts.md).
  tacmap::localizer_config config;
  config.features = tacmap::window_features::shared_dense;  // one dense field for all windows
  config.tau = 0.5;
  const tacmap::image<float> map = make_object();
  int failures = 0;
  for (const bool bright_raised : {true, false}) {
    tacmap::descriptor_localizer<normalised_patch> loc(map, mm_per_px, config);
    simulated_robot robot(map, bright_raised);
    for (int t = 0; t < 8; ++t) {
      const tacmap::odometry moved = robot.move(t);  // none before the first touch
      const tacmap::touch_result r = loc.touch(robot.frame(), moved);
      std::printf("%s raised, touch %d: %-11s P(within) %.2f, P(inverted) %.2f, error %.2f mm\n",
                  bright_raised ? "bright" : "dark", t + 1, to_string(r.verdict),
                  r.probability_within, r.appearance_probability[1], robot.error(r.position_mm));
      // After the last touch: localized within 5 mm, with the right appearance.
      const bool wrong = r.verdict != tacmap::verdict::localized || robot.error(r.position_mm) >= 5;
      failures += t == 7 && (wrong || (r.appearance_probability[1] > 0.5) == bright_raised);
    }
  }
  return failures;
}
