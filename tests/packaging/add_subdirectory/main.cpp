// A consumer that got tacmap through add_subdirectory: one predict/update on the paper's grid.
#include <cmath>
#include <cstdio>
#include <tacmap/tacmap.hpp>

namespace {
struct flat_likelihood {
  struct measurement_type {};
  void log_likelihood(const tacmap::planar_grid<float>&, const measurement_type&,
                      Eigen::ArrayXf& out) const {
    out = Eigen::ArrayXf::LinSpaced(out.size(), -5.0F, 0.0F);
  }
};
}  // namespace

int main() {
  tacmap::bayes_filter filter(tacmap::planar_grid<float>::paper(), tacmap::odometry_gaussian{},
                              flat_likelihood{});
  filter.update({});
  const auto e = filter.estimate();  // the likelihood peaks at the last state
  filter.predict({.dx_mm = 1.0, .dy_mm = -2.0});
  const bool ok =
      std::abs(filter.belief().sum() - 1.0F) < 1e-4F && e.map_index == filter.grid().size() - 1;
  std::printf("tacmap %d: MAP state %ld, %s\n", TACMAP_VERSION, static_cast<long>(e.map_index),
              ok ? "ok" : "WRONG");
  return ok ? 0 : 1;
}
