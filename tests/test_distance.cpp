// SPDX-License-Identifier: MIT
// Point queries (distance.hpp) against an independent brute-force reference: every triangle's double
// distance (the minimum over its edges' segments and, where the projection falls inside, its plane),
// then exact rational arithmetic (GMP) for every triangle within a wide margin of the nearest: the
// nearest triangle with ties to the smaller id, and the squared distance within docs/distance.md's
// bound. Hostile sets: lattices through a subdivided box's faces, edges and vertices, points on the
// surface and near vertices, far points.
#include <gtest/gtest.h>

#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/distance.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/scene.hpp"
#include "grid_box.hpp"

#ifdef SPACEBVH_HAVE_GMP
#include <gmpxx.h>
#endif

namespace spacebvh {

using namespace spacebvh::tools;
namespace {

Bvh build_for(std::span<const Triangle> triangles, const std::string& builder) {
    Scene scene;
    scene.name = "test";
    scene.triangles.assign(triangles.begin(), triangles.end());
    return spacebvh::build(scene, config_for(builder));
}

// Points on a lattice of step 1/2 over [-1, 2n + 1]^3: through the box's faces, edges and vertices,
// and the centre, equidistant from six faces.
std::vector<Vec3d> box_lattice(int n) {
    std::vector<Vec3d> out;
    for (int i = -2; i <= 4 * n + 2; ++i)
        for (int j = -2; j <= 4 * n + 2; ++j)
            for (int k = -2; k <= 4 * n + 2; ++k) out.push_back({i * 0.5, j * 0.5, k * 0.5});
    return out;
}

// Points on triangles, near their vertices (2^-20 and 2^-40 away) and far away (1e6).
std::vector<Vec3d> hostile_points(std::span<const Triangle> triangles, size_t count, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0), sym(-1.0, 1.0);
    std::vector<Vec3d> out;
    for (size_t i = 0; i < count; ++i) {
        const Triangle& t = triangles[rng() % triangles.size()];
        const double u = unit(rng), v = unit(rng) * (1.0 - u);
        Vec3d p;
        for (int a = 0; a < 3; ++a) p[size_t(a)] = t.v0[a] + u * (t.v1[a] - t.v0[a]) + v * (t.v2[a] - t.v0[a]);
        out.push_back(p);
        const Vec3 corner = t.vertex(int(rng() % 3));
        for (double offset : {0x1p-20, 0x1p-40})
            out.push_back({corner.x + offset * sym(rng), corner.y + offset * sym(rng), corner.z + offset * sym(rng)});
        out.push_back({1e6 * sym(rng), 1e6 * sym(rng), 1e6 * sym(rng)});
    }
    return out;
}

#ifdef SPACEBVH_HAVE_GMP

struct Q3 {
    mpq_class x, y, z;
};
Q3 q3(double x, double y, double z) { return {mpq_class(x), mpq_class(y), mpq_class(z)}; }
Q3 q3(const Vec3& v) { return q3(v.x, v.y, v.z); }
Q3 operator-(const Q3& a, const Q3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
mpq_class qdot(const Q3& a, const Q3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Q3 qcross(const Q3& a, const Q3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

// The squared distance to the closed segment ab: the clamped projection.
mpq_class segment_d2(const Q3& p, const Q3& a, const Q3& b) {
    const Q3 e = b - a, d = p - a;
    const mpq_class ee = qdot(e, e);
    mpq_class t = ee == 0 ? mpq_class(0) : qdot(d, e) / ee;
    if (t < 0) t = 0;
    if (t > 1) t = 1;
    const Q3 r{d.x - t * e.x, d.y - t * e.y, d.z - t * e.z};
    return qdot(r, r);
}

// The exact squared distance: the plane's where the projection lies inside, else the edges'.
mpq_class exact_d2(const Vec3d& point, const Triangle& t) {
    const Q3 p = q3(point[0], point[1], point[2]), a = q3(t.v0), b = q3(t.v1), c = q3(t.v2);
    const Q3 n = qcross(b - a, c - a);
    const mpq_class s = qdot(p - a, n) / qdot(n, n);
    const Q3 q{p.x - s * n.x, p.y - s * n.y, p.z - s * n.z};
    if (qdot(qcross(b - a, q - a), n) >= 0 && qdot(qcross(c - b, q - b), n) >= 0 && qdot(qcross(a - c, q - c), n) >= 0)
        return s * s * qdot(n, n);
    mpq_class best = segment_d2(p, a, b);
    for (const mpq_class& d : {segment_d2(p, b, c), segment_d2(p, c, a)})
        if (d < best) best = d;
    return best;
}

// The same in double, only to shortlist triangles for the exact comparison (a wide margin covers
// its rounding).
double rough_d2(const Vec3d& point, const Triangle& t) {
    using D = std::array<double, 3>;
    auto sub = [](D a, D b) { return D{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
    auto dot = [](D a, D b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    auto crs = [](D a, D b) {
        return D{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    const D p = point, a{t.v0.x, t.v0.y, t.v0.z}, b{t.v1.x, t.v1.y, t.v1.z}, c{t.v2.x, t.v2.y, t.v2.z};
    auto segment = [&](D u, D v) {
        const D e = sub(v, u), d = sub(p, u);
        const double tt = std::clamp(dot(d, e) / dot(e, e), 0.0, 1.0);
        const D r{d[0] - tt * e[0], d[1] - tt * e[1], d[2] - tt * e[2]};
        return dot(r, r);
    };
    const D n = crs(sub(b, a), sub(c, a));
    const double s = dot(sub(p, a), n) / dot(n, n);
    const D q{p[0] - s * n[0], p[1] - s * n[1], p[2] - s * n[2]};
    if (dot(crs(sub(b, a), sub(q, a)), n) >= 0 && dot(crs(sub(c, b), sub(q, b)), n) >= 0 &&
        dot(crs(sub(a, c), sub(q, c)), n) >= 0)
        return s * s * dot(n, n);
    return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

// The error bound of a returned squared distance (docs/distance.md).
double documented_bound(const Vec3d& p, const Triangle& t) {
    auto len = [](double x, double y, double z) { return std::sqrt(x * x + y * y + z * z); };
    const Vec3 e1 = t.v1 - t.v0, e2 = t.v2 - t.v0, n = cross(e1, e2);
    const double l1 = len(e1.x, e1.y, e1.z), l2 = len(e2.x, e2.y, e2.z), ln = len(n.x, n.y, n.z);
    const double a = len(p[0] - t.v0.x, p[1] - t.v0.y, p[2] - t.v0.z);
    const double s2 = a * a + (l1 + l2) * (l1 + l2);
    const double kappa = std::max(1.0, l1 * l2 / ln);
    return kappa > 0x1p20 ? 4.0 * s2 : 0x1p-39 * kappa * s2 * 1.01;
}

struct Expected {
    uint32_t id = kInvalidIndex;
    mpq_class d2;
};

// The nearest triangle by brute force: a double shortlist, then exact comparison, ties to the smaller id.
Expected reference_nearest(std::span<const Triangle> triangles, const Vec3d& p, const std::vector<double>& rough) {
    double lowest = INFINITY;
    for (double d : rough) lowest = std::min(lowest, d);
    // Far wider than the rough distances' rounding (relative 2^-50 of the point's and the mesh's scale).
    const double margin = 1e-10 * (lowest + p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + 1.0);
    Expected best;
    for (uint32_t i = 0; i < triangles.size(); ++i) {
        if (triangles[i].is_degenerate() || rough[i] > lowest + margin) continue;
        const mpq_class d2 = exact_d2(p, triangles[i]);
        if (best.id == kInvalidIndex || d2 < best.d2) best = {i, d2};
    }
    return best;
}

// Checks every point against the reference; returns the number checked.
size_t check_against_reference(std::span<const Triangle> triangles, const DistanceQueries& queries,
                               std::span<const Vec3d> points) {
    std::vector<ClosestPoint> found(points.size());
    queries.closest_points(points, found);
    size_t wrong = 0;
    for (size_t k = 0; k < points.size(); ++k) {
        std::vector<double> rough(triangles.size(), INFINITY);
        for (size_t i = 0; i < triangles.size(); ++i)
            if (!triangles[i].is_degenerate()) rough[i] = rough_d2(points[k], triangles[i]);
        const Expected expected = reference_nearest(triangles, points[k], rough);
        const ClosestPoint& got = found[k];
        const double error = std::fabs(got.distance * got.distance - expected.d2.get_d());
        const bool ok = got.primitive == expected.id &&
                        error <= documented_bound(points[k], triangles[expected.id]) + 4e-16 * expected.d2.get_d();
        if (!ok && ++wrong <= 5)
            ADD_FAILURE() << "point " << k << " (" << points[k][0] << ", " << points[k][1] << ", " << points[k][2]
                          << "): got triangle " << got.primitive << " at " << got.distance << ", expected "
                          << expected.id << " at " << std::sqrt(expected.d2.get_d());
    }
    EXPECT_EQ(wrong, 0u);
    return points.size();
}

TEST(Distance, BoxLatticeAndHostilePointsMatchTheExactReference) {
    const std::vector<Triangle> box = grid_box(2);
    for (const std::string builder : {"binned", "spatial"}) {
        const DistanceQueries queries(box, build_for(box, builder));
        check_against_reference(box, queries, box_lattice(2));
        check_against_reference(box, queries, hostile_points(box, 300, 7));
    }
}

TEST(Distance, BuiltinScenesMatchTheExactReference) {
    for (const std::string& name : builtin_scene_names()) {
        const Scene scene = load_scene("builtin:" + name);
        const DistanceQueries queries(scene.triangles, spacebvh::build(scene, config_for("spatial")));
        std::vector<Vec3d> points = hostile_points(scene.triangles, 25, 11);
        const AABB box = scene.bounds();
        std::mt19937_64 rng(5);
        std::uniform_real_distribution<double> unit(-0.25, 1.25);
        for (int i = 0; i < 100; ++i) {
            Vec3d p;
            for (int a = 0; a < 3; ++a) p[size_t(a)] = box.lo[a] + unit(rng) * (box.hi[a] - box.lo[a]);
            points.push_back(p);
        }
        SCOPED_TRACE(name);
        check_against_reference(scene.triangles, queries, points);
    }
}

TEST(Distance, SharedBunnyMatchesTheExactReference) {
    const std::filesystem::path file = std::filesystem::path(SPACEBVH_SHARED_DIR) / "scenes/bunny/bunny.obj";
    if (!std::filesystem::exists(file)) GTEST_SKIP() << "no shared bunny at " << file;
    const Scene scene = load_scene(file.string());
    const DistanceQueries queries(scene.triangles, spacebvh::build(scene, config_for("spatial")));
    check_against_reference(scene.triangles, queries, hostile_points(scene.triangles, 60, 3));
}

// Slivers (the third corner 2^-8 .. 2^-22 of the edge's length off its line) in fans around shared
// edges, far from the origin, with points near their lines, edges and vertices: the double bounds'
// hardest cases, and exact ties.
TEST(Distance, SliversFarFromTheOriginMatchTheExactReference) {
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> unit(0.0, 1.0), sym(-1.0, 1.0);
    std::vector<Triangle> slivers;
    // Fans of four slivers around one edge each: points near the edge tie exactly between them.
    for (int i = 0; i < 30; ++i) {
        const Vec3 a(float(1000 + 4 * sym(rng)), float(-2000 + 4 * sym(rng)), float(500 + 4 * sym(rng)));
        const Vec3 e(float(sym(rng)), float(sym(rng)), float(sym(rng)));
        const Vec3 b = a + e;
        for (int k = 0; k < 4; ++k) {
            const float off = std::ldexp(1.0f, -8 - int(rng() % 15));
            const Vec3 c = a + e * float(unit(rng)) + Vec3(off * float(sym(rng)), off * float(sym(rng)), off);
            slivers.push_back(k % 2 ? Triangle{a, b, c} : Triangle{b, a, c});
        }
    }
    std::vector<Vec3d> points;
    for (int i = 0; i < 400; ++i) {
        const Triangle& t = slivers[rng() % slivers.size()];
        const double s = 3.0 * sym(rng), jitter = std::ldexp(1.0, -int(rng() % 40));
        Vec3d p;
        for (int a = 0; a < 3; ++a)
            p[size_t(a)] = t.v0[a] + s * (t.v1[a] - t.v0[a]) + jitter * sym(rng) + (i % 4 == 0 ? 0.0 : 0.01 * sym(rng));
        points.push_back(p);
    }
    for (const std::string builder : {"binned", "spatial"}) {
        const DistanceQueries queries(slivers, build_for(slivers, builder));
        check_against_reference(slivers, queries, points);
    }
}

#endif  // SPACEBVH_HAVE_GMP

TEST(Distance, AnswersAreIdenticalOverRunsAndThreadCounts) {
    const Scene scene = load_scene("builtin:organic");
    const DistanceQueries queries(scene.triangles, spacebvh::build(scene, config_for("binned")));
    std::vector<Vec3d> points = hostile_points(scene.triangles, 3000, 9);
    auto run = [&](int threads) {
        std::vector<ClosestPoint> found(points.size());
        std::vector<double> signed_d(points.size()), winding(points.size());
        tbb::task_arena(threads).execute([&] {
            queries.closest_points(points, found);
            queries.signed_distances(points, signed_d);
            queries.winding_numbers(points, winding, 2.0);
        });
        std::vector<double> flat;
        for (size_t i = 0; i < points.size(); ++i)
            flat.insert(flat.end(), {double(found[i].primitive), found[i].distance, found[i].point[0], found[i].u,
                                     signed_d[i], winding[i]});
        return flat;
    };
    const std::vector<double> one = run(1);
    EXPECT_EQ(one, run(2));
    EXPECT_EQ(one, run(2));
}

TEST(Distance, BoxSignsOccupancyAndWindingNumbers) {
    const std::vector<Triangle> box = grid_box(2);  // [0, 4]^3
    const DistanceQueries queries(box, build_for(box, "spatial"));
    size_t checked = 0;
    for (const Vec3d& p : box_lattice(2)) {
        const bool inside = p[0] > 0 && p[0] < 4 && p[1] > 0 && p[1] < 4 && p[2] > 0 && p[2] < 4;
        const bool outside = p[0] < 0 || p[0] > 4 || p[1] < 0 || p[1] > 4 || p[2] < 0 || p[2] > 4;
        if (!inside && !outside) {
            EXPECT_EQ(queries.distance(p), 0.0);
            EXPECT_EQ(queries.signed_distance(p), 0.0);
            EXPECT_TRUE(std::isinf(queries.winding_number_bound(p).second) ||
                        queries.winding_number_bound(p).second > 0.0);
            continue;
        }
        ++checked;
        EXPECT_EQ(queries.occupancy(p), inside);
        const double d = queries.distance(p);
        EXPECT_EQ(queries.signed_distance(p), inside ? -d : d);
        EXPECT_EQ(queries.signed_distance(p, SignRule::winding), inside ? -d : d);
        const auto [w, bound] = queries.winding_number_bound(p);
        EXPECT_LE(std::fabs(w - (inside ? 1.0 : 0.0)), bound);
        EXPECT_LT(bound, 1e-9);
        EXPECT_NEAR(queries.winding_number(p, 2.0), inside ? 1.0 : 0.0, 0.05);
    }
    EXPECT_GT(checked, 1000u);
}

// The far field to Taylor order 0, 1 and 2 on an open box (winding numbers strictly between 0 and 1
// inside): each value within its bound of the direct sum (itself within its own bound), and the
// total error falling with the order (a single point's need not).
TEST(Distance, HierarchicalWindingNumbersWithinTheirBounds) {
    std::vector<Triangle> box = grid_box(3);   // [0, 6]^3
    box.erase(box.begin(), box.begin() + 18);  // without the face x = 0
    const DistanceQueries queries(box, build_for(box, "binned"));
    double total[3] = {0.0, 0.0, 0.0};
    size_t checked = 0;
    for (const Vec3d& p : box_lattice(3)) {
        if (queries.distance(p) == 0.0) continue;
        const auto [direct, direct_bound] = queries.winding_number_bound(p);
        ASSERT_LT(direct_bound, 1e-9);
        for (int order = 0; order <= 2; ++order) {
            const auto [w, bound] = queries.winding_number_bound(p, 2.0, order);
            EXPECT_EQ(w, queries.winding_number(p, 2.0, order));
            EXPECT_LE(std::fabs(w - direct), bound + direct_bound) << order;
            total[order] += std::fabs(w - direct);
        }
        ++checked;
    }
    EXPECT_GT(checked, 4000u);
    EXPECT_LT(total[2], total[1]);
    EXPECT_LT(total[1], total[0]);
    EXPECT_THROW(queries.winding_number({0, 0, 0}, 2.0, 3), Error);
    EXPECT_THROW(queries.winding_number({0, 0, 0}, 2.0, -1), Error);
}

TEST(Distance, MaxDistanceIsInclusiveAndExact) {
    const std::vector<Triangle> box = grid_box(2);
    const DistanceQueries queries(box, build_for(box, "binned"));
    const Vec3d p{2.0, 2.0, -1.0};  // 1 below the face z = 0
    EXPECT_EQ(queries.closest_point(p, 1.0).distance, 1.0);
    EXPECT_FALSE(queries.closest_point(p, std::nextafter(1.0, 0.0)).found());
    EXPECT_TRUE(std::isinf(queries.distance(p, 0.5)));
    const ClosestPoint c = queries.closest_point(p);
    EXPECT_EQ(c.point[2], 0.0);
}

TEST(Distance, DegenerateTrianglesAreIgnored) {
    std::vector<Triangle> triangles = grid_box(1);
    const uint32_t degenerate = uint32_t(triangles.size());
    triangles.push_back({Vec3(1, 1, -1), Vec3(1, 1, -1), Vec3(1, 1, -1)});  // a point below the box
    const DistanceQueries queries(triangles, build_for(triangles, "binned"));
    const ClosestPoint c = queries.closest_point({1.0, 1.0, -1.0});
    EXPECT_NE(c.primitive, degenerate);
    EXPECT_EQ(c.distance, 1.0);
}

TEST(Distance, BadInputIsAnError) {
    const std::vector<Triangle> box = grid_box(1);
    const DistanceQueries queries(box, build_for(box, "binned"));
    const double nan = std::nan("");
    EXPECT_THROW(queries.distance({nan, 0, 0}), Error);
    EXPECT_THROW(queries.distance({INFINITY, 0, 0}), Error);
    EXPECT_THROW(queries.distance({1e300, 0, 0}), Error);
    EXPECT_THROW(queries.occupancy({1e39, 0, 0}), Error);  // beyond float32, where containment is decided
    EXPECT_THROW(queries.distance({0, 0, 0}, -1.0), Error);
    EXPECT_THROW(queries.distance({0, 0, 0}, nan), Error);
    EXPECT_THROW(queries.winding_number({0, 0, 0}, -1.0), Error);
    EXPECT_THROW(queries.winding_number({0, 0, 0}, nan), Error);
    EXPECT_THROW(queries.winding_number({0, 0, 0}, 1e9), Error);
    std::vector<Vec3d> points{{0, 0, 0}, {0, nan, 0}};
    std::vector<double> out(2);
    try {
        queries.distances(points, out);
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("point 1"), std::string::npos) << e.what();
    }
    std::vector<double> short_out(1);
    EXPECT_THROW(queries.distances(points, short_out), Error);
}

TEST(Distance, EmptyMeshFindsNothing) {
    const std::vector<Triangle> none;
    const DistanceQueries queries(none, Bvh{});
    EXPECT_FALSE(queries.closest_point({0, 0, 0}).found());
    EXPECT_EQ(queries.winding_number({0, 0, 0}), 0.0);
    EXPECT_FALSE(queries.occupancy({0, 0, 0}));
}

}  // namespace
}  // namespace spacebvh
