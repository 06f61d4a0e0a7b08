// tacmap's Python module: the dense SIFT descriptors (C++ include/tacmap/descriptor/dense_sift.hpp)
// on any image, as numpy arrays (rows, cols, dimension).
#include "bindings.hpp"
// (bindings.hpp first: it defines TACMAP_ASSERT for the tacmap headers below.)

#include "tacmap/descriptor/dense_sift.hpp"

namespace tacmap::python {

namespace {

// Descriptors, one per column of `values` (dimension x positions, column-major, so each
// descriptor is contiguous), as a new (rows, cols, dimension) array: the same bytes in order.
py::array_t<float> descriptors(const Eigen::Array<float, Eigen::Dynamic, Eigen::Dynamic>& values,
                               Eigen::Index rows, Eigen::Index cols) {
  py::array_t<float> out({rows, cols, values.rows()});
  if (values.size() > 0)
    std::memcpy(out.mutable_data(), values.data(),
                static_cast<std::size_t>(values.size()) * sizeof(float));
  return out;
}

template <class D>
void bind_dense_sift(py::module_& m, const char* name, const char* doc) {
  const dense_sift_params d = D::default_params();
  const std::string type_name = name;
  py::class_<D>(m, name, doc)
      .def(py::init([](Eigen::Index patch_size, Eigen::Index grid_spacing, double sigma_edge,
                       double alpha, double norm_threshold, double clamp) {
             return D(dense_sift_params{.patch_size = patch_size,
                                        .grid_spacing = grid_spacing,
                                        .sigma_edge = sigma_edge,
                                        .alpha = alpha,
                                        .norm_threshold = norm_threshold,
                                        .clamp = clamp});
           }),
           py::kw_only(), py::arg("patch_size") = d.patch_size,
           py::arg("grid_spacing") = d.grid_spacing, py::arg("sigma_edge") = d.sigma_edge,
           py::arg("alpha") = d.alpha, py::arg("norm_threshold") = d.norm_threshold,
           py::arg("clamp") = d.clamp,
           "patch_size: side (px) of the square patch one descriptor describes (even, a "
           "multiple of the bins per side). grid_spacing: px between the points of sample(). "
           "sigma_edge: the gradient filters' standard deviation, px. alpha: sharpness of the "
           "soft orientation assignment. norm_threshold: descriptors whose L2 norm exceeds it "
           "are normalised (weaker ones, flat areas, kept as they are; inf: never). clamp: "
           "applied to a unit descriptor before renormalising. Raises ValueError naming an "
           "out-of-range value.")
      .def_property_readonly("dimension", &D::dimension,
                             "Elements of one descriptor: bins^2 x 8 orientations.")
      .def_property_readonly("patch_size", &D::patch_size,
                             "Side, px, of the square patch one descriptor describes.")
      .def_property_readonly("grid_spacing", &D::grid_spacing,
                             "Pixels between neighbouring grid points of sample().")
      .def_property_readonly("bin_size", &D::bin_size, "Side of one spatial bin, px.")
      .def_property_readonly("sigma_edge", [](const D& s) { return s.params().sigma_edge; })
      .def_property_readonly("alpha", [](const D& s) { return s.params().alpha; })
      .def_property_readonly("norm_threshold", [](const D& s) { return s.params().norm_threshold; })
      .def_property_readonly("clamp", [](const D& s) { return s.params().clamp; })
      .def(
          "compute",
          [type_name](const D& self, const py::object& img) {
            const image<float> im = to_image(img, type_name + ".compute: image", "(rows, cols)");
            descriptor_field<float> f;
            {
              const py::gil_scoped_release release;
              f = self.compute(im);
            }
            return descriptors(f.values, f.rows, f.cols);
          },
          py::arg("image"),
          "Descriptors of every patch position at stride 1: a float32 array (H - patch_size + "
          "1, W - patch_size + 1, dimension) whose element [r, c] describes the patch with "
          "top-left pixel (r, c) (its centre at (r, c) + (patch_size - 1) / 2). `image`: a 2-D "
          "real array (any range; divided by its maximum first). Raises ValueError when it is "
          "smaller than a patch or not finite.")
      .def(
          "sample",
          [type_name](const D& self, const py::object& img) {
            const image<float> im = to_image(img, type_name + ".sample: image", "(rows, cols)");
            descriptor_samples<float> s;
            {
              const py::gil_scoped_release release;
              s = self.sample(im);
            }
            return descriptors(s.values, s.rows, s.cols);
          },
          py::arg("image"),
          "Descriptors on the regular grid of patches: element [i, j] is the patch with "
          "top-left pixel (i * grid_spacing, j * grid_spacing), for every patch that fits in "
          "the image (each equal to compute(image)[i * spacing, j * spacing]). For the paper's "
          "42 x 18 tactile image, patch 18 and spacing 9: shape (3, 1, 32).")
      .def("__repr__", [type_name](const D& s) {
        return type_name + "(patch_size=" + std::to_string(s.patch_size()) +
               ", grid_spacing=" + std::to_string(s.grid_spacing()) +
               ", dimension=" + std::to_string(s.dimension()) + ")";
      });
}

}  // namespace

void bind_descriptors(py::module_& m) {
  bind_dense_sift<sift_lite>(
      m, "SiftLite",
      "The paper's dense SIFT descriptor (Sec. III-C; C++ tacmap::sift_lite): 2 x 2 spatial bins "
      "x 8 orientations = 32 elements, patch 18 px, grid spacing 9 px (Lazebnik's dense SIFT "
      "with the paper's parameters). compute() on an image gives every patch position; "
      "sample() the regular grid. Stateless: one object may serve several threads (the GIL is "
      "released while it computes).");
  bind_dense_sift<classic_sift>(
      m, "ClassicSift",
      "Dense SIFT with the classic layout (C++ tacmap::classic_sift): 4 x 4 spatial bins x 8 "
      "orientations = 128 elements, patch 16 px (4 px bins, Lazebnik's default), grid spacing "
      "9 px. The default model of LocalizerConfig. Same methods as SiftLite.");
}

}  // namespace tacmap::python
