// SPDX-License-Identifier: MIT
// Float64 meshes traced exactly: the adaptive predicate against GMP rationals, Tracer64 against an
// independent rational ray-triangle reference on meshes at 10^7 offsets and at 10^-6 scale (rays
// exactly through vertices, along and across edges, near-parallel), watertightness of a closed mesh,
// and the tree against the brute-force float64 arbiter (0 differences).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/exact_float64.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/float64.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/tools/verify.hpp"

#ifdef SPACEBVH_HAVE_GMP
#include <gmpxx.h>
#endif

namespace spacebvh {
namespace {

// A closed box surface: each face an n x n grid of squares split into two triangles, corners at
// centre + (i, j, k) * step, every coordinate exact in double (step a power of two, |centre| < 2^24).
std::vector<Triangle64> closed_box(const Vec3d& centre, double step, int n) {
    std::vector<Triangle64> out;
    auto point = [&](double x, double y, double z) {
        return Vec3d{centre[0] + x * step, centre[1] + y * step, centre[2] + z * step};
    };
    const double h = n / 2.0;
    for (int axis = 0; axis < 3; ++axis)
        for (double side : {-h, h})
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    auto corner = [&](int di, int dj) {
                        double c[3];
                        c[axis] = side;
                        c[(axis + 1) % 3] = -h + i + di;
                        c[(axis + 2) % 3] = -h + j + dj;
                        return point(c[0], c[1], c[2]);
                    };
                    // Alternate diagonals so that vertices have differing valence.
                    if ((i + j) % 2 == 0) {
                        out.push_back({corner(0, 0), corner(1, 0), corner(1, 1)});
                        out.push_back({corner(0, 0), corner(1, 1), corner(0, 1)});
                    } else {
                        out.push_back({corner(0, 0), corner(1, 0), corner(0, 1)});
                        out.push_back({corner(1, 0), corner(1, 1), corner(0, 1)});
                    }
                }
    return out;
}

std::vector<double> flatten(const std::vector<Triangle64>& triangles) {
    std::vector<double> xyz;
    for (const Triangle64& t : triangles)
        for (const Vec3d* v : {&t.v0, &t.v1, &t.v2}) xyz.insert(xyz.end(), v->begin(), v->end());
    return xyz;
}
std::vector<uint32_t> identity_indices(size_t triangles) {
    std::vector<uint32_t> indices(3 * triangles);
    for (size_t i = 0; i < indices.size(); ++i) indices[i] = uint32_t(i);
    return indices;
}

Vec3d minus(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

// Rays exactly through the mesh's features: from `eye` (a grid point, so every direction below is
// exact) to each vertex and each edge midpoint, along each edge (origin on the edge's line), and
// through each vertex with the direction nudged by one ulp (near-parallel to faces and edges).
std::vector<Ray64> feature_rays(const std::vector<Triangle64>& triangles, const Vec3d& eye, size_t limit) {
    std::vector<Ray64> rays;
    for (size_t t = 0; t < triangles.size() && rays.size() < limit; ++t) {
        const Vec3d corners[3] = {triangles[t].v0, triangles[t].v1, triangles[t].v2};
        for (int k = 0; k < 3; ++k) {
            const Vec3d& p = corners[k];
            const Vec3d& q = corners[(k + 1) % 3];
            rays.push_back({eye, minus(p, eye)});
            const Vec3d mid{0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])};
            rays.push_back({eye, minus(mid, eye)});
            rays.push_back({p, minus(q, p)});                      // along the edge
            rays.push_back({minus(p, minus(q, p)), minus(q, p)});  // along, starting outside
            Vec3d nudged = minus(p, eye);
            const double largest = std::max({std::fabs(nudged[0]), std::fabs(nudged[1]), std::fabs(nudged[2])});
            nudged[k] = nudged[k] != 0.0 ? std::nextafter(nudged[k], INFINITY) : std::ldexp(largest, -60);
            rays.push_back({eye, nudged});
            // Along the edge, tilted by 2^-60 of its length off the edge's line (near-parallel).
            Vec3d tilted = minus(q, p);
            const double length = std::max({std::fabs(tilted[0]), std::fabs(tilted[1]), std::fabs(tilted[2])});
            tilted[k] += (k == 1 ? -1.0 : 1.0) * std::ldexp(length, -60);
            rays.push_back({minus(p, minus(q, p)), tilted});
        }
    }
    return rays;
}

#ifdef SPACEBVH_HAVE_GMP

