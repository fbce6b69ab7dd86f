// SPDX-License-Identifier: MIT
// Building a BVH: a quality level for most users, and the full configuration of the generic framework
// of Popov et al. 2009 ("The Generic Algorithm": a set of search spaces plus the cost model with its
// overlap penalty) for research use.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/cost_model.hpp"
#include "spacebvh/mesh.hpp"

namespace spacebvh {

// The search spaces a node's split is chosen from (any union).
enum class SearchSpace : uint32_t {
    object_sweep = 1u << 0,    // exact SAH sweep over centroid-sorted references, all axes (CBVH)
    object_binned = 1u << 1,   // binned object SAH (Wald 2007)
    spatial_binned = 1u << 2,  // kd planes on B bins per axis, straddlers clipped (Stich et al. 2009)
    spatial_sweep = 1u << 3,   // kd planes at every reference bound event, exact child boxes (Popov et al. 2009)
    grid = 1u << 4,            // child boxes on a G^3 grid over the node, exact counts (Popov et al. 2009)
};
constexpr uint32_t operator|(SearchSpace a, SearchSpace b) { return uint32_t(a) | uint32_t(b); }
constexpr uint32_t operator|(uint32_t a, SearchSpace b) { return a | uint32_t(b); }

// The named points of the framework (docs/design.md describes each).
enum class Preset : uint32_t {
    cbvh,     // exact object SAH sweep (the paper's CBVH)
    binned,   // binned object SAH: the fast classical builder
    kdbvh,    // kd planes only, disjoint children (KDBVH)
    spatial,  // object sweep + kd planes under the overlap-penalised SAH: the tree-quality builder
    sbvh,     // Stich et al. 2009
    esc,      // early split clipping pre-splitting, then the cbvh search
    evh,      // edge volume heuristic pre-splitting, then the cbvh search
    full,     // the paper's Full search: grid + kd planes + object sweep, C_o = inf
};

// What most users pick. fast: the binned object SAH (the quickest build, for dynamic scenes);
// balanced: the spatial preset with binned object and spatial search (space subdivision at close to a
// classical build's time); high: the spatial preset (exact object sweep and kd planes), then
// reinsertion optimisation (the lowest-cost trees, for static scenes traced many times).
enum class Quality { fast, balanced, high };

// The most recursive cost evaluation accepts (its cost grows about linearly with the depth).
inline constexpr uint32_t kMaxLookaheadDepth = 8;
// The smallest LookaheadConfig::top_share: below it the nodes priced by whole subtrees, and the
// build time, grow without bound for little gain.
inline constexpr float kMinLookaheadTopShare = 0.01f;
// Reinsertion optimisation: the most iterations accepted, and the effort of the CLI's --optimize.
inline constexpr uint32_t kMaxReinsertionIterations = 1000;
inline constexpr uint32_t kDefaultReinsertionIterations = 16;

struct LimitConfig {
    uint32_t max_leaf_size = 8;  // a node with more references is always split (1..2^20)
    uint32_t max_depth = 64;     // nodes at this depth become leaves whatever their size (1..1024)
    // Spatial splits may grow the references to at most this multiple of the triangle count (1..4);
    // the budget is shared deterministically among subtrees and always honoured.
    float reference_budget = 1.3f;
    // build() refuses, before it starts, a mesh whose estimated peak memory (estimate_build_memory in
    // spacebvh/memory_estimate.hpp) exceeds this many bytes; 0 = the memory available when it starts
    // (MemAvailable; no check where that is unknown).
    uint64_t memory_limit_bytes = 0;
};

struct ObjectConfig {
    uint32_t bins = 32;  // bins per axis of the binned object search space (2..256)
};

struct SpatialConfig {
    uint32_t bins = 32;       // bins per axis of the binned spatial search space (2..1024)
    bool unsplitting = true;  // reference unsplitting (Stich et al. 2009) in spatial splits
    // Spatial planes are tried at a node only when the best object split's children overlap by at
    // least this fraction of SA(root) (Stich et al.'s alpha; 0 = at every node, up to 1). Negative:
    // the preset's own (spatial 1e-4, sbvh 1e-5 as NVIDIA's builder, kdbvh and full 0).
    float gate_alpha = -1.0f;
    // Kd planes at every reference bound event with exact child boxes (SearchSpace::spatial_sweep)
    // instead of on `bins` bins, for presets with spatial search.
    bool exact_sweep = false;
    // Exact sweep: positions sampled inside the intervals next to the best event planes (0..64).
    uint32_t sweep_interior_samples = 0;
};

struct GridConfig {
    // A node of N references gets G = ceil(resolution * N^(1/6)) cells per axis (the slides'
    // G = R N^(1/6)), at least 2 and at most max_cells (work ~20 G^6 per node).
    float resolution = 1.0f;  // R, in (0, 64]
    uint32_t max_cells = 8;   // 2..16
    // Clip a reference that fits in neither child into both (for child boxes that cover the node,
    // within the reference budget). Off: such configurations are infeasible.
    bool splitting = true;
};

// Recursive cost evaluation (Popov et al. 2009, "use recursive cost evaluation").
struct LookaheadConfig {
    // Choose each node's split among the search spaces' best candidates by the SAH of the subtree
    // built greedily this many levels below it (0..kMaxLookaheadDepth; 0 = the greedy choice).
    uint32_t depth = 0;
    uint32_t candidates = 2;  // the cheapest splits per axis and search space compared (1..16)
    // Nodes holding at least this share of the root's references price each search space's cheapest
    // split (and the leaf) by the SAH of the whole greedy subtree it leads to: the greedy step prices
    // children as leaves, furthest from the truth at the top, where most of the SAH sits.
    // 0 = off; else in [kMinLookaheadTopShare, 1]. No effect for presets with one search space.
    float top_share = 0.0f;
};

// Subtree reinsertion after the build (Bittner et al. 2013): at most this many iterations, each
// moving a batch of subtrees to places that lower the tree SAH; leaves stay as built.
struct ReinsertionConfig {
    uint32_t iterations = 0;  // 0 = off; at most kMaxReinsertionIterations
};

// Termination-aware split choice: where enough sample rays reach a node, its split is chosen among the
// search spaces' cheapest candidates by a cost that prices each child by the share of the node's
// sample segments that meet it (Bittner & Havran 2009, "RDH"), each segment ending where its ray
// stops (its first hit), so children behind the surfaces rays hit cost nothing; blended with the
// cost model's split cost by w = n / (n + shrinkage) for a node met by n segments. The segments are
// data: the builder never traces (spacebvh::tools::termination_segments makes them).
struct TerminationConfig {
    std::vector<Ray> segments;  // from tmin to tmax (where the ray stops); empty = off
    float shrinkage = 32.0f;    // n_0 of the blend, >= 0
    uint32_t min_rays = 8;      // nodes met by fewer segments keep the cost model's choice (>= 1)
    uint32_t candidates = 4;    // the cheapest splits per axis and search space compared (1..16)
    bool split_choice = true;   // off: the cost model chooses every split; the segments serve the optimiser only
    // After the build (and any SAH reinsertion), subtree reinsertion that prices each inner node by the
    // number of segments meeting its box - the sample's visits, each ray stopping at its first hit -
    // plus `reinsertion_prior` pseudo-segments spread by area (the SAH's rays), where the SAH optimiser
    // prices it by area alone: at most this many iterations (0 = off, at most kMaxReinsertionIterations).
    uint32_t reinsertion_iterations = 0;
    float reinsertion_prior = 64.0f;  // >= 0, finite
};

struct BuildHooks {
    // Called now and then with the fraction of the work done (0..1), from any thread. May be empty.
    std::function<void(double)> progress;
    // Polled between nodes, from any thread; once it reads true the build throws Cancelled. May be null.
    const std::atomic<bool>* cancel = nullptr;
};

struct BuildConfig {
    Preset preset = Preset::binned;
    // The search spaces combined at every node (a union of SearchSpace bits); 0 = the preset's own.
    // The rest of the preset (pre-splitting, unsplitting rule, spatial gate) stays.
    uint32_t search_spaces = 0;
    CostModel cost;  // C_T, C_I, C_o, leaf block; for_preset sets the preset's own C_o
    LimitConfig limits;
    ObjectConfig object;
    SpatialConfig spatial;
    GridConfig grid;
    LookaheadConfig lookahead;
    ReinsertionConfig reinsertion;
    TerminationConfig termination;
    BuildHooks hooks;

