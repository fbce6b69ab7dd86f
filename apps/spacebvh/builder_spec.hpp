// SPDX-License-Identifier: MIT
// The row syntax of `compare --builders`: a builder name with settings of its own.
#pragma once

#include <string>

#include "cli_common.hpp"

namespace spacebvh::cli {

// "NAME" or
// "NAME@co=0.3;ct=3;ci=1;leaf=8;block=4;budget=1.5;bins=64;spatialbins=64;gate=1e-5;search=object+grid;grid=2;gridmax=8;lookahead=2;top=0.25;optimize=16":
// a builder with some options of its own, each key named after its build flag (bins: --bins, the
// binned object search space's; spatialbins: --spatial-bins). "NAME+opt" is NAME with the
// reinsertion optimisation; the label shows "+opt" whenever the tree is optimised ("binned+opt@budget=1.5").
struct BuilderSpec {
    std::string label;
    TreeRecipe options;
    bool saved_tree = false;  // --tree: loaded, not built (options unused)
};

// Throws Error naming the row and the setting for an unknown key or a value out of range.
BuilderSpec parse_builder_spec(const std::string& text, const BuildCliOptions& defaults);

}  // namespace spacebvh::cli
