// SPDX-License-Identifier: MIT
// The walks of the exact multi-hit queries (docs/queries.md), compiled twice from query_walks.inl as
// the kernels are (kernel_instances.cpp): for the baseline, over the binary layout only, and under
// `#pragma GCC target` for AVX2 and FMA, over the eight-wide layout too. A layout holds eight-wide
// nodes only where the CPU reports AVX2 and FMA (query_layout.cpp), so the walks are chosen per
// layout at run time, and a portable build walks the eight-wide nodes on such CPUs too.
//
// Decision for one ray and one triangle, in three stages:
//  1. the float edge functions of the watertight test with their error bound (triangle_pack.hpp):
//     most triangles are clearly missed, and a clear crossing of the interior needs nothing more;
//  2. otherwise the sign of each edge function, exactly, under one symbolic perturbation of the
//     ray (perturbed_triangle.hpp: crosses_perturbed);
//  3. the distance: t in [tmin, tmax] decided exactly, t itself in double (crossing_in_range).
// The answers never depend on the order leaves are visited in: all hits and counts are sorted and
// deduplicated, the first crossing is the least (t, id) of all, and any hit is a yes or no. Nor on
// the layout walked: both node tests are conservative, and the leaf test is exact.
#include "trace/queries/query_walks.hpp"

#include <immintrin.h>

#include <algorithm>
#include <cmath>

#include "trace/leaf_tests/perturbed_triangle.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"
#include "trace/leaf_tests/watertight_triangle.hpp"
#include "trace/queries/query_node_tests.hpp"
#include "trace/target_region.hpp"
#include "trace/traversal/walk.hpp"

namespace spacebvh::trace::queries {

namespace {

using Layout = RayQueries::Layout;

// One instruction set's walks.
struct Walks {
    void (*nearest)(const Layout&, const Ray&, QueryHit&);
    uint32_t (*nearest_id)(const Layout&, const Ray&);
    bool (*any)(const Layout&, const Ray&);
    void (*collect)(const Layout&, const Ray&, std::vector<QueryHit>&, size_t);
    uint32_t (*count)(const Layout&, const Ray&, std::vector<uint32_t>&);
};

// A build that targets AVX2 and FMA already (the native one) needs neither the baseline's copy nor
// the target pragma: its AVX2 walks take layouts without eight-wide nodes over the binary ones.
#if defined(__AVX2__) && defined(__FMA__)
#define SPACEBVH_QUERY_WALKS_BASELINE 0
#else
#define SPACEBVH_QUERY_WALKS_BASELINE 1
#endif
#if SPACEBVH_QUERY_WALKS_BASELINE
namespace baseline_walks {
#include "trace/queries/query_walks.inl"
constexpr Walks kWalks{nearest_crossing, nearest_crossing_id, any_crossing, collect_hits, count_crossings};
}  // namespace baseline_walks

SPACEBVH_TARGET_BEGIN("avx2,fma")
#endif
// The walk skeleton again, under this target: the baseline's walk() may not inline a node test
// compiled for AVX2.
namespace avx2_walks {
#include "trace/traversal/walk_skeleton.inl"
#include "trace/queries/query_wide_tests.inl"
#define SPACEBVH_QUERY_WALKS_WIDE 1
#include "trace/queries/query_walks.inl"
#undef SPACEBVH_QUERY_WALKS_WIDE
constexpr Walks kWalks{nearest_crossing, nearest_crossing_id, any_crossing, collect_hits, count_crossings};
}  // namespace avx2_walks
#if SPACEBVH_QUERY_WALKS_BASELINE
SPACEBVH_TARGET_END()

const Walks& walks_of(const Layout& layout) { return layout.has_wide ? avx2_walks::kWalks : baseline_walks::kWalks; }
#else
const Walks& walks_of(const Layout&) { return avx2_walks::kWalks; }
#endif

}  // namespace

void nearest_crossing(const Layout& layout, const Ray& ray, QueryHit& out) {
    walks_of(layout).nearest(layout, ray, out);
}

uint32_t nearest_crossing_id(const Layout& layout, const Ray& ray) { return walks_of(layout).nearest_id(layout, ray); }

bool any_crossing(const Layout& layout, const Ray& ray) { return walks_of(layout).any(layout, ray); }

void collect_hits(const Layout& layout, const Ray& ray, std::vector<QueryHit>& out, size_t max_hits) {
    walks_of(layout).collect(layout, ray, out, max_hits);
}

uint32_t count_crossings(const Layout& layout, const Ray& ray, std::vector<uint32_t>& scratch) {
    return walks_of(layout).count(layout, ray, scratch);
}

}  // namespace spacebvh::trace::queries
