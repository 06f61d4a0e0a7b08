// The four policy concepts, tested both ways: shipped types model them, and near-miss types
// (each missing exactly one requirement) do not.
#include <doctest/doctest.h>

#include "tacmap/tacmap.hpp"

namespace test_concepts {

namespace {

using tacmap::belief_array;
using tacmap::descriptor_field;
using tacmap::prediction_report;

// ---- state_grid -------------------------------------------------------------------------
struct corridor {  // the minimal conforming type from grid/concept.hpp
  using scalar_type = double;
  static constexpr int dimension = 1;
  using state_type = Eigen::Matrix<double, 1, 1>;
  Eigen::Index rows() const { return 1; }
  Eigen::Index cols() const { return 10; }
  Eigen::Index size() const { return 10; }
  state_type state_mm(Eigen::Index i) const { return state_type(5.0 * static_cast<double>(i)); }
};
struct grid_int_scalar : corridor {
  using scalar_type = int;
};
struct grid_no_size {
  using scalar_type = double;
  static constexpr int dimension = 1;
  using state_type = Eigen::Matrix<double, 1, 1>;
  Eigen::Index rows() const { return 1; }
  Eigen::Index cols() const { return 10; }
  state_type state_mm(Eigen::Index) const { return state_type(0.0); }
};
struct grid_wrong_state_type : corridor {
  using state_type = Eigen::Matrix<float, 1, 1>;
};
struct grid_no_dimension {
  using scalar_type = double;
  using state_type = Eigen::Matrix<double, 1, 1>;
  Eigen::Index rows() const { return 1; }
  Eigen::Index cols() const { return 10; }
  Eigen::Index size() const { return 10; }
  state_type state_mm(Eigen::Index) const { return state_type(0.0); }
};
struct grid_int_rows : corridor {
  int rows() const { return 1; }
};

static_assert(tacmap::state_grid<corridor>);
static_assert(tacmap::state_grid<tacmap::planar_grid<float>>);
static_assert(tacmap::state_grid<tacmap::planar_grid<double>>);
static_assert(!tacmap::state_grid<grid_int_scalar>);
static_assert(!tacmap::state_grid<grid_no_size>);
static_assert(!tacmap::state_grid<grid_wrong_state_type>);
static_assert(!tacmap::state_grid<grid_no_dimension>);
static_assert(!tacmap::state_grid<grid_int_rows>);
static_assert(!tacmap::state_grid<int>);

// ---- motion_model -----------------------------------------------------------------------
struct stay_put {  // the minimal conforming type from motion/concept.hpp
  struct control_type {};
  template <class G>
  prediction_report predict(const G&, const belief_array<G>& in, belief_array<G>& out,
                            const control_type&) const {
    out = in;
    return {};
  }
};
struct motion_no_control {
  template <class G>
  prediction_report predict(const G&, const belief_array<G>&, belief_array<G>&, int) const {
    return {};
  }
};
struct motion_returns_void {
  struct control_type {};
  template <class G>
  void predict(const G&, const belief_array<G>&, belief_array<G>&, const control_type&) const {}
};
struct motion_mutating {  // predict is not const: a configured value must not change per call
  struct control_type {};
  template <class G>
  prediction_report predict(const G&, const belief_array<G>&, belief_array<G>&,
                            const control_type&) {
    return {};
  }
};

using paper_grid = tacmap::planar_grid<float>;
static_assert(tacmap::motion_model<stay_put, corridor>);
static_assert(tacmap::motion_model<tacmap::odometry_gaussian, paper_grid>);
static_assert(tacmap::motion_model<tacmap::odometry_gaussian, tacmap::planar_grid<double>>);
static_assert(
    !tacmap::motion_model<tacmap::odometry_gaussian, corridor>);  // needs a 2-D metric grid
static_assert(!tacmap::motion_model<motion_no_control, corridor>);
static_assert(!tacmap::motion_model<motion_returns_void, corridor>);
static_assert(!tacmap::motion_model<motion_mutating, corridor>);

// ---- measurement_model ------------------------------------------------------------------
struct uninformative {  // the minimal conforming type from measurement/concept.hpp
  struct measurement_type {};
  template <class G>
  void log_likelihood(const G&, const measurement_type&, belief_array<G>& out) const {
    out.setZero();
  }
};
struct measurement_no_type {
  template <class G>
  void log_likelihood(const G&, int, belief_array<G>& out) const {
    out.setZero();
  }
};
struct measurement_returns_array {  // must write into the filter's buffer, not allocate
  struct measurement_type {};
  template <class G>
  belief_array<G> log_likelihood(const G& g, const measurement_type&, belief_array<G>&) const {
    return belief_array<G>::Zero(g.size());
  }
};
struct measurement_wrong_scalar {  // writes a double array into a float belief grid
  struct measurement_type {};
  void log_likelihood(const paper_grid&, const measurement_type&, Eigen::ArrayXd&) const {}
};

static_assert(tacmap::measurement_model<uninformative, corridor>);
static_assert(tacmap::measurement_model<uninformative, paper_grid>);
static_assert(!tacmap::measurement_model<measurement_no_type, corridor>);
static_assert(!tacmap::measurement_model<measurement_returns_array, corridor>);
static_assert(!tacmap::measurement_model<measurement_wrong_scalar, paper_grid>);

// ---- descriptor -------------------------------------------------------------------------
struct mean_intensity {  // the minimal conforming type from descriptor/concept.hpp
  using scalar_type = float;
  using column = Eigen::Ref<const Eigen::Array<float, Eigen::Dynamic, 1>>;
  Eigen::Index dimension() const { return 1; }
  Eigen::Index patch_size() const { return 3; }
  descriptor_field<float> compute(const tacmap::image<float>& img) const {
    descriptor_field<float> f;
    f.rows = img.rows() - 2;
    f.cols = img.cols() - 2;
    f.values.resize(1, f.rows * f.cols);
    for (Eigen::Index r = 0; r < f.rows; ++r)
      for (Eigen::Index c = 0; c < f.cols; ++c)
        f.values(0, r * f.cols + c) = img.block(r, c, 3, 3).mean();
    return f;
  }
  float distance(column a, column b) const { return std::abs(a(0) - b(0)); }
};
struct descriptor_no_distance {
  using scalar_type = float;
  Eigen::Index dimension() const { return 1; }
  Eigen::Index patch_size() const { return 3; }
  descriptor_field<float> compute(const tacmap::image<float>&) const { return {}; }
};
struct descriptor_int_dimension : mean_intensity {
  int dimension() const { return 1; }
};
struct descriptor_wrong_field : mean_intensity {
  descriptor_field<double> compute(const tacmap::image<float>&) const { return {}; }
};

static_assert(tacmap::descriptor<mean_intensity>);
static_assert(!tacmap::descriptor<descriptor_no_distance>);
static_assert(!tacmap::descriptor<descriptor_int_dimension>);
static_assert(!tacmap::descriptor<descriptor_wrong_field>);

}  // namespace
}  // namespace test_concepts

