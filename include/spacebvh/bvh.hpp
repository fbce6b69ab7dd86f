// The binary BVH that every builder produces, and the options that choose a builder.
//
// Builders are points in the generic framework of Popov et al. 2009 ("The Generic Algorithm"): a set
// of search spaces plus the cost model (with its overlap penalty). Each named builder is a preset.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "spacebvh/cost_model.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/scene.hpp"

namespace spacebvh {

struct BvhNode {
    AABB bounds;
    // Inner node (reference_count == 0): children are nodes[first] and nodes[first + 1].
    // Leaf (reference_count > 0): triangles are primitives[first .. first + reference_count).
    uint32_t first = 0;
    uint32_t reference_count = 0;

    bool is_leaf() const { return reference_count > 0; }
};

struct Bvh {
    std::vector<BvhNode> nodes;       // nodes[0] is the root; depth-first order, left child first
    std::vector<uint32_t> primitives;  // triangle ids of the leaves, leaf by leaf
    std::string builder;               // the preset that built it
    CostModel cost;                    // the cost model it was built with

    const BvhNode& root() const { return nodes.front(); }
    bool empty() const { return nodes.empty(); }
};

// The search spaces a node's split is chosen from (any union).
enum class SearchSpace : uint32_t {
    object_sweep = 1u << 0,   // exact SAH sweep over centroid-sorted references, all axes (CBVH)
    object_binned = 1u << 1,  // binned object SAH (Wald 2007)
    spatial_binned = 1u << 2, // kd planes on B bins per axis, straddlers clipped (Stich et al. 2009)
    spatial_sweep = 1u << 3,  // kd planes at every reference bound event, exact child boxes (Popov et al. 2009)
    grid = 1u << 4,           // child boxes on a G^3 grid over the node, exact counts (Popov et al. 2009)
};
constexpr uint32_t operator|(SearchSpace a, SearchSpace b) { return uint32_t(a) | uint32_t(b); }
constexpr uint32_t operator|(uint32_t a, SearchSpace b) { return a | uint32_t(b); }

// "object,binned,spatial,grid" (names separated by ',' or '+'; any union) -> SearchSpace bits:
// object = object_sweep, binned = object_binned, spatial = spatial_binned, spatial-sweep =
// spatial_sweep, grid = grid. Throws Error
// naming an unknown name, or for an empty list.
uint32_t parse_search_spaces(const std::string& names);
// The inverse: "object+spatial+grid".
std::string search_space_names(uint32_t search_spaces);

// The deepest recursive cost evaluation BuildOptions accepts (the cost grows about linearly with it).
inline constexpr uint32_t kMaxLookaheadDepth = 8;
// The smallest BuildOptions::lookahead_top_share: below it the nodes priced by whole subtrees, and the
// build time, grow without bound for little gain.
inline constexpr float kMinLookaheadTopShare = 0.01f;
// Reinsertion optimisation: the most iterations BuildOptions accepts, and the effort of --optimize.
inline constexpr uint32_t kMaxReinsertionIterations = 1000;
inline constexpr uint32_t kDefaultReinsertionIterations = 16;

struct BuildOptions {
    std::string builder = "binned";  // a name from builder_names()
    // The search spaces combined at every node (a union of SearchSpace bits); 0 = the preset's own.
    // The rest of the preset (its default C_o, pre-splitting, unsplitting rule) stays.
    uint32_t search_spaces = 0;
    // C_T, C_I, C_o. Use options_for(builder) to start from the preset's default C_o.
    CostModel cost;
    uint32_t max_leaf_size = 8;  // a node with more references is always split
    uint32_t max_depth = 64;     // nodes at this depth become leaves whatever their size
    uint32_t object_bins = 32;   // bins per axis of the binned object search space (2..256)
    uint32_t spatial_bins = 32;  // bins per axis of the binned spatial search space (2..1024)
    // Spatial splits may grow the references to at most this multiple of the triangle count; the
    // budget is shared deterministically among subtrees and always honoured.
    float reference_budget = 1.3f;
    bool unsplitting = true;  // reference unsplitting (Stich et al. 2009) in spatial splits
    // Spatial planes are tried at a node only when the best object split's children overlap by at
    // least this fraction of SA(root) (Stich et al.'s alpha; 0 = at every node). Negative: the
    // preset's own: spatial 1e-4 (measured: same speed as 0, 1.5-2.5x faster builds), sbvh 1e-5 (as
    // NVIDIA's builder), kdbvh 0 (no object split to gate on) and full 0 (the paper's Full search).
    float spatial_gate_alpha = -1.0f;
    // Grid search space: a node of N references gets G = ceil(grid_resolution * N^(1/6)) cells per axis
    // (the slides' G = R N^(1/6)), at least 2 and at most grid_max_cells (work ~20 G^6 per node).
    float grid_resolution = 1.0f;   // R, in (0, 64]; 1: G = 2 up to N = 64, 4 at 4096, 8 from 117650
    uint32_t grid_max_cells = 8;    // 2..16
    // Clip a reference that fits in neither grid child into both (only for child boxes that together
    // cover the node; within the reference budget). Off: such configurations are infeasible.
    bool grid_splitting = true;
    // Recursive cost evaluation (Popov et al. 2009, "use recursive cost evaluation"): choose each
    // node's split among the search spaces' best candidates by the SAH of the subtree built greedily
    // this many levels below the node (src/builders/lookahead.hpp). 0 = the greedy local choice.
    uint32_t lookahead_depth = 0;
    // The candidates it compares: this many of the cheapest splits per axis and search space (1..16).
    uint32_t lookahead_candidates = 2;
    // Recursive cost evaluation to the leaves at the top of the tree: a node holding at least this
    // share of the root's references prices each search space's cheapest split (and the leaf, where
    // allowed) by the SAH of the whole subtree it leads to, built greedily, and takes the cheapest.
    // The greedy step prices children as leaves, which is furthest from the truth at the top, where
    // most of the tree's SAH sits (bench/LOOKAHEAD_RESULTS.md, session 16). 0 = off; else in
    // [kMinLookaheadTopShare, 1]. Costs about one greedy build per search space for each level of
    // such nodes. Builders with one search space (cbvh, binned, kdbvh) have nothing to choose: no effect.
    float lookahead_top_share = 0.0f;
    // Presets with spatial search (kdbvh, spatial, sbvh) evaluate kd planes at every reference bound
    // event with exact child boxes (SearchSpace::spatial_sweep) instead of on --spatial-bins bins.
    // Off by default: measured not to pay for its build time (bench/SWEEP_RESULTS.md).
    bool exact_spatial_sweep = false;
    // Exact sweep: positions sampled inside the intervals next to the best event planes (0..64;
    // 0 = event planes only). See src/builders/spatial_sweep_split_finder.hpp.
    uint32_t sweep_interior_samples = 0;
    // After the build, optimise the tree by subtree reinsertion (Bittner et al. 2013; see
    // optimize_bvh): at most this many iterations, each moving a batch of subtrees to places that
    // lower the tree SAH; it stops earlier once an iteration gains little. 0 = off (every preset's
    // default); kDefaultReinsertionIterations is the CLI's --optimize. Leaves stay as built.
    uint32_t reinsertion_iterations = 0;
    // Called now and then with the fraction of references that have reached a leaf (0..1), from any
    // thread. May be empty.
    std::function<void(double)> progress;
    // Polled between nodes, from any thread; once it reads true, build_bvh stops and throws Cancelled
    // (nothing leaks). May be null.
    const std::atomic<bool>* cancel = nullptr;

