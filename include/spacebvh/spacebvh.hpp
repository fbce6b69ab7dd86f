// SPDX-License-Identifier: MIT
// spacebvh: BVHs by space subdivision (Popov, Georgiev, Dimov, Slusallek 2009) with exact traversal.
// The core API: a mesh view, a build configuration (or a quality level), the tree, and a tracer.
// Header-only: it includes the core API headers.
#pragma once

#include "spacebvh/build.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/cost_model.hpp"
#include "spacebvh/distance.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/float64.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/mesh.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/settings.hpp"
#include "spacebvh/trace.hpp"