mpq_class q(double x) { return mpq_class(x); }
struct Q3 {
    mpq_class x, y, z;
};
Q3 qsub(const Vec3d& a, const Vec3d& b) { return {q(a[0]) - q(b[0]), q(a[1]) - q(b[1]), q(a[2]) - q(b[2])}; }
Q3 qcross(const Q3& a, const Q3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
mpq_class qdot(const Q3& a, const Q3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// The rational reference, written from the definition (not from the predicate): the point
// o + t d with t = n·(v0 - o) / n·d lies in the closed triangle when its barycentric coordinates
// (sub-areas against n) are all >= 0; t must lie in [tmin, tmax]; zero area or d·n = 0: no hit.
std::optional<mpq_class> rational_hit(const Ray64& ray, const Triangle64& tri) {
    const Q3 e1 = qsub(tri.v1, tri.v0), e2 = qsub(tri.v2, tri.v0);
    const Q3 n = qcross(e1, e2);
    if (n.x == 0 && n.y == 0 && n.z == 0) return std::nullopt;
    const Q3 d{q(ray.dir[0]), q(ray.dir[1]), q(ray.dir[2])};
    const mpq_class den = qdot(n, d);
    if (den == 0) return std::nullopt;
    const mpq_class t = qdot(n, qsub(tri.v0, ray.org)) / den;
    if (std::isfinite(ray.tmin) && t < q(ray.tmin)) return std::nullopt;
    if (std::isfinite(ray.tmax) && t > q(ray.tmax)) return std::nullopt;
    const Q3 p{q(ray.org[0]) + t * d.x, q(ray.org[1]) + t * d.y, q(ray.org[2]) + t * d.z};
    const Vec3d* v[3] = {&tri.v0, &tri.v1, &tri.v2};
    for (int k = 0; k < 3; ++k) {
        const Q3 a = qsub(*v[(k + 1) % 3], Vec3d{}), b = qsub(*v[(k + 2) % 3], Vec3d{});
        const Q3 pa{a.x - p.x, a.y - p.y, a.z - p.z}, pb{b.x - p.x, b.y - p.y, b.z - p.z};
        if (sgn(qdot(qcross(pa, pb), n)) < 0) return std::nullopt;
    }
    return t;
}

struct RationalClosest {
    bool hit = false;
    mpq_class t;
};
RationalClosest rational_closest(const std::vector<Triangle64>& triangles, const Ray64& ray) {
    RationalClosest best;
    for (const Triangle64& tri : triangles)
        if (auto t = rational_hit(ray, tri); t && (!best.hit || *t < best.t)) best = {true, *t};
    return best;
}

// Ours agrees with the reference: the same hit or miss; the hit triangle is hit at exactly the
// closest rational t; our rounded t is within a few ulps of it.
void expect_matches_reference(const std::vector<Triangle64>& triangles, const Ray64& ray, const Hit64& ours,
                              const char* what, size_t index) {
    const RationalClosest truth = rational_closest(triangles, ray);
    ASSERT_EQ(ours.is_hit(), truth.hit) << what << " ray " << index;
    if (!truth.hit) return;
    const auto t_of_ours = rational_hit(ray, triangles[ours.primitive]);
    ASSERT_TRUE(t_of_ours) << what << " ray " << index;
    EXPECT_EQ(*t_of_ours, truth.t) << what << " ray " << index;
    const double t = truth.t.get_d();
    EXPECT_NEAR(ours.t, t, 1e-12 * std::fabs(t) + 1e-300) << what << " ray " << index;
}

TEST(Float64Predicate, EdgeFunctionSignEqualsRationalSign) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::uniform_int_distribution<int> exponent(-60, 60);
    std::uniform_int_distribution<int64_t> small(-(1 << 20), 1 << 20);
    auto value = [&] { return std::ldexp(unit(rng), exponent(rng)); };
    auto vec = [&] { return Vec3d{value(), value(), value()}; };
    int exact_zero = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        Vec3d o = vec(), d = vec(), p = vec(), qv = vec();
        if (trial % 2 == 0) {
            // o near 2^40 and p, d small: p - o and q - o need more than 53 bits, so only the
            // expansions see that q = p + s d lies exactly in the plane of o, d and p.
            const int scale = exponent(rng) / 2;
            for (int i = 0; i < 3; ++i) {
                o[i] = std::ldexp(double((int64_t(1) << 40) + small(rng)) + std::ldexp(double(small(rng)), -10), scale);
                p[i] = std::ldexp(std::ldexp(double(small(rng)), -10), scale);
                d[i] = double(small(rng) >> 8);
            }
            const double s = double(small(rng) >> 16);
            for (int i = 0; i < 3; ++i) qv[i] = p[i] + s * d[i];  // exact: small integers times 2^(scale-10)
            if (trial % 4 == 0) qv[trial % 3] = std::nextafter(qv[trial % 3], trial % 8 == 0 ? INFINITY : -INFINITY);
        }
        const double ours = exact::edge_function(o, d, p, qv);
        const Q3 qd{q(d[0]), q(d[1]), q(d[2])};
        const int truth = sgn(qdot(qd, qcross(qsub(p, o), qsub(qv, o))));
        ASSERT_EQ((ours > 0) - (ours < 0), truth) << "trial " << trial;
        exact_zero += truth == 0;
    }
    EXPECT_GT(exact_zero, 1000);  // the exact path met real zeros
}

