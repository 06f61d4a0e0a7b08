// tacmap's Python module: the module itself. Each part of the API is bound in its own
// translation unit (core.cpp, localizer.cpp, library.cpp, sim.cpp, io.cpp, descriptor.cpp) so that
// the heavy ones (the localizer's filters, the experiment) compile in parallel.
#include "bindings.hpp"
// (bindings.hpp first: it defines TACMAP_ASSERT for the tacmap headers below.)

#include "tacmap/config.hpp"

// The compiled part of the package tacmap (python/tacmap/__init__.py re-exports it, after checking
// that this interpreter is the one it was built for).
PYBIND11_MODULE(_tacmap, m) {
  namespace tp = tacmap::python;
  m.doc() =
      R"doc(tacmap: localize a tactile sensor's contact on an object by matching tactile images
against a visual map in a recursive Bayes filter (Luo et al., ICRA 2015).

The front door is Localizer: built from a map image (a 2-D numpy array), its scale (mm per
pixel) and the sensor's geometry, it takes one tactile frame per touch with the arm's motion
since the previous touch, and returns the estimate (mm, map frame: x right, y down), how sure
it is, and a verdict ('localized', 'uncertain', 'contradicted', 'rejected_frame')::

    import tacmap
    protocol = tacmap.load_protocol("data/gecko/protocol.txt")
    sim = tacmap.Simulator(protocol.relief_mm(), protocol.mm_per_px)
    loc = tacmap.Localizer(protocol.map, protocol.mm_per_px)
    for k, step in enumerate(protocol.sequences[0]):
        x, y = protocol.locations[step.location]
        r = loc.touch(sim.render(x, y), step.measured_motion if k else None)
        print(r.verdict, r.position_mm, r.probability_within)

LibraryLocalizer does the same over a library of photographs: which object, and where, with
P(none of these) beside the objects.

Also: LocalizerConfig (the filter's configuration; enumerations are strings), Simulator and
ScenarioParams (simulated touches), load_protocol and Experiment (the paper's evaluation on one
map), SessionReader (recorded sessions), SiftLite and ClassicSift (dense descriptors),
read_pgm / load_image (maps).

Arrays in are copied (any real dtype, any strides); wrong dtypes raise TypeError, wrong shapes
ValueError, naming the argument and the expected shape. C++ errors keep their messages:
std::invalid_argument becomes ValueError, std::runtime_error RuntimeError. The GIL is released
during map preparation, touches, experiment runs and descriptor computation.)doc";
  m.attr("__version__") = std::to_string(TACMAP_VERSION_MAJOR) + "." +
                          std::to_string(TACMAP_VERSION_MINOR) + "." +
                          std::to_string(TACMAP_VERSION_PATCH);
  // Order matters: a type must be registered before a signature shows a default value of it.
  tp::bind_core(m);
  tp::bind_config(m);
  tp::bind_localizer(m);
  tp::bind_library(m);
  tp::bind_simulation(m);
  tp::bind_io(m);
  tp::bind_descriptors(m);
}
