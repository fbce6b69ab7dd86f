// SPDX-License-Identifier: MIT
// The names of builders, search spaces and kernels, for the command line and Python. C++ callers
// use the typed Preset, BuildConfig, Kernel and TracerConfig instead.
// Implemented beside what the names name: src/builders/builder_names.cpp and src/trace/kernel_names.cpp.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh {

// "cbvh", "binned", "kdbvh", "spatial", "sbvh", "esc", "evh", "full", in Preset order.
std::vector<std::string> builder_names();
// The preset of that name. Throws Error for an unknown name, listing the known ones.
Preset parse_preset(const std::string& name);
// BuildConfig::for_preset(parse_preset(name)).
BuildConfig config_for(const std::string& builder);
// One line each, for --help.
std::string describe_builder(const std::string& name);

// Embree's own binary trees, offered beside our presets under these names ("embree-medium",
// "embree-high"); the tools library builds them (spacebvh/tools/embree_builder.hpp), the core knows
// their names so that every front end reads a builder name the same way (spacebvh/recipe.hpp).
const std::vector<std::string>& embree_tree_names();
bool is_embree_tree(const std::string& builder);

// "fast", "balanced", "high", in Quality order.
std::vector<std::string> quality_names();
const char* to_string(Quality quality);
// Throws Error for an unknown name, listing the known ones.
Quality parse_quality(const std::string& name);

// "object,binned,spatial,grid" (names separated by ',' or '+'; any union) -> SearchSpace bits:
// object = object_sweep, binned = object_binned, spatial = spatial_binned, spatial-sweep =
// spatial_sweep, grid = grid. Throws Error naming an unknown name, or for an empty list.
uint32_t parse_search_spaces(const std::string& names);
// The inverse: "object+spatial+grid".
std::string search_space_names(uint32_t search_spaces);

// Kernel names: "auto"; "binary"; "bvh4", "bvh8" (widest node test) or "bvh4-NODETEST" /
// "bvh8-NODETEST" with NODETEST one of scalar, sse, avx2, avx512; "packet8", "packet16" (also with
// "-NODETEST"); bvh4 and bvh8 kernels (not -scalar) also "NAME+moller" (the moller leaf test); wide
// and packet kernels also "NAME@area" (Embree's collapse) or "NAME@sah".
// Throws Error for an unknown name, listing the kernels of this CPU.
TracerConfig parse_kernel(const std::string& name);
// The names parse_kernel accepts on this CPU (without the @ suffixes).
std::vector<std::string> kernel_names();
// Tracer(mesh, bvh, parse_kernel(name)), on the heap.
std::unique_ptr<Tracer> make_tracer(const std::string& kernel, const MeshView& mesh, const Bvh& bvh);

}  // namespace spacebvh