TEST(Float64Predicate, DegenerateIsExactZeroArea) {
    // Collinear in float64 at a 10^7 offset, and one ulp off it.
    const double big = 1e7;
    Triangle64 collinear{{big, big, big}, {big + 0.5, big + 1.0, big + 1.5}, {big + 1.0, big + 2.0, big + 3.0}};
    EXPECT_TRUE(exact::is_degenerate(collinear));
    Triangle64 sliver = collinear;
    sliver.v2[1] = std::nextafter(sliver.v2[1], INFINITY);
    EXPECT_FALSE(exact::is_degenerate(sliver));
}

struct Placement {
    const char* name;
    Vec3d centre;
    double step;
    int cells;
};
const Placement kPlacements[] = {
    {"offset 1e7, extent 4e-6", {1e7, -1e7, 1e7}, 0x1p-20, 4},
    {"offset 1e7, extent 4", {1e7, 1e7, -1e7}, 1.0, 4},
    {"scale 1e-6 at origin", {0.0, 0.0, 0.0}, 0x1p-22, 4},
    {"scale 1e-6 at 0.75", {0.75, 0.75, -0.75}, 0x1p-22, 4},
};

TEST(Float64Tracer, FeatureRaysEqualRationalReference) {
    for (const Placement& place : kPlacements) {
        const std::vector<Triangle64> triangles = closed_box(place.centre, place.step, place.cells);
        const std::vector<double> xyz = flatten(triangles);
        const std::vector<uint32_t> indices = identity_indices(triangles.size());
        const MeshView mesh = MeshView(xyz, indices).named(place.name);
        const Tracer64 binned(mesh, BuildConfig::for_preset(Preset::binned));
        const Tracer64 sbvh(mesh, BuildConfig::for_preset(Preset::sbvh));
        // From inside (the centre) every ray must hit: the box is closed (watertight at edges and
        // vertices); from outside, rays graze and cross edges.
        const double out = place.step * place.cells * 3;
        for (const Vec3d& eye :
             {place.centre, Vec3d{place.centre[0] + out, place.centre[1] + out / 2, place.centre[2] - out}}) {
            const bool inside = eye == place.centre;
            const std::vector<Ray64> rays = feature_rays(triangles, eye, 300);
            std::vector<Hit64> hits(rays.size());
            binned.intersect(rays, hits);
            std::vector<uint8_t> occluded(rays.size());
            sbvh.occluded(rays, occluded);
            for (size_t i = 0; i < rays.size(); ++i) {
                expect_matches_reference(triangles, rays[i], hits[i], place.name, i);
                const Hit64 other = sbvh.intersect(rays[i]);
                EXPECT_EQ(other.primitive, hits[i].primitive) << place.name << " ray " << i;
                EXPECT_EQ(occluded[i] != 0, hits[i].is_hit()) << place.name << " ray " << i;
                if (inside && rays[i].org == eye) {
                    EXPECT_TRUE(hits[i].is_hit()) << place.name << ": ray " << i << " from inside escaped";
                }
            }
        }
    }
}

TEST(Float64Tracer, RangeEndsAreExact) {
    // A ray whose origin lies exactly on a face at 10^7 (t = 0 is a hit, tmin = next double above 0
    // is not), and tmax exactly at the exit face.
    const std::vector<Triangle64> triangles = closed_box({1e7, 1e7, 1e7}, 0x1p-20, 4);
    const std::vector<double> xyz = flatten(triangles);
    const std::vector<uint32_t> indices = identity_indices(triangles.size());
    const Tracer64 tracer(MeshView(xyz, indices));
    const double face = 1e7 - 2 * 0x1p-20;  // the -x face
    Ray64 ray{{face, 1e7 + 0x1p-22, 1e7 + 0x1p-21}, {1.0, 0.0, 0.0}};
    EXPECT_TRUE(tracer.intersect(ray).is_hit());
    EXPECT_EQ(tracer.intersect(ray).t, 0.0);
    ray.tmin = 0x1p-200;
    const Hit64 far = tracer.intersect(ray);  // the +x face at t = 4 * 2^-20
    ASSERT_TRUE(far.is_hit());
    EXPECT_EQ(far.t, 4 * 0x1p-20);
    ray.tmax = 4 * 0x1p-20;
    EXPECT_TRUE(tracer.occluded(ray));
    ray.tmax = std::nextafter(4 * 0x1p-20, 0.0);
    EXPECT_FALSE(tracer.occluded(ray));
    for (const Ray64& r : {ray}) expect_matches_reference(triangles, r, tracer.intersect(r), "range", 0);
}

