// SPDX-License-Identifier: MIT
// RayQueries (queries.hpp, docs/queries.md): argument checks and batches over the walks of
// queries/query_walks.cpp, on the layout of queries/query_layout.hpp.
#include "spacebvh/queries.hpp"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "spacebvh/error.hpp"
#include "trace/leaf_tests/perturbed_triangle.hpp"
#include "trace/queries/query_batches.hpp"
#include "trace/queries/query_layout.hpp"
#include "trace/queries/query_walks.hpp"

namespace spacebvh {

namespace {

using namespace trace::queries;

bool valid_ray(const Ray& ray) {
    return is_finite(ray.org) && is_finite(ray.dir) && !(ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) &&
           !std::isnan(ray.tmin) && !std::isnan(ray.tmax);
}

void check_ray(const Ray& ray) {
    if (!valid_ray(ray))
        throw Error("queries: a ray needs a finite origin, a finite nonzero direction and tmin, tmax that are not NaN");
}

Ray containment_ray(Vec3 point) {
    if (!is_finite(point)) throw Error("queries: contains() needs a finite point");
    return Ray{point, kContainmentDirection, 0.0f, kInfinity};
}

void check_sizes(size_t a, size_t b, const char* what) {
    if (a != b)
        throw Error(std::string("queries: ") + what + ": " + std::to_string(a) + " inputs but room for " +
                    std::to_string(b) + " answers");
}

}  // namespace

std::optional<QueryHit> intersect_triangle_perturbed(const Ray& ray, const Triangle& triangle, uint32_t id) {
    check_ray(ray);
    if (triangle.is_degenerate()) return std::nullopt;
    if (!trace::perturbed::crosses_perturbed(ray, triangle.v0, triangle.v1, triangle.v2)) return std::nullopt;
    double t;
    if (!trace::perturbed::crossing_in_range(ray, triangle.v0, triangle.v1, triangle.v2, ray.tmax, t))
        return std::nullopt;
    return trace::perturbed::make_hit(ray, triangle.v0, triangle.v1, triangle.v2, id, t);
}

RayQueries::RayQueries(std::span<const Triangle> triangles, const Bvh& bvh)
    : layout_(std::make_unique<Layout>(triangles, bvh)) {}

RayQueries::~RayQueries() = default;
RayQueries::RayQueries(RayQueries&&) noexcept = default;
RayQueries& RayQueries::operator=(RayQueries&&) noexcept = default;

size_t RayQueries::triangle_count() const { return layout_->triangle_count; }

std::optional<QueryHit> RayQueries::first_hit(const Ray& ray) const {
    check_ray(ray);
    QueryHit hit;
    nearest_crossing(*layout_, ray, hit);
    if (!hit.is_hit()) return std::nullopt;
    return hit;
}

bool RayQueries::any_hit(const Ray& ray) const {
    check_ray(ray);
    return any_crossing(*layout_, ray);
}

void RayQueries::all_hits(const Ray& ray, std::vector<QueryHit>& out, size_t max_hits) const {
    check_ray(ray);
    collect_hits(*layout_, ray, out, max_hits);
}

uint32_t RayQueries::count_hits(const Ray& ray) const {
    check_ray(ray);
    std::vector<uint32_t> scratch;
    return count_crossings(*layout_, ray, scratch);
}

bool RayQueries::contains(Vec3 point) const {
    std::vector<uint32_t> scratch;
    return count_crossings(*layout_, containment_ray(point), scratch) % 2 == 1;
}

void RayQueries::first_hits(std::span<const Ray> rays, std::span<QueryHit> out) const {
    check_sizes(rays.size(), out.size(), "first_hits");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) nearest_crossing(*layout_, rays[i], out[i]);
    });
}

void RayQueries::first_hit_ids(std::span<const Ray> rays, std::span<uint32_t> out) const {
    check_sizes(rays.size(), out.size(), "first_hit_ids");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) out[i] = nearest_crossing_id(*layout_, rays[i]);
    });
}

void RayQueries::any_hits(std::span<const Ray> rays, std::span<uint8_t> out) const {
    check_sizes(rays.size(), out.size(), "any_hits");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) out[i] = any_crossing(*layout_, rays[i]) ? 1 : 0;
    });
}

HitLists RayQueries::all_hits(std::span<const Ray> rays, size_t max_hits) const {
    for (const Ray& ray : rays) check_ray(ray);
    const size_t chunks = (rays.size() + kGrain - 1) / kGrain;
    std::vector<std::vector<QueryHit>> chunk_hits(chunks);
    HitLists lists;
    lists.offsets.assign(rays.size() + 1, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1), [&](const tbb::blocked_range<size_t>& range) {
        std::vector<QueryHit> scratch;
        for (size_t c = range.begin(); c != range.end(); ++c) {
            std::vector<QueryHit>& hits = chunk_hits[c];
            const size_t end = std::min(rays.size(), (c + 1) * kGrain);
            for (size_t i = c * kGrain; i < end; ++i) {
                collect_hits(*layout_, rays[i], scratch, max_hits);
                lists.offsets[i + 1] = scratch.size();
                hits.insert(hits.end(), scratch.begin(), scratch.end());
            }
        }
    });
    for (size_t i = 0; i < rays.size(); ++i) lists.offsets[i + 1] += lists.offsets[i];
    lists.hits.resize(lists.offsets.back());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t c = range.begin(); c != range.end(); ++c)
            std::copy(chunk_hits[c].begin(), chunk_hits[c].end(),
                      lists.hits.begin() + ptrdiff_t(lists.offsets[c * kGrain]));
    });
    return lists;
}

void RayQueries::count_hits(std::span<const Ray> rays, std::span<uint32_t> out) const {
    check_sizes(rays.size(), out.size(), "count_hits");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        std::vector<uint32_t> scratch;
        for (size_t i = begin; i < end; ++i) out[i] = count_crossings(*layout_, rays[i], scratch);
    });
}

void RayQueries::contains(std::span<const Vec3> points, std::span<uint8_t> out) const {
    check_sizes(points.size(), out.size(), "contains");
    for (const Vec3& p : points) containment_ray(p);
    const size_t n = points.size();
    if (n < kOrderedBatch || n > std::numeric_limits<uint32_t>::max() || layout_->nodes.empty()) {
        for_chunks(n, [&](size_t begin, size_t end) {
            std::vector<uint32_t> scratch;
            for (size_t i = begin; i < end; ++i)
                out[i] = count_crossings(*layout_, containment_ray(points[i]), scratch) % 2;
        });
        return;
    }
    // In coherent_order, the rays gathered first: read in place, each would be a cache miss the walk
    // waits on.
    const std::vector<uint32_t> order =
        coherent_order(layout_->bounds, n, [&](size_t i) { return containment_ray(points[i]); });
    std::vector<Ray> ordered(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1 << 14), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t k = range.begin(); k < range.end(); ++k) ordered[k] = containment_ray(points[order[k]]);
    });
    for_chunks(n, [&](size_t begin, size_t end) {
        std::vector<uint32_t> scratch;
        for (size_t k = begin; k < end; ++k) out[order[k]] = count_crossings(*layout_, ordered[k], scratch) % 2;
    });
}

}  // namespace spacebvh