// Whole-template instantiation: every member of the filter compiles for float and double. (At
// global scope: an explicit instantiation belongs to a namespace enclosing tacmap's.)
template class tacmap::bayes_filter<tacmap::planar_grid<float>, tacmap::odometry_gaussian,
                                    test_concepts::uninformative>;
template class tacmap::bayes_filter<tacmap::planar_grid<double>, tacmap::odometry_gaussian,
                                    test_concepts::uninformative>;
template class tacmap::bayes_filter<test_concepts::corridor, test_concepts::stay_put,
                                    test_concepts::uninformative>;

namespace test_concepts {

TEST_CASE("the minimal conforming descriptor from the concept's documentation works") {
  tacmap::image<float> img = tacmap::image<float>::Zero(5, 6);
  img(2, 3) = 9.0F;
  const mean_intensity d;
  const auto field = d.compute(img);
  CHECK(field.rows == 3);
  CHECK(field.cols == 4);
  CHECK(field.at(1, 2)(0) == doctest::Approx(1.0));  // the 3 x 3 patch at (1, 2) holds the 9
  CHECK(d.distance(field.at(0, 0), field.at(1, 2)) == doctest::Approx(1.0));
}

TEST_CASE("a filter over the minimal grid and models runs and stays normalised") {
  tacmap::bayes_filter<corridor, stay_put, uninformative> filter(corridor{}, stay_put{},
                                                                 uninformative{});
  filter.predict({});
  filter.update({});
  CHECK(filter.belief().sum() == doctest::Approx(1.0));
  CHECK(filter.estimate().mean_mm(0) == doctest::Approx(22.5));  // uniform over 0, 5, ..., 45
}

}  // namespace test_concepts
