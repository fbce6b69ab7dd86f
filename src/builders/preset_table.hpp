// SPDX-License-Identifier: MIT
// The presets: each named builder is a point of the generic framework (search spaces, pre-splitting,
// default C_o, unsplitting rule, spatial gate). One table serves the builder and the name registry.
#pragma once

#include <cstdint>

#include "spacebvh/build.hpp"

namespace spacebvh::builders {

enum class Presplit { none, early_split_clipping, edge_volume_heuristic };

struct BuilderPreset {
    Preset preset;
    const char* name;
    uint32_t search_spaces;
    Presplit presplit;
    float overlap_penalty;     // default C_o
    bool allow_unsplitting;    // kdbvh keeps children disjoint, so never unsplits
    float spatial_gate_alpha;  // try spatial splits only above this overlap area / SA(root)
    const char* description;
};

inline constexpr float kInf = kInfinity;
// In Preset order.
inline constexpr BuilderPreset kPresets[] = {
    {Preset::cbvh, "cbvh", uint32_t(SearchSpace::object_sweep), Presplit::none, 0.0f, false, 0.0f,
     "classical BVH: exact SAH sweep over centroid-sorted references on all three axes (Popov et al.'s CBVH)"},
    {Preset::binned, "binned", uint32_t(SearchSpace::object_binned), Presplit::none, 0.0f, false, 0.0f,
     "binned object SAH (Wald 2007), --bins bins per axis; the fast classical builder"},
    {Preset::kdbvh, "kdbvh", uint32_t(SearchSpace::spatial_binned), Presplit::none, kInf, false, 0.0f,
     "spatial (kd) search space only: planes on --spatial-bins bins, straddlers clipped; disjoint children (KDBVH)"},
    {Preset::spatial, "spatial", SearchSpace::object_sweep | SearchSpace::spatial_binned, Presplit::none, 1.0f, true,
     1e-4f,
     "object sweep + spatial planes chosen by the overlap-penalised SAH (--co), with unsplitting, spatial tried when "
     "object overlap >= 1e-4 SA(root): the practical builder (fast variant: --search binned,spatial)"},
    {Preset::sbvh, "sbvh", SearchSpace::object_sweep | SearchSpace::spatial_binned, Presplit::none, 0.0f, true, 1e-5f,
     "SBVH (Stich et al. 2009): object sweep + binned spatial with unsplitting, spatial tried when object overlap >= "
     "1e-5 SA(root)"},
    {Preset::esc, "esc", uint32_t(SearchSpace::object_sweep), Presplit::early_split_clipping, 0.0f, false, 0.0f,
     "early split clipping (Ernst & Greiner 2007) pre-splits references within the budget, then the cbvh search"},
    {Preset::evh, "evh", uint32_t(SearchSpace::object_sweep), Presplit::edge_volume_heuristic, 0.0f, false, 0.0f,
     "edge volume heuristic (Dammertz & Keller 2008, t = 14) pre-splits triangles within the budget, then the cbvh "
     "search"},
    {Preset::full, "full", SearchSpace::object_sweep | SearchSpace::spatial_binned | SearchSpace::grid, Presplit::none,
     kInf, false, 0.0f,
     "Popov et al.'s Full search: grid (--grid-resolution, --grid-max) + kd planes + object sweep, C_o = inf"},
};

inline const BuilderPreset& preset_of(Preset preset) { return kPresets[uint32_t(preset)]; }
inline constexpr size_t kPresetCount = sizeof(kPresets) / sizeof(kPresets[0]);

}  // namespace spacebvh::builders