#endif  // SPACEBVH_HAVE_GMP

// The tree never loses a hit: tree answers equal the brute-force float64 arbiter bit for bit, for
// random rays and rays at the vertices of the built-in scenes moved to 10^7 and scaled to 10^-6.
TEST(Float64Tracer, TreeEqualsBruteForceOnScaledScenes) {
    for (const char* name : {"interior", "organic"}) {
        const tools::Scene scene = tools::make_builtin_scene(name);
        for (const auto& [scale, offset] :
             {std::pair{1e-6 / scene.diagonal(), 0.0}, std::pair{1.0 / scene.diagonal(), 1e7}}) {
            std::vector<double> xyz;
            for (const Triangle& t : scene.triangles)
                for (Vec3 v : {t.v0, t.v1, t.v2})
                    for (int i = 0; i < 3; ++i) xyz.push_back(offset + double(v[i]) * scale);
            const std::vector<uint32_t> indices = identity_indices(scene.triangles.size());
            const MeshView mesh = MeshView(xyz, indices).named(name);
            const std::vector<Triangle64> triangles = mesh.triangles64();
            std::mt19937_64 rng(11);
            std::uniform_real_distribution<double> unit(-1.0, 1.0);
            std::uniform_int_distribution<size_t> pick(0, triangles.size() - 1);
            std::vector<Ray64> rays;
            const Vec3d centre{offset, offset, offset};
            for (int i = 0; i < 60; ++i) {
                const Vec3d org{centre[0] + unit(rng) * scale * 0.3, centre[1] + unit(rng) * scale * 0.3,
                                centre[2] + unit(rng) * scale * 0.3};
                rays.push_back({org, {unit(rng), unit(rng), unit(rng)}});
                const Vec3d& target = triangles[pick(rng)].v1;  // at a vertex (rounded direction)
                rays.push_back({org, minus(target, org)});
            }
            std::vector<Hit64> truth(rays.size());
            for (size_t i = 0; i < rays.size(); ++i) truth[i] = tools::arbiter_closest_hit(triangles, rays[i]);
            for (Preset preset : {Preset::binned, Preset::sbvh}) {
                const Tracer64 tracer(mesh, BuildConfig::for_preset(preset));
                for (size_t i = 0; i < rays.size(); ++i) {
                    const Hit64 ours = tracer.intersect(rays[i]);
                    ASSERT_EQ(ours.primitive, truth[i].primitive) << name << " " << to_string(preset) << " ray " << i;
                    ASSERT_EQ(ours.t, truth[i].t) << name << " ray " << i;
                    ASSERT_EQ(tracer.occluded(rays[i]), truth[i].is_hit());
                }
            }
        }
    }
}

// The large-coordinate case of the trimesh drop-in: a ray 0.01 off a surface at 5e5, cast away
// from it, does not hit (in float32 the origin rounds onto the surface: ulp(5e5) = 1/32).
TEST(Float64Tracer, RayJustOffFarSurfaceCastAwayMisses) {
    const double z = 5e5;
    const std::vector<double> xyz = {-1e3, -1e3, z, 1e3, -1e3, z, 1e3, 1e3, z, -1e3, 1e3, z};
    const std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3};
    const Tracer64 tracer(MeshView(xyz, indices));
    EXPECT_FALSE(tracer.intersect(Ray64{{0.3, 0.2, z + 0.01}, {0.0, 0.0, 1.0}}).is_hit());
    EXPECT_FALSE(tracer.occluded(Ray64{{0.3, 0.2, z - 0.01}, {0.1, 0.0, -1.0}}));
    const Hit64 back = tracer.intersect(Ray64{{0.3, 0.2, z + 0.01}, {0.0, 0.0, -1.0}});
    ASSERT_TRUE(back.is_hit());
    EXPECT_NEAR(back.t, 0.01, 1e-9);
}

