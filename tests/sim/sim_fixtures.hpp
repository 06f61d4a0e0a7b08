// Maps and simulator settings the simulator's tests share.
#pragma once

#include "tacmap/image.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace tacmap_test {

/// The paper's map scale: the sensor's 3.4 mm pitch over 3 px.
inline constexpr double paper_mm_per_px = 3.4 / 3.0;

/// A 120 x 120 px relief raised 4 mm everywhere: a press indents every taxel alike.
inline tacmap::image<float> flat_relief() { return tacmap::image<float>::Constant(120, 120, 4.0F); }

/// A 120 x 120 px relief raised 4 mm on its right half only.
inline tacmap::image<float> step_relief() {
  tacmap::image<float> r = tacmap::image<float>::Zero(120, 120);
  r.block(0, 60, 120, 60).setConstant(4.0F);
  return r;
}

/// `p` without read-out noise or gain variation: counts follow the relief exactly.
inline tacmap::simulator_params quiet(tacmap::simulator_params p = {}) {
  p.noise_counts = 0.0;
  p.gain_variation = 0.0;
  return p;
}

}  // namespace tacmap_test