    // The preset with its default overlap penalty C_o.
    static BuildConfig for_preset(Preset preset);
    static BuildConfig for_quality(Quality quality);
    // Throws Error naming the setting for any value out of its range.
    void validate() const;
};

const char* to_string(Preset preset);  // "spatial"

// Builds a BVH over the mesh with the calling thread's oneTBB arena (limit threads with
// tbb::global_control or a tbb::task_arena). Deterministic: the same triangles and configuration give
// the same tree, whatever the thread count. Throws Error for an empty or malformed mesh or an invalid
// configuration, Cancelled when hooks.cancel is set. With reinsertion.iterations > 0 the tree is then
// optimised (optimize) and its builder label gets "+opt".
[[nodiscard]] Bvh build(const MeshView& mesh, const BuildConfig& config);
[[nodiscard]] inline Bvh build(const MeshView& mesh, Quality quality = Quality::balanced) {
    return build(mesh, BuildConfig::for_quality(quality));
}

// Reinsertion optimisation of any binary tree (ours or imported): moves subtrees to where they lower
// the tree SAH under bvh.cost (the plain SAH: C_o only prices split choices), never raising it;
// leaves, their boxes and triangles stay; the depth stays within max_depth (or the tree's own depth
// if deeper). Deterministic for any thread count; throws Cancelled (tree unchanged) when cancelled.
// Appends "+opt" to bvh.builder when it ran (iterations > 0).
void optimize(Bvh& bvh, const ReinsertionConfig& reinsertion, uint32_t max_depth = 64, const BuildHooks& hooks = {});

// A tree's boxes recomputed bottom-up after its triangles moved (same triangles, same count): the
// shape, leaves and references stay; a leaf's box becomes the union of its triangles' whole boxes (a
// reference that spatial splits clipped gets its triangle's whole box back, so such leaves overlap
// more than the build chose). Nodes must be in depth-first order (children after their parent), as
// every builder and tree file gives them. Throws Error when a leaf names a triangle out of range.
void refit_boxes(Bvh& bvh, std::span<const Triangle> triangles);

// The termination-aware reinsertion (TerminationConfig::reinsertion_iterations, priced by its
// segments) of any binary tree, as build() runs it after the build; segments may come from tracing
// this very tree. Never raises the sampled price; same guarantees as optimize. Appends "+topt" to
// bvh.builder when it ran (iterations > 0 and segments given).
void optimize_for_termination(Bvh& bvh, const TerminationConfig& termination, uint32_t max_depth = 64,
                              const BuildHooks& hooks = {});

}  // namespace spacebvh
