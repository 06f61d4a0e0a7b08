// Must NOT compile: a measurement policy without the (x, y, theta) model (localizer.hpp, hook
// P1: `typename P::pose_model` and `p.pose(config, map, pose_grid)`) asked for
// heading_support::localized. The test checks that the diagnostic names the missing hook.
#include "tacmap/localizer.hpp"

namespace {
// A planar-only policy: the shipped descriptor model in the plane, no pose model.
struct planar_only {
  using planar_model = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  planar_model planar(const tacmap::localizer_config&, const tacmap::image<float>& map,
                      tacmap::pixel_size window) const {
    return planar_model({}, map, window);
  }
};
}  // namespace

int main() {
  const tacmap::image<float> map = tacmap::image<float>::Zero(60, 60);
  tacmap::basic_localizer<planar_only, tacmap::heading_support::localized> loc(map, 3.4 / 3.0);
  return loc.touches() > 0 ? 1 : 0;
}
