// SPDX-License-Identifier: MIT
// Multi-hit queries (queries.hpp) against two brute-force references, every triangle tested for
// every ray: the library's own one-triangle decision (intersect_triangle_perturbed), which the walks
// must reproduce bit for bit; and an independent one, exact rational arithmetic (GMP) wherever a
// double predicate is not clearly decided, the perturbation rule of docs/queries.md written out from
// its definition.
#include <gtest/gtest.h>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/queries.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"
#include "grid_box.hpp"

#ifdef SPACEBVH_HAVE_GMP
#include <gmpxx.h>
#endif

namespace spacebvh {

using namespace spacebvh::tools;
namespace {

#ifdef SPACEBVH_HAVE_GMP

mpq_class q(float x) { return mpq_class(double(x)); }

struct QVec {
    mpq_class x, y, z;
};
QVec qv(Vec3 a) { return {q(a.x), q(a.y), q(a.z)}; }
QVec qsub(const QVec& a, const QVec& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
QVec qcross(const QVec& a, const QVec& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
mpq_class qdot(const QVec& a, const QVec& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Sign of dir . ((p - o) x (q - o)): double when it is clearly away from zero, else rationals; an exact
// zero takes the perturbation's sign (origin moved by e x + e^2 y + e^3 z): dir x (q - p), first
// nonzero component.
int reference_edge_sign(const Ray& ray, Vec3 p, Vec3 qq) {
    const double ax = double(p.x) - ray.org.x, ay = double(p.y) - ray.org.y, az = double(p.z) - ray.org.z;
    const double bx = double(qq.x) - ray.org.x, by = double(qq.y) - ray.org.y, bz = double(qq.z) - ray.org.z;
    const double value =
        ray.dir.x * (ay * bz - az * by) + ray.dir.y * (az * bx - ax * bz) + ray.dir.z * (ax * by - ay * bx);
    const double size = std::fabs(ray.dir.x) * (std::fabs(ay * bz) + std::fabs(az * by)) +
                        std::fabs(ray.dir.y) * (std::fabs(az * bx) + std::fabs(ax * bz)) +
                        std::fabs(ray.dir.z) * (std::fabs(ax * by) + std::fabs(ay * bx));
    if (std::fabs(value) > 1e-10 * size + 1e-280) return value > 0 ? 1 : -1;
    const QVec o = qv(ray.org), d = qv(ray.dir);
    const int s = sgn(qdot(d, qcross(qsub(qv(p), o), qsub(qv(qq), o))));
    if (s != 0) return s;
    const QVec w = qcross(d, qsub(qv(qq), qv(p)));
    if (sgn(w.x) != 0) return sgn(w.x);
    if (sgn(w.y) != 0) return sgn(w.y);
    return sgn(w.z);
}

struct ReferenceHit {
    double t;
    uint32_t primitive;
};

// Every crossing by brute force, sorted by (exact t, primitive).
std::vector<ReferenceHit> reference_hits(std::span<const Triangle> triangles, const Ray& ray) {
    std::vector<std::pair<mpq_class, uint32_t>> exact;
    for (uint32_t i = 0; i < triangles.size(); ++i) {
        const Triangle& tri = triangles[i];
        if (tri.is_degenerate()) continue;
        const int su = reference_edge_sign(ray, tri.v1, tri.v2);
        if (su == 0) continue;
        if (reference_edge_sign(ray, tri.v2, tri.v0) != su || reference_edge_sign(ray, tri.v0, tri.v1) != su) continue;
        const QVec v0 = qv(tri.v0), n = qcross(qsub(qv(tri.v1), v0), qsub(qv(tri.v2), v0));
        const mpq_class denominator = qdot(n, qv(ray.dir));
        if (sgn(denominator) == 0) continue;
        const mpq_class t = qdot(n, qsub(v0, qv(ray.org))) / denominator;
        if (std::isfinite(ray.tmin) && t < q(ray.tmin)) continue;
        if (std::isfinite(ray.tmax) && t > q(ray.tmax)) continue;
        exact.emplace_back(t, i);
    }
    std::sort(exact.begin(), exact.end());
    std::vector<ReferenceHit> hits;
    for (const auto& [t, id] : exact) hits.push_back({t.get_d(), id});
    return hits;
}

// Our hits agree with the reference: the same triangles; each t within rounding of the exact one;
// sorted by our t (ties by id), which may swap crossings whose exact t differ by less than rounding.
::testing::AssertionResult same_hits(const std::vector<QueryHit>& ours, const std::vector<ReferenceHit>& reference) {
    if (ours.size() != reference.size())
        return ::testing::AssertionFailure() << ours.size() << " hits, reference " << reference.size();
    std::vector<uint32_t> a, b;
    for (size_t i = 0; i < ours.size(); ++i) {
        a.push_back(ours[i].primitive);
        b.push_back(reference[i].primitive);
        if (i > 0 &&
            (ours[i].t < ours[i - 1].t || (ours[i].t == ours[i - 1].t && ours[i].primitive < ours[i - 1].primitive)))
            return ::testing::AssertionFailure() << "hits not sorted at " << i;
    }
    std::vector<uint32_t> sa = a, sb = b;
    std::sort(sa.begin(), sa.end());
    std::sort(sb.begin(), sb.end());
    if (sa != sb) return ::testing::AssertionFailure() << "different triangles";
    for (const QueryHit& hit : ours) {
        const auto it = std::find_if(reference.begin(), reference.end(),
                                     [&](const ReferenceHit& r) { return r.primitive == hit.primitive; });
        if (std::fabs(it->t - hit.t) > 1e-9 * std::max(1.0, std::fabs(it->t)))
            return ::testing::AssertionFailure()
                   << "t " << hit.t << " vs exact " << it->t << " on triangle " << hit.primitive;
    }
    return ::testing::AssertionSuccess();
}

#endif  // SPACEBVH_HAVE_GMP

// A direction rounded to 8 significant bits, so that a vertex minus it is usually exact in float.
Vec3 coarse(Vec3 d) {
    for (int a = 0; a < 3; ++a) {
        int e;
        std::frexp(d[a], &e);
        d[a] = std::ldexp(std::round(std::ldexp(d[a], 8 - e)), e - 8);
    }
    return d;
}

// Rays exactly through points of the mesh: origin o = m - d in float, kept only when o + d == m
// exactly (checked in double, where the sum of two floats of nearby magnitude is exact), where m is
// the vertex or edge midpoint `target(triangle, attempt)` returns (nothing when it is not a float).
template <class Target>
std::vector<Ray> rays_through(std::span<const Triangle> triangles, size_t count, uint64_t seed, Target&& target) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<size_t> pick(0, triangles.size() - 1);
    AABB bounds;
    for (const Triangle& t : triangles) bounds.extend(t.bounds());
    const float scale = length(bounds.extent()) * 0.5f;
    std::vector<Ray> rays;
    for (size_t attempt = 0; rays.size() < count && attempt < count * 1000; ++attempt) {
        const std::optional<Vec3> m = target(triangles[pick(rng)], int(attempt % 3));
        const Vec3 d = coarse({unit(rng) * scale, unit(rng) * scale, unit(rng) * scale});
        if (!m) continue;
        const Vec3 o = *m - d;
        bool exact = true;
        for (int a = 0; a < 3; ++a) exact = exact && double(o[a]) + double(d[a]) == double((*m)[a]);
        if (exact) rays.push_back({o, d, 0.0f, kInfinity});
    }
    return rays;
}

std::vector<Ray> rays_through_vertices(std::span<const Triangle> triangles, size_t count, uint64_t seed) {
    return rays_through(triangles, count, seed,
                        [](const Triangle& tri, int k) -> std::optional<Vec3> { return tri.vertex(k); });
}

std::vector<Ray> rays_through_edges(std::span<const Triangle> triangles, size_t count, uint64_t seed) {
    return rays_through(triangles, count, seed, [](const Triangle& tri, int k) -> std::optional<Vec3> {
        const Vec3 p = tri.vertex(k), q = tri.vertex((k + 1) % 3);
        Vec3 m;
        for (int a = 0; a < 3; ++a) {
            const double mid = (double(p[a]) + double(q[a])) * 0.5;
            m[a] = float(mid);
            if (double(m[a]) != mid) return std::nullopt;
        }
        return m;
    });
}

Bvh build_for(std::span<const Triangle> triangles, const std::string& builder) {
    Scene scene;
    scene.name = "test";
    scene.triangles.assign(triangles.begin(), triangles.end());
    return spacebvh::build(scene, config_for(builder));
}

TEST(Queries, ClosedBoxCrossedOnceAtEveryVertexAndEdge) {
    const std::vector<Triangle> box = grid_box(3);
    for (const std::string builder : {"binned", "spatial"}) {
        const RayQueries queries(box, build_for(box, builder));
        // From interior points at half-integers, aimed at every vertex and edge midpoint of the box.
        std::vector<Vec3> targets;
        for (const Triangle& t : box)
            for (int k = 0; k < 3; ++k) {
                targets.push_back(t.vertex(k));
                targets.push_back((t.vertex(k) + t.vertex((k + 1) % 3)) * 0.5f);
            }
        for (const Vec3 origin : {Vec3{1.5f, 2.5f, 3.5f}, Vec3{3.0f, 3.0f, 3.0f}, Vec3{0.5f, 5.5f, 2.0f}}) {
            for (const Vec3& target : targets) {
                const Ray ray{origin, target - origin, 0.0f, kInfinity};
                std::vector<QueryHit> hits;
                queries.all_hits(ray, hits);
                ASSERT_EQ(hits.size(), 1u) << builder << " target " << target.x << "," << target.y << "," << target.z;
                EXPECT_EQ(queries.count_hits(ray), 1u);
                EXPECT_TRUE(queries.any_hit(ray));
                ASSERT_TRUE(queries.first_hit(ray));
                EXPECT_EQ(queries.first_hit(ray)->primitive, hits[0].primitive);
                EXPECT_NEAR(hits[0].t, 1.0, 1e-12);
                for (int a = 0; a < 3; ++a) EXPECT_NEAR(hits[0].point[size_t(a)], target[a], 1e-9);
                EXPECT_TRUE(queries.contains(origin));
                // The same line from outside: in and out, once each.
                const Ray through{origin - (target - origin) * 64.0f, target - origin, 0.0f, kInfinity};
                EXPECT_EQ(queries.count_hits(through), 2u);
            }
        }
        // Axis-aligned rays along the box's grid lines (in the plane of faces, through edges and
        // vertices): a ray along an inner face's plane crosses the two faces it meets once each.
        for (int x = 0; x <= 6; x += 2)
            for (int y = 0; y <= 6; y += 2) {
                const Ray ray{{float(x), float(y), -5.0f}, {0.0f, 0.0f, 1.0f}, 0.0f, kInfinity};
                const uint32_t count = queries.count_hits(ray);
                const bool on_boundary_line = x == 0 || x == 6 || y == 0 || y == 6;
                // Along the box's side faces the ray runs in their plane (never hit) and crosses the
                // bottom and top at their boundary: the perturbation decides both the same way.
                if (!on_boundary_line) {
                    EXPECT_EQ(count, 2u) << x << "," << y;
                }
                EXPECT_EQ(count % 2, 0u) << x << "," << y;
            }
    }
}

TEST(Queries, CoplanarAndParallelRaysNeverHit) {
    const std::vector<Triangle> box = grid_box(2);
    const RayQueries queries(box, build_for(box, "binned"));
    // In the plane z = 0 of the bottom face, through its vertices and across it.
    for (const Vec3 dir : {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{1, 1, 0}, Vec3{1, 2, 0}}) {
        const Ray ray{{-1.0f, -1.0f, 0.0f}, dir, 0.0f, kInfinity};
        std::vector<QueryHit> hits;
        queries.all_hits(ray, hits);
        // The bottom face is in the ray's plane (never hit); side faces are crossed at their lower edge,
        // and the perturbation takes such a crossing either way, identically for both triangles of it.
        for (const QueryHit& hit : hits) EXPECT_NE(box[hit.primitive].geometric_normal().z != 0.0f, true);
        EXPECT_EQ(hits.size() % 2, 0u);
    }
}

TEST(Queries, DuplicateRaysAndDuplicateTriangles) {
    std::vector<Triangle> box = grid_box(2);
    const size_t n = box.size();
    box.insert(box.end(), box.begin(), box.begin() + ptrdiff_t(n));  // every triangle twice
    const RayQueries queries(box, build_for(box, "binned"));
    const Ray ray{{1.5f, 1.5f, -3.0f}, {0.0f, 0.0f, 1.0f}, 0.0f, kInfinity};
    std::vector<Ray> rays(100, ray);
    const HitLists lists = queries.all_hits(rays);
    for (size_t i = 0; i < rays.size(); ++i) {
        ASSERT_EQ(lists.offsets[i + 1] - lists.offsets[i], 4u);  // two surfaces, each stored twice
        for (uint64_t k = 0; k < 4; ++k) EXPECT_EQ(lists.hits[lists.offsets[i] + k].primitive, lists.hits[k].primitive);
    }
    EXPECT_EQ(lists.hits[0].primitive + n, lists.hits[1].primitive);  // equal t: by id
    EXPECT_FALSE(queries.contains({1.5f, 1.5f, 1.5f}));               // parity: each surface counted twice
}

TEST(Queries, MaxHitsKeepsTheNearest) {
    const std::vector<Triangle> box = grid_box(2);
    const RayQueries queries(box, build_for(box, "binned"));
    const Ray ray{{1.5f, 1.5f, -3.0f}, {0.0f, 0.0f, 1.0f}, 0.0f, kInfinity};
    std::vector<QueryHit> all, one;
    queries.all_hits(ray, all);
    queries.all_hits(ray, one, 1);
    ASSERT_EQ(all.size(), 2u);
    ASSERT_EQ(one.size(), 1u);
    EXPECT_EQ(one[0].primitive, all[0].primitive);
    EXPECT_EQ(all[0].t, 3.0);
    EXPECT_EQ(all[1].t, 7.0);
    // Closed interval: a segment ending exactly on a face counts it; one starting there too.
    EXPECT_EQ(queries.count_hits({{1.5f, 1.5f, -3.0f}, {0, 0, 1}, 0.0f, 3.0f}), 1u);
    EXPECT_EQ(queries.count_hits({{1.5f, 1.5f, -3.0f}, {0, 0, 1}, 3.0f, 6.9f}), 1u);
    EXPECT_EQ(queries.count_hits({{1.5f, 1.5f, -3.0f}, {0, 0, 1}, 3.0001f, 6.9f}), 0u);
}

TEST(Queries, BadRaysAreErrors) {
    const std::vector<Triangle> box = grid_box(1);
    const RayQueries queries(box, build_for(box, "binned"));
    EXPECT_THROW(queries.count_hits({{0, 0, 0}, {0, 0, 0}, 0.0f, kInfinity}), Error);
    EXPECT_THROW(queries.any_hit({{NAN, 0, 0}, {0, 0, 1}, 0.0f, kInfinity}), Error);
    EXPECT_THROW(queries.contains({INFINITY, 0, 0}), Error);
    std::vector<uint32_t> counts(1);
    std::vector<Ray> rays(2, Ray{{0, 0, 0}, {0, 0, 1}, 0.0f, kInfinity});
    EXPECT_THROW(queries.count_hits(rays, counts), Error);
}

TEST(Queries, ContainmentIsRepeatableAndIndependentOfThreads) {
    const Scene scene = load_scene("builtin:organic");
    const RayQueries queries(scene.triangles, spacebvh::build(scene, config_for("binned")));
    AABB bounds;
    for (const Triangle& t : scene.triangles) bounds.extend(t.bounds());
    std::vector<Vec3> points;
    SplitMix64 rng(7);
    // A batch large enough to be walked in coherent order, from a box a fifth larger than the mesh's
    // (points outside it are clamped to the border cells of that order).
    for (int i = 0; i < 20000; ++i) {
        const Vec3 e = bounds.extent();
        auto coordinate = [&](float lo, float extent) { return lo + extent * (1.2f * rng.uniform() - 0.1f); };
        points.push_back({coordinate(bounds.lo.x, e.x), coordinate(bounds.lo.y, e.y), coordinate(bounds.lo.z, e.z)});
    }
    // Mesh vertices too: points on the surface.
    for (size_t i = 0; i < scene.triangles.size(); i += 7) points.push_back(scene.triangles[i].v0);
    std::vector<uint8_t> first(points.size());
    tbb::task_arena(1).execute([&] { queries.contains(points, first); });
    for (int run = 0; run < 10; ++run) {
        std::vector<uint8_t> again(points.size());
        tbb::task_arena(run % 2 ? 2 : 1).execute([&] { queries.contains(points, again); });
        ASSERT_EQ(first, again) << "run " << run;
    }
    size_t inside = 0;
    for (size_t i = 0; i < points.size(); ++i) {
        EXPECT_EQ(bool(first[i]), queries.contains(points[i]));
        inside += first[i];
    }
    EXPECT_GT(inside, 0u);
}

TEST(Queries, LargeContainmentBatchOverDegenerateTrianglesIsOutside) {
    // Zero-area triangles only (never crossed), in a flat box: the coherent order's grid has zero
    // extent on every axis.
    Scene scene;
    scene.name = "degenerate";
    for (int i = 0; i < 64; ++i) {
        const Vec3 p{1.0f, 2.0f, 3.0f};
        scene.triangles.push_back({p, p, p});
    }
    const RayQueries queries(scene.triangles, spacebvh::build(scene, config_for("binned")));
    std::vector<Vec3> points;
    SplitMix64 rng(3);
    for (int i = 0; i < 5000; ++i) points.push_back({4 * rng.uniform() - 1, 4 * rng.uniform(), 4 * rng.uniform() + 1});
    points.push_back({1.0f, 2.0f, 3.0f});
    std::vector<uint8_t> inside(points.size(), 1);
    queries.contains(points, inside);
    EXPECT_EQ(std::count(inside.begin(), inside.end(), uint8_t(1)), 0);
}

// ---------------------------------------------------------------------------------------------
// Every query's answers against a brute-force loop over intersect_triangle_perturbed (the decision for
// one triangle, no tree): the layouts, the walks with their culling, and the float filter of the leaf
// test may change no answer, bit for bit. Without GMP too (the exact reference below checks the
// decision itself).

bool same_hit(const QueryHit& a, const QueryHit& b) {
    return a.primitive == b.primitive && a.t == b.t && a.u == b.u && a.v == b.v && a.point == b.point;
}

// All hits and counts on a split tree (triangles referenced from several leaves), on rays through
// vertices and edges, the same bit for bit on one thread and on several, in batches and one ray at a
// time (as the Python binding calls it from its threads).
TEST(Queries, CrossingsAreIndependentOfThreads) {
    const Scene scene = load_scene("builtin:organic");
    const RayQueries queries(scene.triangles, spacebvh::build(scene, config_for("spatial")));
    AABB bounds;
    for (const Triangle& t : scene.triangles) bounds.extend(t.bounds());
    std::vector<Ray> rays = generate_random_rays(bounds, 3000, 41);
    for (const std::vector<Ray>& through :
         {rays_through_vertices(scene.triangles, 3000, 42), rays_through_edges(scene.triangles, 3000, 43)})
        rays.insert(rays.end(), through.begin(), through.end());
    const auto answers = [&](int threads) {
        HitLists lists;
        std::vector<uint32_t> counts(rays.size()), per_ray(rays.size());
        tbb::task_arena(threads).execute([&] {
            lists = queries.all_hits(rays);
            queries.count_hits(rays, counts);
            tbb::parallel_for(size_t(0), rays.size(), [&](size_t i) {
                std::vector<QueryHit> hits;
                queries.all_hits(rays[i], hits);
                per_ray[i] = uint32_t(hits.size());
            });
        });
        return std::make_tuple(std::move(lists), counts, per_ray);
    };
    const auto [lists, counts, per_ray] = answers(1);
    size_t crossings = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        ASSERT_EQ(lists.offsets[i + 1] - lists.offsets[i], counts[i]) << "ray " << i;
        ASSERT_EQ(per_ray[i], counts[i]) << "ray " << i;
        crossings += counts[i];
    }
    EXPECT_GT(crossings, rays.size() / 4);
    for (int threads : {2, 3}) {
        const auto [again, again_counts, again_per_ray] = answers(threads);
        EXPECT_EQ(again.offsets, lists.offsets) << threads << " threads";
        ASSERT_EQ(again.hits.size(), lists.hits.size()) << threads << " threads";
        for (size_t k = 0; k < lists.hits.size(); ++k)
            ASSERT_TRUE(same_hit(again.hits[k], lists.hits[k])) << threads << " threads, hit " << k;
        EXPECT_EQ(again_counts, counts) << threads << " threads";
        EXPECT_EQ(again_per_ray, per_ray) << threads << " threads";
    }
}

// Every crossing of the ray, sorted by (t, primitive), from every triangle.
std::vector<QueryHit> brute_force_hits(std::span<const Triangle> triangles, const Ray& ray) {
    std::vector<QueryHit> hits;
    for (uint32_t i = 0; i < triangles.size(); ++i)
        if (const std::optional<QueryHit> hit = intersect_triangle_perturbed(ray, triangles[i], i))
            hits.push_back(*hit);
    std::sort(hits.begin(), hits.end(), [](const QueryHit& a, const QueryHit& b) {
        return a.t < b.t || (a.t == b.t && a.primitive < b.primitive);
    });
    return hits;
}

// All hits, counts, first hits (whole and ids) and any hit, in batches and one ray at a time; returns
// the number of crossings.
size_t check_rays_by_brute_force(const RayQueries& queries, std::span<const Triangle> triangles,
                                 std::span<const Ray> rays, const std::string& what) {
    std::vector<std::vector<QueryHit>> expected(rays.size());
    tbb::parallel_for(size_t(0), rays.size(), [&](size_t i) { expected[i] = brute_force_hits(triangles, rays[i]); });
    const HitLists lists = queries.all_hits(rays);
    std::vector<uint32_t> counts(rays.size()), first_ids(rays.size());
    std::vector<QueryHit> firsts(rays.size());
    std::vector<uint8_t> anys(rays.size());
    queries.count_hits(rays, counts);
    queries.first_hits(rays, firsts);
    queries.first_hit_ids(rays, first_ids);
    queries.any_hits(rays, anys);
    size_t wrong = 0, crossings = 0;
    std::vector<QueryHit> one_ray;
    for (size_t i = 0; i < rays.size(); ++i) {
        const std::vector<QueryHit>& reference = expected[i];
        crossings += reference.size();
        bool ok = lists.offsets[i + 1] - lists.offsets[i] == reference.size();
        for (size_t k = 0; ok && k < reference.size(); ++k)
            ok = same_hit(lists.hits[lists.offsets[i] + k], reference[k]);
        ok = ok && counts[i] == reference.size() && bool(anys[i]) == !reference.empty();
        ok = ok && (reference.empty() ? !firsts[i].is_hit() : same_hit(firsts[i], reference[0]));
        ok = ok && first_ids[i] == firsts[i].primitive;
        if (i % 8 == 0) {
            const std::optional<QueryHit> first = queries.first_hit(rays[i]);
            ok = ok && (reference.empty() ? !first : first && same_hit(*first, reference[0]));
            ok =
                ok && queries.any_hit(rays[i]) == !reference.empty() && queries.count_hits(rays[i]) == reference.size();
            queries.all_hits(rays[i], one_ray, 2);
            ok = ok && one_ray.size() == std::min<size_t>(2, reference.size());
            for (size_t k = 0; ok && k < one_ray.size(); ++k) ok = same_hit(one_ray[k], reference[k]);
        }
        if (!ok && ++wrong <= 5)
            ADD_FAILURE() << what << " ray " << i << ": " << reference.size() << " crossings by brute force, "
                          << counts[i] << " counted";
    }
    EXPECT_EQ(wrong, 0u) << what << ": " << rays.size() << " rays, " << crossings << " crossings";
    return crossings;
}

// Containment (a batch, and one point at a time) against the parity of the brute-force crossings.
void check_containment_by_brute_force(const RayQueries& queries, std::span<const Triangle> triangles,
                                      std::span<const Vec3> points, const std::string& what) {
    std::vector<uint8_t> expected(points.size());
    tbb::parallel_for(size_t(0), points.size(), [&](size_t i) {
        expected[i] = brute_force_hits(triangles, {points[i], kContainmentDirection, 0.0f, kInfinity}).size() % 2;
    });
    std::vector<uint8_t> inside(points.size());
    queries.contains(points, inside);
    size_t wrong = 0;
    for (size_t i = 0; i < points.size(); ++i) {
        wrong += inside[i] != expected[i];
        if (i % 64 == 0) wrong += queries.contains(points[i]) != bool(expected[i]);
    }
    EXPECT_EQ(wrong, 0u) << what << ": " << points.size() << " points";
}

// Rays of every kind the walks tell apart: random (tmin 0: the wide layout where there is one); through
// vertices and edge midpoints, whole and as segments ending or starting exactly there (t = 1: the range
// decided exactly); axis-aligned from vertices; and with a negative tmin (the binary layout).
std::vector<Ray> brute_force_rays(const std::vector<Triangle>& triangles, size_t per_kind, uint64_t seed) {
    AABB bounds;
    for (const Triangle& t : triangles) bounds.extend(t.bounds());
    std::vector<Ray> rays = generate_random_rays(bounds, per_kind, seed);
    const std::vector<Ray> vertices = rays_through_vertices(triangles, per_kind, seed + 1);
    const std::vector<Ray> edges = rays_through_edges(triangles, per_kind, seed + 2);
    for (const std::vector<Ray>* through : {&vertices, &edges}) {
        for (size_t i = 0; i < through->size(); ++i) {
            Ray ray = (*through)[i];
            if (i % 3 == 1) ray.tmax = 1.0f;
            if (i % 3 == 2) ray.tmin = 1.0f;
            rays.push_back(ray);
        }
    }
    const float reach = length(bounds.extent());
    for (size_t i = 0; i < per_kind; ++i) {
        Vec3 dir{0, 0, 0};
        dir[int(i % 3)] = i % 2 ? 1.0f : -1.0f;
        rays.push_back({triangles[(i * 7919) % triangles.size()].v1, dir, 0.0f, kInfinity});
        Ray segment = rays[i];
        segment.tmin = -reach / length(segment.dir);
        segment.tmax = i % 2 ? 0.5f * reach / length(segment.dir) : kInfinity;
        rays.push_back(segment);
    }
    return rays;
}

// Points inside and around the mesh's box, and mesh vertices (on the surface).
std::vector<Vec3> brute_force_points(const std::vector<Triangle>& triangles, size_t count, uint64_t seed) {
    AABB bounds;
    for (const Triangle& t : triangles) bounds.extend(t.bounds());
    SplitMix64 rng(seed);
    std::vector<Vec3> points;
    for (size_t i = 0; i < count; ++i) {
        if (i % 5 == 0) {
            points.push_back(triangles[(i * 104729) % triangles.size()].v2);
            continue;
        }
        Vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = bounds.lo[a] + bounds.extent()[a] * (1.2f * rng.uniform() - 0.1f);
        points.push_back(p);
    }
    return points;
}

void check_scene_by_brute_force(const Scene& scene, size_t per_kind, size_t points,
                                const std::vector<std::string>& builders) {
    const std::vector<Ray> rays = brute_force_rays(scene.triangles, per_kind, 21);
    const std::vector<Vec3> inside = brute_force_points(scene.triangles, points, 22);
    for (const std::string& builder : builders) {
        const RayQueries queries(scene.triangles, spacebvh::build(scene, config_for(builder)));
        const std::string what = scene.name + "/" + builder;
        EXPECT_GT(check_rays_by_brute_force(queries, scene.triangles, rays, what), 0u) << what;
        check_containment_by_brute_force(queries, scene.triangles, inside, what);
    }
}

TEST(Queries, BuiltinScenesMatchBruteForceBitForBit) {
    // A modest count: every ray tests every triangle.
    for (const std::string& name : builtin_scene_names())
        check_scene_by_brute_force(load_scene("builtin:" + name), 50, 600, {"binned", "spatial"});
    // More points than a containment batch walks in input order (kOrderedBatch): the coherent order.
    Scene box;
    box.name = "grid_box";
    box.triangles = grid_box(4);
    check_scene_by_brute_force(box, 500, 5000, {"binned", "spatial"});
}

TEST(Queries, SharedScenesMatchBruteForceBitForBit) {
    const std::filesystem::path dir = std::filesystem::path(SPACEBVH_SHARED_DIR) / "scenes";
    if (!std::filesystem::exists(dir)) GTEST_SKIP() << "no shared scenes at " << dir;
    size_t checked = 0;
    for (const char* name : {"bunny", "sibenik", "crytek_sponza"}) {
        const std::filesystem::path file = dir / name / (std::string(name) + ".obj");
        if (!std::filesystem::exists(file)) continue;
        // A modest count: every ray tests every triangle.
        check_scene_by_brute_force(load_scene(file.string()), 40, 200, {"spatial"});
        ++checked;
    }
    EXPECT_GT(checked, 0u);
}

#ifdef SPACEBVH_HAVE_GMP

// A set of rays with the reference's answers (computed once, in parallel, for every tree checked).
struct ReferenceCase {
    std::string what;
    std::vector<Ray> rays;
    std::vector<std::vector<ReferenceHit>> expected;
};

ReferenceCase reference_case(std::span<const Triangle> triangles, std::string what, std::vector<Ray> rays) {
    ReferenceCase c{std::move(what), std::move(rays), {}};
    c.expected.resize(c.rays.size());
    tbb::parallel_for(size_t(0), c.rays.size(),
                      [&](size_t i) { c.expected[i] = reference_hits(triangles, c.rays[i]); });
    return c;
}

// All hits, counts, first and any hit against the reference on one set of rays.
void check_against_reference(const RayQueries& queries, const ReferenceCase& c, const std::string& tree) {
    const std::span<const Ray> rays = c.rays;
    const HitLists lists = queries.all_hits(rays);
    std::vector<uint32_t> counts(rays.size());
    queries.count_hits(rays, counts);
    std::vector<QueryHit> firsts(rays.size());
    queries.first_hits(rays, firsts);
    std::vector<uint32_t> first_ids(rays.size());
    queries.first_hit_ids(rays, first_ids);
    std::vector<uint8_t> anys(rays.size());
    queries.any_hits(rays, anys);
    size_t wrong = 0, hits = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const std::vector<ReferenceHit>& reference = c.expected[i];
        const std::vector<QueryHit> ours(lists.hits.begin() + ptrdiff_t(lists.offsets[i]),
                                         lists.hits.begin() + ptrdiff_t(lists.offsets[i + 1]));
        hits += reference.size();
        const auto result = same_hits(ours, reference);
        bool ok = bool(result);
        ok = ok && counts[i] == reference.size() && bool(anys[i]) == !reference.empty();
        ok = ok && firsts[i].is_hit() == !reference.empty() &&
             (reference.empty() || firsts[i].primitive == ours[0].primitive);
        ok = ok && first_ids[i] == firsts[i].primitive && (reference.empty() || firsts[i].t == ours[0].t);
        if (!ok && ++wrong <= 5)
            ADD_FAILURE() << c.what << "/" << tree << " ray " << i << ": " << result.message() << " count "
                          << counts[i];
    }
    EXPECT_EQ(wrong, 0u) << c.what << "/" << tree << ": " << rays.size() << " rays, " << hits << " reference hits";
}

void check_scene(const Scene& scene, size_t random_rays, size_t special_rays,
                 const std::vector<std::string>& builders = {"binned", "spatial"}) {
    AABB bounds;
    for (const Triangle& t : scene.triangles) bounds.extend(t.bounds());
    const std::vector<Ray> random = generate_random_rays(bounds, random_rays, 11);
    // Axis-aligned rays from random origins, and from mesh vertices (origin on the surface).
    std::vector<Ray> axis;
    for (size_t i = 0; i < special_rays; ++i) {
        Vec3 dir{0, 0, 0};
        dir[int(i % 3)] = i % 2 ? 1.0f : -1.0f;
        const Vec3 origin =
            i % 4 < 2 ? random[i % random.size()].org : scene.triangles[(i * 7919) % scene.triangles.size()].v1;
        axis.push_back({origin, dir, 0.0f, kInfinity});
    }
    // Containment rays: from random points and from mesh vertices (points on the surface).
    std::vector<Vec3> points;
    std::vector<Ray> containment;
    for (size_t i = 0; i < special_rays; ++i) {
        points.push_back(i % 5 ? random[i % random.size()].org : scene.triangles[i % scene.triangles.size()].v2);
        containment.push_back({points.back(), kContainmentDirection, 0.0f, kInfinity});
    }
    const std::vector<Ray> vertices = rays_through_vertices(scene.triangles, special_rays, 12);
    EXPECT_GT(vertices.size(), special_rays / 2) << scene.name;
    const std::vector<Ray> edges = rays_through_edges(scene.triangles, special_rays, 13);
    EXPECT_GT(edges.size(), special_rays / 4) << scene.name;
    const std::vector<ReferenceCase> cases = {
        reference_case(scene.triangles, scene.name + " random", random),
        reference_case(scene.triangles, scene.name + " vertices", vertices),
        reference_case(scene.triangles, scene.name + " edges", edges),
        reference_case(scene.triangles, scene.name + " axis-aligned", axis),
    };
    const ReferenceCase parity = reference_case(scene.triangles, scene.name + " containment", containment);
    for (const std::string& builder : builders) {
        const RayQueries queries(scene.triangles, spacebvh::build(scene, config_for(builder)));
        for (const ReferenceCase& c : cases) check_against_reference(queries, c, builder);
        // Containment against the brute-force parity count.
        std::vector<uint8_t> inside(points.size());
        queries.contains(points, inside);
        size_t wrong = 0;
        for (size_t i = 0; i < points.size(); ++i) wrong += bool(inside[i]) != (parity.expected[i].size() % 2 == 1);
        EXPECT_EQ(wrong, 0u) << scene.name << "/" << builder << " containment";
    }
}

TEST(Queries, BuiltinScenesMatchTheReference) {
    for (const std::string& name : builtin_scene_names()) {
        const Scene scene = load_scene("builtin:" + name);
        check_scene(scene, 100, 100);
    }
}

TEST(Queries, GridBoxMatchesTheReference) {
    std::vector<Triangle> box = grid_box(4);
    Scene scene;
    scene.name = "grid_box";
    scene.triangles = box;
    check_scene(scene, 500, 500);
}

TEST(Queries, SharedScenesMatchTheReference) {
    const std::filesystem::path dir = std::filesystem::path(SPACEBVH_SHARED_DIR) / "scenes";
    if (!std::filesystem::exists(dir)) GTEST_SKIP() << "no shared scenes at " << dir;
    size_t checked = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (!entry.is_directory()) continue;
        std::string file;
        for (const auto& f : std::filesystem::directory_iterator(entry.path())) {
            const std::string ext = f.path().extension().string();
            if (ext == ".obj" || ext == ".ply") file = f.path().string();
        }
        if (file.empty()) continue;
        const Scene scene = load_scene(file);
        // A modest ray count: the reference tests every triangle for every ray.
        check_scene(scene, 24, 24, {"binned"});
        ++checked;
    }
    EXPECT_GT(checked, 0u);
}

#else

TEST(Queries, ReferenceNeedsGmp) { GTEST_SKIP() << "built without GMP: the exact rational reference is not available"; }

#endif

}  // namespace
}  // namespace spacebvh
