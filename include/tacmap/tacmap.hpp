// tacmap: umbrella header — the core library (never the device adapters, which need their own
// dependencies: include tacmap/devices/... explicitly).
#pragma once

#include "tacmap/angle.hpp"
#include "tacmap/config.hpp"
#include "tacmap/descriptor/concept.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/appearance_likelihood.hpp"
#include "tacmap/measurement/concept.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/ncc_likelihood.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/concept.hpp"
#include "tacmap/motion/latent_motion.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
#include "tacmap/tactile/frame.hpp"
#include "tacmap/tactile/preprocess.hpp"