// The boxes hold the float64 triangles, not only their float32 stand-ins: a triangle whose top edge
// lies 2^-30 above the stand-in's (which rounds it down onto y = 0.5 in the local frame) is hit by a
// ray passing between the two.
TEST(Float64Tracer, BoxesContainTheFloat64Triangles) {
    const double delta = 0x1p-30;
    const std::vector<double> xyz = {0, 0, 0, 0.5, 1 + delta, 0, 0, 1 + delta, 0};
    const std::vector<uint32_t> indices = {0, 1, 2};
    const MeshView mesh(xyz, indices);
    EXPECT_EQ(local_frame_mesh(mesh).triangles[0].v1.y, 0.5f);
    const Tracer64 tracer(mesh);
    const Ray64 ray{{0.1, 1 + delta / 2, 5}, {0, 0, -1}};
    const Hit64 hit = tracer.intersect(ray);
    ASSERT_TRUE(hit.is_hit());
    EXPECT_EQ(hit.t, 5.0);
    EXPECT_TRUE(tracer.occluded(ray));
    EXPECT_GE(double(tracer.bvh().root().bounds.hi.y) + tracer.frame_origin()[1], 1 + delta);
}

// A float64 triangle whose float32 stand-in has zero area (tiny beside the rest of the mesh) is
// still found; an exactly collinear one never is.
TEST(Float64Tracer, TinyTriangleBesideLargeMeshIsHit) {
    const double tiny = 1e-9;
    const std::vector<double> xyz = {
        0,  0,  0,  100,       0,  0,  0,  100,       0,    // large
        20, 20, 10, 20 + tiny, 20, 10, 20, 20 + tiny, 10,   // tiny: below float resolution at 30 from the centre
        0,  0,  20, 1,         1,  20, 2,  2,         20};  // collinear
    const std::vector<uint32_t> indices = identity_indices(3);
    const Tracer64 tracer(MeshView(xyz, indices));
    EXPECT_GE(tracer.unindexed_count(), 1u);
    const Hit64 hit = tracer.intersect(Ray64{{20 + tiny / 4, 20 + tiny / 4, 30}, {0, 0, -1}});
    ASSERT_TRUE(hit.is_hit());
    EXPECT_EQ(hit.primitive, 1u);
    EXPECT_NEAR(hit.t, 20.0, 1e-12);
    const Hit64 beside = tracer.intersect(Ray64{{20 + tiny, 20 + tiny, 30}, {0, 0, -1}});
    EXPECT_EQ(beside.primitive, 0u);  // misses the tiny one, hits the large one below
    EXPECT_FALSE(tracer.intersect(Ray64{{1, 1, 30}, {0, 0, -1}}).primitive == 2u);
}

TEST(Float64Tracer, OutOfRangeInputIsAClearError) {
    const std::vector<double> xyz = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const std::vector<uint32_t> indices = {0, 1, 2};
    const Tracer64 tracer(MeshView(xyz, indices));
    EXPECT_THROW((void)tracer.intersect(Ray64{{NAN, 0, 0}, {0, 0, 1}}), Error);
    EXPECT_THROW((void)tracer.intersect(Ray64{{0, 0, 0}, {0, 0, 0}}), Error);
    EXPECT_THROW((void)tracer.intersect(Ray64{{0, 0, 0}, {0, 0, 1}, NAN}), Error);
    const std::vector<Ray64> rays = {Ray64{{0, 0, 1}, {0, 0, -1}}, Ray64{{0, 0, 1}, {1e-300, 0, -1}}};
    std::vector<Hit64> hits(2);
    try {
        tracer.intersect(rays, hits);
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("ray 1"), std::string::npos) << e.what();
    }
    // A tree built over the global float triangles instead of the local-frame stand-ins.
    const std::vector<double> far_xyz = {1e7,     0, 0, 1e7 + 1,  0, 0, 1e7,     1, 0,
                                         1e7 + 9, 0, 0, 1e7 + 10, 0, 0, 1e7 + 9, 1, 0};
    const std::vector<uint32_t> two = {0, 1, 2, 3, 4, 5};
    const MeshView far(far_xyz, two);
    EXPECT_THROW(Tracer64(far, build(MeshView(far.triangles()), Quality::fast)), Error);
    EXPECT_NO_THROW(Tracer64(far, build(MeshView(local_frame_mesh(far).triangles), Quality::fast)));
    const std::vector<double> tiny_xyz = {0, 0, 0, 1, 0, 0, 0, 1, 1e-70};
    try {
        Tracer64 bad(MeshView(tiny_xyz, indices).named("tiny"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("mesh 'tiny': triangle 0"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace spacebvh
