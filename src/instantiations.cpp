// tacmap::precompiled: the common models, compiled once (the list: tacmap/precompiled.hpp).
#define TACMAP_PRECOMPILED_DEFINE 1
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
