// The conformance suite users run on their own descriptors, run here on a test descriptor
// through both distance paths (the shipped descriptors invoke it in tests/descriptor/).
#include <doctest/doctest.h>

#include "raw_patch_descriptor.hpp"
#include "tacmap/testing/conformance.hpp"

namespace test_conformance {

TEST_CASE_TEMPLATE_INVOKE(tacmap_descriptor_conformance, tacmap_test::raw_patch,
                          tacmap_test::raw_patch_generic);

}  // namespace test_conformance