    // Throws Error for an unknown builder or absurd parameters.
    void validate() const;
};

// Named builders: "cbvh", "binned", "kdbvh", "spatial", "sbvh", "esc", "evh", "full" (see describe_builder).
std::vector<std::string> builder_names();
// Options with the preset's defaults (its overlap penalty C_o). Throws Error for an unknown name.
BuildOptions options_for(const std::string& builder);
// One line each, for --help.
std::string describe_builder(const std::string& name);

// Builds a BVH over the scene's triangles with the calling thread's oneTBB arena (limit threads with
// tbb::global_control or a tbb::task_arena). Deterministic: the same scene and options give the same
// tree, whatever the thread count. An empty scene throws Error; a set cancel flag throws Cancelled.
// With options.reinsertion_iterations > 0 the tree is then optimised (optimize_bvh) and its builder
// name gets "+opt" ("binned+opt").
Bvh build_bvh(const Scene& scene, const BuildOptions& options);

// Reinsertion optimisation of any binary tree (ours, Embree's imported trees): moves subtrees to
// where they lower the tree SAH under bvh.cost (the plain SAH: an overlap penalty C_o only prices
// split choices), never raising it; leaves, their boxes and triangles stay; the depth stays within
// options.max_depth (or the tree's own depth if it is deeper). Uses options.reinsertion_iterations
// (nothing when 0), max_depth, progress and cancel (throws Cancelled; the tree is then unchanged).
// Deterministic for any thread count. Appends "+opt" to bvh.builder when it ran.
void optimize_bvh(Bvh& bvh, const BuildOptions& options);

}  // namespace spacebvh
