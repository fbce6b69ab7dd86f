// SPDX-License-Identifier: MIT
// The row syntax of `compare --builders`: a builder name with settings of its own.
#pragma once

#include <string>

#include "cli_common.hpp"

namespace spacebvh::cli {

// "NAME" or "NAME@key=value;key=value": a builder with some settings of its own, each key the row key
// of a build setting (spacebvh/settings.hpp: co, budget, bins, spatialbins, search=object+grid, ...),
// on top of the command's build options. "NAME+opt" is NAME with the reinsertion optimisation; the
// label shows "+opt" whenever the tree is optimised ("binned+opt@budget=1.5").
struct BuilderSpec {
    std::string label;
    TreeRecipe options;
    bool saved_tree = false;  // --tree: loaded, not built (options unused)
};

// Throws Error naming the row and the setting for an unknown key or a value out of range.
BuilderSpec parse_builder_spec(const std::string& text, const BuildCliOptions& defaults);

}  // namespace spacebvh::cli
