// SPDX-License-Identifier: MIT
// The walks of RayQueries (queries.hpp): the node tests of query_node_tests.hpp over the walk
// skeleton (walk.hpp), with the leaf visitors of each query. One ray each; batching is the caller's.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "spacebvh/geometry.hpp"
#include "spacebvh/queries.hpp"
#include "trace/queries/query_layout.hpp"

namespace spacebvh::trace::queries {

// The crossing with the smallest t (ties: the smaller triangle id) into `out`; QueryHit{}
// (primitive == kInvalidIndex) when there is none.
void nearest_crossing(const RayQueries::Layout& layout, const Ray& ray, QueryHit& out);
// Its triangle only (kInvalidIndex when there is none).
uint32_t nearest_crossing_id(const RayQueries::Layout& layout, const Ray& ray);
bool any_crossing(const RayQueries::Layout& layout, const Ray& ray);
// Every crossing, sorted by (t, primitive), at most max_hits of them (the nearest); replaces `out`.
void collect_hits(const RayQueries::Layout& layout, const Ray& ray, std::vector<QueryHit>& out, size_t max_hits);
// The number of crossings; `scratch` is working memory the caller keeps between rays.
uint32_t count_crossings(const RayQueries::Layout& layout, const Ray& ray, std::vector<uint32_t>& scratch);

}  // namespace spacebvh::trace::queries
