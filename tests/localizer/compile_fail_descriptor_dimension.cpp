// Must NOT compile: `int_dimension` is a descriptor in all but one requirement, its
// `dimension()` returns `int` where the `descriptor` concept asks for `Eigen::Index`
// (descriptor/concept.hpp, requirement 2). The test checks that the diagnostic names the unmet
// concept and the hook, `d.dimension()`, rather than failing deep inside the filter.
#include <cmath>

#include "tacmap/localizer.hpp"

namespace {
struct int_dimension {
  using scalar_type = float;
  using column = Eigen::Ref<const Eigen::ArrayXf>;
  int dimension() const { return 1; }  // the mistake: Eigen::Index expected
  Eigen::Index patch_size() const { return 3; }
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    tacmap::descriptor_field<float> f{{}, img.rows() - 2, img.cols() - 2};
    f.values.setZero(1, f.rows * f.cols);
    return f;
  }
  float distance(column a, column b) const { return std::abs(a(0) - b(0)); }
};
}  // namespace

int main() {
  const tacmap::image<float> map = tacmap::image<float>::Zero(60, 60);
  tacmap::descriptor_localizer<int_dimension> loc(map, 3.4 / 3.0);
  return loc.touches() > 0 ? 1 : 0;
}
