// Compile-time measurement (README, "Compile time"): a translation unit that runs the front
// door, tacmap::localizer (its planar filter: latent appearance, robust motion, classic SIFT).
#include "tacmap/localizer.hpp"
int main() {
  tacmap::image<float> map = tacmap::image<float>::Zero(120, 120);
  tacmap::localizer loc(map, 3.4 / 3.0);
  tacmap::tactile_frame f;
  const auto r = loc.touch(f);
  return r.position_mm(0) > 0 ? 0 : 1;
}
