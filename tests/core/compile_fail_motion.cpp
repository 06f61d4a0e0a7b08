// Must NOT compile: `not_a_motion_model` has no control_type and no predict(). The test checks
// that the compiler's diagnostic names the unmet `motion_model` concept.
#include "tacmap/tacmap.hpp"

namespace {
struct not_a_motion_model {};
struct uninformative {
  struct measurement_type {};
  template <class G>
  void log_likelihood(const G&, const measurement_type&, tacmap::belief_array<G>& out) const {
    out.setZero();
  }
};
}  // namespace

int main() {
  tacmap::bayes_filter<tacmap::planar_grid<float>, not_a_motion_model, uninformative> filter(
      tacmap::planar_grid<float>::paper(), not_a_motion_model{}, uninformative{});
  return static_cast<int>(filter.belief().size());
}
