// SPDX-License-Identifier: MIT
// The binary tracer (include/spacebvh/trace.hpp): watertightness on closed meshes, axis-parallel rays
// and rays in slab planes, the ray segment [tmin, tmax], degenerate triangles, statistics, the batch
// API, and unusual trees (empty, a single leaf, very deep), each checked against the exact arbiter of
// docs/rays.md where a brute-force answer is affordable.
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "core/exact_triangle.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/verify.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

// ---------------------------------------------------------------------------------------------------
// Closed meshes built from indexed vertices, so that shared vertices are bit-identical.

struct IndexedMesh {
    std::vector<Vec3> vertices;
    std::vector<std::array<uint32_t, 3>> faces;

    Scene scene(const std::string& name) const {
        Scene s;
        s.name = name;
        for (const auto& f : faces) s.triangles.push_back({vertices[f[0]], vertices[f[1]], vertices[f[2]]});
        return s;
    }
};

// An icosphere (subdivided icosahedron) with a bumpy radius and an off-axis rotation: nothing lines up
// with the coordinate axes.
IndexedMesh bumpy_icosphere(int subdivisions) {
    const float p = (1.0f + std::sqrt(5.0f)) / 2.0f;
    IndexedMesh mesh;
    mesh.vertices = {{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
                     {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
    mesh.faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                  {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                  {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (Vec3& v : mesh.vertices) v = normalize(v);
    for (int s = 0; s < subdivisions; ++s) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
        auto midpoint = [&](uint32_t a, uint32_t b) {
            const auto key = std::minmax(a, b);
            auto it = midpoints.find(key);
            if (it != midpoints.end()) return it->second;
            mesh.vertices.push_back(normalize(mesh.vertices[a] + mesh.vertices[b]));
            return midpoints[key] = uint32_t(mesh.vertices.size() - 1);
        };
        std::vector<std::array<uint32_t, 3>> next;
        for (const auto& f : mesh.faces) {
            const uint32_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
            next.push_back({f[0], ab, ca});
            next.push_back({f[1], bc, ab});
            next.push_back({f[2], ca, bc});
            next.push_back({ab, bc, ca});
        }
        mesh.faces = std::move(next);
    }
    const float c = std::cos(0.7f), s = std::sin(0.7f), c2 = std::cos(0.3f), s2 = std::sin(0.3f);
    for (Vec3& v : mesh.vertices) {
        const float r = 3.0f * (1.0f + 0.2f * std::sin(5.0f * v.x) * std::cos(4.0f * v.y) + 0.1f * v.z);
        Vec3 q = v * r;
        q = {c * q.x - s * q.y, s * q.x + c * q.y, q.z};      // about z
        q = {q.x, c2 * q.y - s2 * q.z, s2 * q.y + c2 * q.z};  // about x
        v = q + Vec3(0.25f, -0.5f, 1.0f);
    }
    return mesh;
}

// A cube [lo, hi]^3 with each face an n x n grid of quads: axis-aligned faces on node planes.
IndexedMesh grid_cube(int n, float lo, float hi) {
    IndexedMesh mesh;
    std::map<std::tuple<int, int, int>, uint32_t> index;
    auto vertex = [&](int i, int j, int k) {
        const auto key = std::make_tuple(i, j, k);
        auto it = index.find(key);
        if (it != index.end()) return it->second;
        auto coord = [&](int a) { return lo + (hi - lo) * float(a) / float(n); };
        mesh.vertices.push_back({coord(i), coord(j), coord(k)});
        return index[key] = uint32_t(mesh.vertices.size() - 1);
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int side : {0, n})
            for (int u = 0; u < n; ++u)
                for (int v = 0; v < n; ++v) {
                    auto at = [&](int a, int b) {
                        int c[3];
                        c[axis] = side;
                        c[(axis + 1) % 3] = a;
                        c[(axis + 2) % 3] = b;
                        return vertex(c[0], c[1], c[2]);
                    };
                    const uint32_t a = at(u, v), b = at(u + 1, v), c = at(u + 1, v + 1), d = at(u, v + 1);
                    // Alternate the diagonal so both diagonal directions occur.
                    if ((u + v) % 2) {
                        mesh.faces.push_back({a, b, c});
                        mesh.faces.push_back({a, c, d});
                    } else {
                        mesh.faces.push_back({a, b, d});
                        mesh.faces.push_back({b, c, d});
                    }
                }
    return mesh;
}

// A closed, very pointed double cone: long sliver triangles meeting at two apexes.
IndexedMesh sliver_spindle(int segments) {
    IndexedMesh mesh;
    mesh.vertices.push_back({0.1f, 0.2f, -40.0f});
    mesh.vertices.push_back({-0.1f, 0.05f, 40.0f});
    for (int i = 0; i < segments; ++i) {
        const float a = 2.0f * std::numbers::pi_v<float> * float(i) / float(segments);
        mesh.vertices.push_back({0.7f * std::cos(a), 0.5f * std::sin(a), 0.3f * std::sin(3.0f * a)});
    }
    for (int i = 0; i < segments; ++i) {
        const uint32_t a = 2 + uint32_t(i), b = 2 + uint32_t((i + 1) % segments);
        mesh.faces.push_back({0, b, a});
        mesh.faces.push_back({1, a, b});
    }
    return mesh;
}

// Rays from points inside a closed mesh aimed at every vertex, every edge's midpoint and a random
// point on every edge. A closed mesh cannot be left without crossing it, so each ray must hit and be
// occluded; a ray that passes exactly through its target vertex (dir = target - org computed
// without rounding) must hit at t <= 1. (When dir was rounded the ray passes a hair beside the
// vertex and, where it grazes a curved surface, may rightly cross it only further on: the exact
// arbiter agrees.) Returns a description of failures.
std::string rays_escaping(const std::vector<Vec3>& vertices, const std::vector<std::array<uint32_t, 3>>& faces,
                          const std::vector<Vec3>& inside, const Tracer& tracer, size_t* ray_count = nullptr) {
    std::set<std::pair<uint32_t, uint32_t>> edges;
    for (const auto& f : faces)
        for (int e = 0; e < 3; ++e) edges.insert(std::minmax(f[e], f[(e + 1) % 3]));
    std::vector<Ray> rays;
    std::vector<uint8_t> at_vertex;
    size_t origin = 0;
    auto aim = [&](Vec3 from, Vec3 target, bool vertex) {
        Ray ray;
        ray.org = from;
        ray.dir = target - ray.org;
        rays.push_back(ray);
        const bool exact = double(from.x) + double(ray.dir.x) == double(target.x) &&
                           double(from.y) + double(ray.dir.y) == double(target.y) &&
                           double(from.z) + double(ray.dir.z) == double(target.z);
        at_vertex.push_back(vertex && exact);
    };
    for (const Vec3& from : inside)
        for (const Vec3& v : vertices) aim(from, v, true);
    SplitMix64 rng(2024);
    for (const auto& [a, b] : edges) {
        const Vec3 p = vertices[a], q = vertices[b];
        aim(inside[origin++ % inside.size()], (p + q) * 0.5f, false);
        aim(inside[origin++ % inside.size()], p + (q - p) * rng.uniform(), false);
    }
    std::vector<Hit> hits(rays.size());
    std::vector<uint8_t> occluded(rays.size());
    tracer.intersect(rays, hits);
    tracer.occluded(rays, occluded);
    size_t missed = 0, not_occluded = 0, too_far = 0;
    std::ostringstream first;
    for (size_t i = 0; i < rays.size(); ++i) {
        const bool miss = !hits[i].is_hit();
        const bool far = !miss && at_vertex[i] && hits[i].t > 1.0f + 1e-5f;
        missed += miss;
        not_occluded += !occluded[i];
        too_far += far;
        if ((miss || far || !occluded[i]) && missed + not_occluded + too_far <= 3)
            first << " ray " << i << " org (" << rays[i].org.x << ", " << rays[i].org.y << ", " << rays[i].org.z
                  << ") dir (" << rays[i].dir.x << ", " << rays[i].dir.y << ", " << rays[i].dir.z << ") t " << hits[i].t
                  << ";";
    }
    if (ray_count) *ray_count = rays.size();
    if (missed + not_occluded + too_far == 0) return "";
    return std::to_string(missed) + " missed, " + std::to_string(not_occluded) + " not occluded, " +
           std::to_string(too_far) + " hit beyond the target vertex, of " + std::to_string(rays.size()) +
           " rays:" + first.str();
}

// Every kernel make_tracer offers on this CPU, aliases ("auto", "bvh8", ...) left out.
std::vector<std::string> distinct_kernels() {
    std::vector<std::string> kernels;
    for (const std::string& name : kernel_names())
        if (name.find('-') != std::string::npos || name == "binary") kernels.push_back(name);
    return kernels;
}

// The kernels a builder's parametrised tests check: all of them on `spatial` trees (clipped boxes,
// references shared between leaves), the reference and the default kernel on the others (the suite's
// time goes to every kernel once, not to every pair).
std::vector<std::string> kernels_for(const std::string& builder) {
    if (builder == "spatial") return distinct_kernels();
    return {"binary", "auto"};
}

// Closest hit and occlusion of every kernel on `bvh` (single-ray calls and batches) against the
// arbiter on every ray; returns a description of disagreements.
std::string disagreements_with_arbiter(const Scene& scene, const Bvh& bvh, const std::vector<Ray>& rays,
                                       const std::vector<std::string>& kernels = distinct_kernels()) {
    const float diagonal = scene.diagonal();
    std::vector<HitRecord> truth(rays.size());
    std::vector<uint8_t> truth_occluded(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        truth[i] = arbiter_closest_hit(scene, rays[i]);
        truth_occluded[i] = arbiter_occlusion(scene, rays[i]).is_hit();
    }
    std::ostringstream text;
    size_t wrong = 0;
    for (const std::string& kernel : kernels) {
        const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, bvh);
        std::vector<Hit> batch_hits(rays.size());
        std::vector<uint8_t> batch_occluded(rays.size());
        tracer->intersect(rays, batch_hits);
        tracer->occluded(rays, batch_occluded);
        for (size_t i = 0; i < rays.size(); ++i) {
            const HitRecord single = to_record(tracer->intersect(rays[i])), batch = to_record(batch_hits[i]);
            const bool single_occluded = tracer->occluded(rays[i]);
            if (hits_agree(single, truth[i], rays[i], diagonal) && hits_agree(batch, truth[i], rays[i], diagonal) &&
                single_occluded == bool(truth_occluded[i]) && bool(batch_occluded[i]) == bool(truth_occluded[i]))
                continue;
            if (wrong++ < 4)
                text << " " << kernel << " ray " << i << " org (" << rays[i].org.x << ", " << rays[i].org.y << ", "
                     << rays[i].org.z << ") dir (" << rays[i].dir.x << ", " << rays[i].dir.y << ", " << rays[i].dir.z
                     << ") [" << rays[i].tmin << ", " << rays[i].tmax << "]: ours t=" << single.t << "/" << batch.t
                     << " prim=" << single.primitive << "/" << batch.primitive << " occl=" << single_occluded << "/"
                     << int(batch_occluded[i]) << ", arbiter t=" << truth[i].t << " prim=" << truth[i].primitive
                     << " occl=" << int(truth_occluded[i]) << ";";
        }
    }
    if (wrong == 0) return "";
    return std::to_string(wrong) + " wrong (rays x kernels, of " + std::to_string(rays.size()) + " rays):" + text.str();
}

Bvh build_with(const Scene& scene, const std::string& builder, uint32_t max_leaf = 8) {
    BuildConfig options = config_for(builder);
    options.limits.max_leaf_size = max_leaf;
    return spacebvh::build(scene, options);
}

std::string param_name(const ::testing::TestParamInfo<std::string>& info) {
    std::string text = info.param;
    for (char& c : text)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return text;
}

// Rebuilds the shared vertices and faces of the welded triangle soup of builtin:organic (moved by
// `offset`; equal vertices stay equal) and checks that it is closed.
void organic_mesh(const Scene& scene, std::vector<Vec3>& vertices, std::vector<std::array<uint32_t, 3>>& faces) {
    std::map<std::tuple<uint32_t, uint32_t, uint32_t>, uint32_t> index;
    auto id = [&](Vec3 v) {
        uint32_t bits[3];
        std::memcpy(bits, &v, sizeof bits);
        const auto key = std::make_tuple(bits[0], bits[1], bits[2]);
        auto it = index.find(key);
        if (it != index.end()) return it->second;
        vertices.push_back(v);
        return index[key] = uint32_t(vertices.size() - 1);
    };
    for (const Triangle& t : scene.triangles) faces.push_back({id(t.v0), id(t.v1), id(t.v2)});
    // A closed genus-0 triangle mesh has V - E + F = 2, i.e. V = F / 2 + 2.
    ASSERT_EQ(vertices.size(), faces.size() / 2 + 2) << "organic is not a closed, welded mesh";
}

class TracerWithBuilder : public ::testing::TestWithParam<std::string> {};

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Watertightness.

// No ray from inside the closed builtin `organic` mesh slips through at a vertex or along an edge.
TEST_P(TracerWithBuilder, OrganicMeshIsWatertight) {
    const Scene scene = load_scene("builtin:organic");
    std::vector<Vec3> vertices;
    std::vector<std::array<uint32_t, 3>> faces;
    organic_mesh(scene, vertices, faces);

    const Bvh bvh = build_with(scene, GetParam());
    const std::vector<Vec3> inside = {{0, 0, 0}, {0.5f, -0.3f, 0.2f}, {-1.0f, 0.7f, -0.4f}, {0.3f, 1.1f, 0.9f}};
    for (const std::string& kernel : kernels_for(GetParam())) {
        size_t rays = 0;
        EXPECT_EQ(rays_escaping(vertices, faces, inside, *make_tracer(kernel, scene, bvh), &rays), "") << kernel;
        EXPECT_GT(rays, 450000u);
    }
}

// The same far from the world's origin (about 1000 times the mesh's size away): a ray's origin times
// its inverse direction is then far larger than the distances to the boxes it enters, the case the
// single-ray kernels' fused box test widens its offsets for (wide_kernel.inl, RayBoxes).
TEST(Tracer, OrganicMeshFarFromTheOriginIsWatertight) {
    SceneTransform transform;
    transform.translate = {2500.0f, -1700.0f, 900.0f};
    const Scene scene = load_scene("builtin:organic", transform);
    std::vector<Vec3> vertices;
    std::vector<std::array<uint32_t, 3>> faces;
    organic_mesh(scene, vertices, faces);
    const Bvh bvh = build_with(scene, "spatial");
    const std::vector<Vec3> inside = {transform.translate, transform.translate + Vec3(0.5f, -0.3f, 0.2f)};
    for (const std::string& kernel : distinct_kernels())
        EXPECT_EQ(rays_escaping(vertices, faces, inside, *make_tracer(kernel, scene, bvh)), "") << kernel;
}

// The same on hand-made closed meshes: a bumpy rotated icosphere, axis-aligned and rotated grid cubes
// (faces on node planes) and a spindle of long slivers.
TEST_P(TracerWithBuilder, HandMadeClosedMeshesAreWatertight) {
    IndexedMesh rotated_cube = grid_cube(12, -2.0f, 2.0f);
    for (Vec3& v : rotated_cube.vertices) {
        const float c = std::cos(0.4f), s = std::sin(0.4f);
        v = {c * v.x + s * v.z, v.y, -s * v.x + c * v.z};
        v = {v.x, 0.8f * v.y - 0.6f * v.z, 0.6f * v.y + 0.8f * v.z};
    }
    const std::vector<std::tuple<std::string, IndexedMesh, std::vector<Vec3>>> meshes = {
        {"icosphere", bumpy_icosphere(4), {{0, 0, 0}, {0.25f, -0.5f, 1.0f}, {1.0f, 0.0f, 0.5f}, {-0.5f, -1.0f, 1.5f}}},
        {"grid cube", grid_cube(16, -1.0f, 3.0f), {{1, 1, 1}, {0, 0, 0}, {2.5f, -0.5f, 1.0f}, {1, 2, 1}}},
        {"rotated cube", rotated_cube, {{0, 0, 0}, {0.5f, 0.5f, -0.5f}, {-1.0f, 0.3f, 0.2f}}},
        {"spindle", sliver_spindle(64), {{0, 0, 0}, {0, 0.1f, 0}, {0, 0.1f, -20.0f}, {0, 0.1f, 30.0f}}},
    };
    for (const auto& [name, mesh, inside] : meshes) {
        SCOPED_TRACE(name);
        const Scene scene = mesh.scene(name);
        for (uint32_t max_leaf : {1u, 8u}) {
            const Bvh bvh = build_with(scene, GetParam(), max_leaf);
            for (const std::string& kernel : kernels_for(GetParam()))
                EXPECT_EQ(rays_escaping(mesh.vertices, mesh.faces, inside, *make_tracer(kernel, scene, bvh)), "")
                    << kernel << ", max leaf " << max_leaf;
        }
    }
}

// The smallest case behind a leak at a vertex: a ray from the origin whose direction is a vertex of a
// triangle passes exactly through that vertex, and vertices count as inside (closed triangles), so the
// exact test, the arbiter and the tracer must all report a hit at t = 1. These six triangles share the
// vertex v; they are the fan around vertex 60 of builtin:organic seen from its centre.
TEST(Tracer, RayThroughASharedVertexHitsItsTriangles) {
    const Vec3 v{-0x1.5b89eap+1f, -0x1.5b89ecp+1f, -0x1.818f4p-1f};
    Scene fan;
    fan.name = "fan";
    fan.triangles = {
        {{-0x1.5d9a9cp+1f, -0x1.5d9a9cp+1f, -0x1.9eced6p-1f}, v, {-0x1.61f24ep+1f, -0x1.52fe04p+1f, -0x1.84d416p-1f}},
        {v, {-0x1.5ec866p+1f, -0x1.5ec868p+1f, -0x1.6a5158p-1f}, {-0x1.660db6p+1f, -0x1.56e384p+1f, -0x1.6e2be6p-1f}},
        {v, {-0x1.660db6p+1f, -0x1.56e384p+1f, -0x1.6e2be6p-1f}, {-0x1.61f24ep+1f, -0x1.52fe04p+1f, -0x1.84d416p-1f}},
        {{-0x1.5d9a9cp+1f, -0x1.5d9a9cp+1f, -0x1.9eced6p-1f}, {-0x1.550234p+1f, -0x1.640d46p+1f, -0x1.872428p-1f}, v},
        {v, {-0x1.550234p+1f, -0x1.640d46p+1f, -0x1.872428p-1f}, {-0x1.57ap+1f, -0x1.66d28cp+1f, -0x1.6ef53p-1f}},
        {v, {-0x1.57ap+1f, -0x1.66d28cp+1f, -0x1.6ef53p-1f}, {-0x1.5ec866p+1f, -0x1.5ec868p+1f, -0x1.6a5158p-1f}},
    };
    Ray ray;
    ray.org = {0, 0, 0};
    ray.dir = v;  // exactly through v
    size_t exact_hits = 0;
    for (const Triangle& t : fan.triangles) exact_hits += intersect_triangle_exact(ray, t).has_value();
    EXPECT_GT(exact_hits, 0u) << "intersect_triangle_exact: no triangle containing v is hit by a ray through v";
    const HitRecord truth = arbiter_closest_hit(fan, ray);
    EXPECT_TRUE(truth.is_hit()) << "the arbiter lets the ray slip through the fan at its vertex";
    const Tracer tracer(fan, build_with(fan, "binned"), Kernel::binary);
    const Hit hit = tracer.intersect(ray);
    ASSERT_TRUE(hit.is_hit()) << "the tracer lets the ray slip through the fan at its vertex";
    EXPECT_NEAR(hit.t, 1.0f, 1e-6f);
    EXPECT_TRUE(tracer.occluded(ray));
}

// ---------------------------------------------------------------------------------------------------
// Axis-parallel rays and rays in slab planes.

namespace {

// Unit-ish boxes on an integer grid (some sharing faces), a flat triangle in z = 0 and a wall in x = 5:
// every node plane is at an integer or half-integer coordinate.
Scene axis_aligned_scene() {
    IndexedMesh all;
    auto add_box = [&](Vec3 lo, Vec3 hi) {
        IndexedMesh box = grid_cube(1, 0.0f, 1.0f);
        const uint32_t base = uint32_t(all.vertices.size());
        for (Vec3 v : box.vertices) all.vertices.push_back(lo + v * (hi - lo));
        for (auto f : box.faces) all.faces.push_back({base + f[0], base + f[1], base + f[2]});
    };
    add_box({0, 0, 0}, {1, 1, 1});
    add_box({1, 0, 0}, {2, 1, 1});  // shares the face x = 1
    add_box({0, 2, 0}, {1, 3, 2});
    add_box({2.5f, 0.5f, -1}, {3, 1.5f, 0});
    Scene scene = all.scene("axis_aligned");
    scene.triangles.push_back({{-1, -1, 0}, {4, -1, 0}, {-1, 4, 0}});           // flat in z = 0
    scene.triangles.push_back({{5, -1, -1}, {5, 4, -1}, {5, -1, 3}});           // flat in x = 5
    scene.triangles.push_back({{-2, 0.5f, -1}, {-2, 0.5f, 2}, {-2, 3, 0.5f}});  // flat in x = -2
    return scene;
}

}  // namespace

// Rays along the axes (zero direction components written as +0.0f and -0.0f) from grid points on and
// between the node planes, many of them lying exactly in a box face or a flat leaf's plane: every
// answer equals the arbiter's.
TEST_P(TracerWithBuilder, AxisParallelRaysMatchTheArbiter) {
    const Scene scene = axis_aligned_scene();
    std::vector<Ray> rays;
    const float coords[] = {-1.5f, -1.0f, 0.0f, 0.5f, 1.0f, 1.5f, 2.0f, 2.5f, 3.0f, 4.5f, 6.0f};
    for (float x : coords)
        for (float y : coords)
            for (float z : coords)
                for (int axis = 0; axis < 3; ++axis)
                    for (float sign : {1.0f, -1.0f})
                        for (int zeros = 0; zeros < 4; ++zeros) {
                            Ray ray;
                            ray.org = {x, y, z};
                            Vec3 dir(0.0f);
                            dir[(axis + 1) % 3] = (zeros & 1) ? -0.0f : 0.0f;
                            dir[(axis + 2) % 3] = (zeros & 2) ? -0.0f : 0.0f;
                            dir[axis] = sign * (zeros == 3 ? 2.5f : 1.0f);  // also a non-unit length
                            ray.dir = dir;
                            rays.push_back(ray);
                        }
    ASSERT_TRUE(std::signbit(rays[1].dir.y) || std::signbit(rays[1].dir.z));
    for (uint32_t max_leaf : {1u, 4u}) {
        const Bvh tree = build_with(scene, GetParam(), max_leaf);
        EXPECT_EQ(disagreements_with_arbiter(scene, tree, rays, kernels_for(GetParam())), "")
            << "max leaf " << max_leaf;
    }
}

// Explicit cases: a ray in the plane of a flat leaf box is not stopped by it, and hits what lies beyond.
TEST(Tracer, RayInTheSlabPlaneOfAFlatNode) {
    Scene scene;
    scene.name = "flat";
    scene.triangles = {{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}},      // 0: in z = 0
                       {{6, -1, -1}, {6, 5, -1}, {6, 2, 3}}};  // 1: in x = 6, crossing z = 0
    const Tracer tracer(scene, build_with(scene, "binned", 1), Kernel::binary);
    for (float zero : {0.0f, -0.0f}) {
        Ray ray;
        ray.org = {-1.0f, 1.0f, 0.0f};  // in the plane z = 0
        ray.dir = {1.0f, zero, zero};
        const Hit hit = tracer.intersect(ray);
        EXPECT_EQ(hit.primitive, 1u);
        EXPECT_EQ(hit.t, 7.0f);
        // Along the edge y = 0 of triangle 0, in its plane: still only the wall.
        ray.org = {-1.0f, 0.0f, 0.0f};
        EXPECT_EQ(tracer.intersect(ray).primitive, 1u);
        // Straight down through triangle 0's interior and along its edge, from above.
        Ray down;
        down.org = {1.0f, 1.0f, 5.0f};
        down.dir = {zero, zero, -1.0f};
        EXPECT_EQ(tracer.intersect(down).primitive, 0u);
        EXPECT_EQ(tracer.intersect(down).t, 5.0f);
        down.org = {2.0f, 0.0f, 5.0f};
        EXPECT_EQ(tracer.intersect(down).primitive, 0u);
        down.org = {2.0f, -0.0f, 5.0f};
        EXPECT_EQ(tracer.intersect(down).primitive, 0u);
        down.org = {2.0f, 2.0f, 5.0f};  // on the hypotenuse
        EXPECT_EQ(tracer.intersect(down).primitive, 0u);
        down.org = {2.0f, 2.0001f, 5.0f};
        EXPECT_FALSE(tracer.intersect(down).is_hit());
    }
}

// ---------------------------------------------------------------------------------------------------
// The ray segment.

namespace {

using testing_support::two_floors;  // two unit squares at z = 0 (triangles 0, 1) and z = -1 (2, 3)

}  // namespace

// Hits beyond tmax or before tmin are not reported, by closest hit or occlusion; the ends are inclusive.
TEST(Tracer, TminAndTmaxAreHonoured) {
    const Scene scene = two_floors();
    const Tracer tracer(scene, build_with(scene, "binned", 1), Kernel::binary);
    Ray ray;
    ray.org = {0.7f, 0.2f, 1.0f};
    ray.dir = {0, 0, -1};
    EXPECT_EQ(tracer.intersect(ray).t, 1.0f);
    EXPECT_EQ(tracer.intersect(ray).primitive, 0u);

    ray.tmax = 0.5f;  // before the first floor
    EXPECT_FALSE(tracer.intersect(ray).is_hit());
    EXPECT_FALSE(tracer.occluded(ray));
    ray.tmax = 1.0f;  // exactly at the first floor: inclusive
    EXPECT_EQ(tracer.intersect(ray).t, 1.0f);
    EXPECT_TRUE(tracer.occluded(ray));
    ray.tmax = std::nextafter(1.0f, 0.0f);
    EXPECT_FALSE(tracer.intersect(ray).is_hit());
    EXPECT_FALSE(tracer.occluded(ray));

    ray.tmax = kInfinity;
    ray.tmin = 1.5f;  // past the first floor: the second one at t = 2
    EXPECT_EQ(tracer.intersect(ray).t, 2.0f);
    EXPECT_EQ(tracer.intersect(ray).primitive, 2u);
    EXPECT_TRUE(tracer.occluded(ray));
    ray.tmin = 2.0f;  // inclusive
    EXPECT_EQ(tracer.intersect(ray).t, 2.0f);
    ray.tmin = std::nextafter(2.0f, 3.0f);
    EXPECT_FALSE(tracer.intersect(ray).is_hit());
    EXPECT_FALSE(tracer.occluded(ray));
    ray.tmin = 1.0f;
    ray.tmax = 2.0f;  // both floors inside, the nearer wins
    EXPECT_EQ(tracer.intersect(ray).t, 1.0f);
    ray.tmin = 1.25f;
    ray.tmax = 1.75f;  // between the floors
    EXPECT_FALSE(tracer.intersect(ray).is_hit());
    EXPECT_FALSE(tracer.occluded(ray));

    // t is in units of |dir|.
    Ray scaled = ray;
    scaled.tmin = 0.0f;
    scaled.tmax = kInfinity;
    scaled.dir = {0, 0, -4};
    EXPECT_EQ(tracer.intersect(scaled).t, 0.25f);
    scaled.tmax = 0.24f;
    EXPECT_FALSE(tracer.intersect(scaled).is_hit());
    EXPECT_FALSE(tracer.occluded(scaled));

    // Origin on the surface with tmin = 0: t = 0 is a hit.
    Ray on_surface;
    on_surface.org = {0.7f, 0.2f, 0.0f};
    on_surface.dir = {0, 0, -1};
    EXPECT_EQ(tracer.intersect(on_surface).t, 0.0f);
    EXPECT_TRUE(tracer.occluded(on_surface));
}

// With tmax or tmin set right at the exact hit distance (rounded to float, and one float either side),
// hit or miss is decided as the arbiter decides, on oblique rays at irregular triangles.
TEST(Tracer, SegmentEndsAtTheHitDistanceMatchTheArbiter) {
    SplitMix64 rng(77);
    Scene scene;
    scene.name = "irregular";
    for (int i = 0; i < 40; ++i) {
        const Vec3 c{10 * rng.uniform() - 5, 10 * rng.uniform() - 5, 10 * rng.uniform() - 5};
        auto corner = [&] {
            return c + Vec3(3 * rng.uniform() - 1.5f, 3 * rng.uniform() - 1.5f, 3 * rng.uniform() - 1.5f);
        };
        scene.triangles.push_back({corner(), corner(), corner()});
    }
    const Bvh tree = build_with(scene, "binned", 2);
    std::vector<Ray> rays;
    for (const Ray& ray : generate_random_rays(scene.bounds(), 3000, 5)) {
        const HitRecord truth = arbiter_closest_hit(scene, ray);
        if (!truth.is_hit()) continue;
        const float t = truth.t;
        for (const float end : {std::nextafter(t, 0.0f), t, std::nextafter(t, kInfinity)}) {
            Ray cut = ray;
            cut.tmax = end;
            rays.push_back(cut);
            Ray late = ray;
            late.tmin = end;
            rays.push_back(late);
        }
    }
    ASSERT_GT(rays.size(), 1000u);
    EXPECT_EQ(disagreements_with_arbiter(scene, tree, rays), "");
}

// ---------------------------------------------------------------------------------------------------
// Degenerate triangles.

// Zero-area triangles are never hit, even by rays aimed straight at their points or lying along them.
TEST_P(TracerWithBuilder, DegenerateTrianglesAreNeverHit) {
    Scene scene;
    scene.name = "degenerates";
    std::vector<Triangle> degenerate = {
        {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}},                             // collinear on an axis
        {{0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}},  // a point
        {{0, 1, 0}, {1, 2, 0}, {1, 2, 0}},                             // repeated vertex
        {{-1, -1, -1}, {1, 1, 1}, {3, 3, 3}},                          // collinear, oblique
        {{0, 0, 1}, {0, 2, 1}, {0, 1, 1}},                             // collinear, middle vertex last
    };
    for (const Triangle& t : degenerate) ASSERT_TRUE(t.is_degenerate());
    scene.triangles = degenerate;
    scene.triangles.push_back({{-5, -5, -3}, {5, -5, -3}, {0, 6, -3}});  // a real floor behind them
    const uint32_t floor = uint32_t(scene.triangles.size() - 1);
    scene.degenerate_count = degenerate.size();

    std::vector<Ray> rays;
    SplitMix64 rng(3);
    for (const Triangle& t : degenerate)
        for (const Vec3 target : {t.v0, t.v1, t.v2, (t.v0 + t.v1) * 0.5f, (t.v1 + t.v2) * 0.5f}) {
            for (int k = 0; k < 20; ++k) {
                Ray ray;
                ray.org = target + Vec3(4 * rng.uniform() - 2, 4 * rng.uniform() - 2, 3 + 2 * rng.uniform());
                ray.dir = target - ray.org;
                rays.push_back(ray);
            }
            // Along the segment itself.
            Ray along;
            along.org = t.v0 - (t.v2 - t.v0);
            along.dir = t.v2 - t.v0;
            if (!(along.dir == Vec3(0.0f))) rays.push_back(along);
        }
    for (uint32_t max_leaf : {1u, 8u}) {
        const Bvh tree = build_with(scene, GetParam(), max_leaf);
        const Tracer tracer(scene, tree, Kernel::binary);
        size_t degenerate_hits = 0;
        for (const Ray& ray : rays) {
            const Hit hit = tracer.intersect(ray);
            if (hit.is_hit() && hit.primitive != floor) ++degenerate_hits;
        }
        EXPECT_EQ(degenerate_hits, 0u) << "max leaf " << max_leaf;
        EXPECT_EQ(disagreements_with_arbiter(scene, tree, rays, kernels_for(GetParam())), "")
            << "max leaf " << max_leaf;
    }
    // Only degenerate triangles: nothing at all is hit.
    Scene only;
    only.name = "only_degenerate";
    only.triangles = degenerate;
    const Tracer tracer(only, build_with(only, GetParam(), 1), Kernel::binary);
    size_t hits = 0;
    for (const Ray& ray : rays) hits += tracer.intersect(ray).is_hit() + tracer.occluded(ray);
    EXPECT_EQ(hits, 0u);
}

// A tiny but non-degenerate triangle is still hit where the arbiter says so.
TEST(Tracer, TinyTrianglesAreHitLikeTheArbiterSays) {
    Scene scene;
    scene.name = "tiny";
    SplitMix64 rng(8);
    for (int i = 0; i < 200; ++i) {
        const Vec3 c{rng.uniform(), rng.uniform(), rng.uniform()};
        const float s = 1e-5f * (1 + rng.uniform());
        scene.triangles.push_back({c, c + Vec3(s, 0, 0.3f * s), c + Vec3(0.2f * s, s, -s)});
    }
    const Bvh tree = build_with(scene, "binned", 4);
    const Tracer tracer(scene, tree, Kernel::binary);
    std::vector<Ray> rays;
    size_t hits = 0;
    for (const Triangle& t : scene.triangles) {
        Ray ray;
        ray.org = t.v0 + Vec3(0.3f, -0.2f, 0.9f);
        ray.dir = (t.v0 + t.v1 + t.v2) * (1.0f / 3.0f) - ray.org;
        rays.push_back(ray);
        hits += tracer.intersect(ray).is_hit();
    }
    EXPECT_EQ(disagreements_with_arbiter(scene, tree, rays), "");
    EXPECT_GT(hits, 150u);
}

// ---------------------------------------------------------------------------------------------------
// Statistics and the batch API.

namespace {

const Scene& soup() {
    static const Scene scene = load_scene("builtin:soup");
    return scene;
}

bool same_hit(const Hit& a, const Hit& b) {
    return std::memcmp(&a.t, &b.t, sizeof(float)) == 0 && a.primitive == b.primitive &&
           std::memcmp(&a.u, &b.u, sizeof(float)) == 0 && std::memcmp(&a.v, &b.v, sizeof(float)) == 0;
}

}  // namespace

// Statistics mode returns the same answers; counts are positive and add up to the batch totals.
TEST(Tracer, TraversalStatsAreConsistent) {
    const Scene& scene = soup();
    const Tracer tracer(scene, build_with(scene, "binned"), Kernel::binary);
    const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 2000, 4);
    TraversalStats closest_sum, occlusion_sum;
    size_t different = 0, hits = 0;
    for (const Ray& ray : rays) {
        TraversalStats closest, occlusion;
        const Hit plain = tracer.intersect(ray);
        const Hit counted = tracer.intersect(ray, closest);
        different += !same_hit(plain, counted);
        different += tracer.occluded(ray) != tracer.occluded(ray, occlusion);
        EXPECT_GE(closest.nodes_visited, 2u);  // the root's two children are always tested
        EXPECT_GE(occlusion.nodes_visited, 2u);
        if (plain.is_hit()) {
            ++hits;
            EXPECT_GE(closest.triangles_tested, 1u);
            EXPECT_GE(occlusion.triangles_tested, 1u);
        }
        closest_sum += closest;
        occlusion_sum += occlusion;
    }
    EXPECT_EQ(different, 0u);
    EXPECT_GT(hits, 500u);

    std::vector<Hit> batch(rays.size());
    TraversalStats batch_stats;
    tracer.intersect(rays, batch, &batch_stats);
    EXPECT_EQ(batch_stats.nodes_visited, closest_sum.nodes_visited);
    EXPECT_EQ(batch_stats.triangles_tested, closest_sum.triangles_tested);
    std::vector<uint8_t> occluded(rays.size());
    TraversalStats occlusion_batch_stats;
    tracer.occluded(rays, occluded, &occlusion_batch_stats);
    EXPECT_EQ(occlusion_batch_stats.nodes_visited, occlusion_sum.nodes_visited);
    EXPECT_EQ(occlusion_batch_stats.triangles_tested, occlusion_sum.triangles_tested);
    // The batch overwrites stale totals rather than adding to them.
    TraversalStats stale{123456789, 987654321};
    tracer.intersect(rays, batch, &stale);
    EXPECT_EQ(stale.nodes_visited, closest_sum.nodes_visited);
    // Closest hit visits no fewer triangles than it needs: at least one per hit.
    EXPECT_GE(closest_sum.triangles_tested, hits);
    EXPECT_GT(tracer.memory_bytes(), scene.triangles.size() * 36);
}

// Batch calls give exactly the single-ray answers, with and without statistics, in any arena.
TEST(Tracer, BatchEqualsSingleRayCalls) {
    const Scene& scene = soup();
    const Tracer tracer(scene, build_with(scene, "cbvh"), Kernel::binary);
    std::vector<Ray> rays = generate_random_rays(scene.bounds(), 3001, 9);  // not a multiple of the chunk
    const std::vector<Ray> primary = generate_primary_rays(default_camera(scene), 40, 30);
    rays.insert(rays.end(), primary.begin(), primary.end());
    std::vector<Hit> batch(rays.size()), batch_stats(rays.size());
    std::vector<uint8_t> occluded(rays.size()), occluded_stats(rays.size());
    TraversalStats stats;
    tracer.intersect(rays, batch);
    tracer.intersect(rays, batch_stats, &stats);
    tracer.occluded(rays, occluded);
    tracer.occluded(rays, occluded_stats, &stats);
    size_t different = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const Hit single = tracer.intersect(rays[i]);
        different += !same_hit(single, batch[i]) + !same_hit(single, batch_stats[i]);
        const bool single_occluded = tracer.occluded(rays[i]);
        different += (occluded[i] != single_occluded) + (occluded_stats[i] != single_occluded);
        // Occlusion and closest hit agree on whether anything is hit.
        different += single_occluded != single.is_hit();
    }
    EXPECT_EQ(different, 0u);
    // Empty batches are fine.
    tracer.intersect(std::span<const Ray>(), std::span<Hit>());
    tracer.occluded(std::span<const Ray>(), std::span<uint8_t>());
}

// A moved-from tracer's target keeps working.
TEST(Tracer, MoveKeepsTheLayout) {
    const Scene scene = two_floors();
    Tracer original(scene, build_with(scene, "binned"), Kernel::binary);
    Tracer moved(std::move(original));
    Ray ray;
    ray.org = {0.5f, 0.25f, 3.0f};
    ray.dir = {0, 0, -1};
    EXPECT_EQ(moved.intersect(ray).t, 3.0f);
    Tracer assigned(scene, Bvh{}, Kernel::binary);
    assigned = std::move(moved);
    EXPECT_EQ(assigned.intersect(ray).t, 3.0f);
}

// ---------------------------------------------------------------------------------------------------
// Unusual trees.

// An empty Bvh traces: nothing is hit, in single and batch calls.
TEST(Tracer, EmptyBvhMissesEverything) {
    const Scene scene = two_floors();
    const Tracer tracer(scene, Bvh{}, Kernel::binary);
    const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 500, 2);
    size_t hits = 0;
    for (const Ray& ray : rays) {
        TraversalStats stats;
        hits += tracer.intersect(ray).is_hit() + tracer.occluded(ray) + tracer.intersect(ray, stats).is_hit();
    }
    std::vector<Hit> batch(rays.size());
    tracer.intersect(rays, batch);
    for (const Hit& hit : batch) hits += hit.is_hit();
    EXPECT_EQ(hits, 0u);
    // Also over an empty scene.
    Scene empty;
    const Tracer nothing(empty, Bvh{}, Kernel::binary);
    EXPECT_FALSE(nothing.intersect(rays[0]).is_hit());
    EXPECT_FALSE(nothing.occluded(rays[0]));
}

// A tree that is a single leaf holding every triangle answers like the arbiter.
TEST(Tracer, SingleLeafRootMatchesTheArbiter) {
    Scene scene = two_floors();
    SplitMix64 rng(12);
    for (int i = 0; i < 30; ++i) {
        const Vec3 c{3 * rng.uniform() - 1, 3 * rng.uniform() - 1, 3 * rng.uniform() - 2};
        scene.triangles.push_back(
            {c, c + Vec3(rng.uniform(), 0.1f, rng.uniform()), c + Vec3(0.2f, rng.uniform(), 0.5f)});
    }
    scene.triangles.push_back({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}});  // degenerate
    Bvh bvh;
    bvh.builder = "hand-made";
    BvhNode root;
    root.bounds = scene.bounds();
    root.first = 0;
    root.reference_count = uint32_t(scene.triangles.size());
    bvh.nodes = {root};
    for (uint32_t i = 0; i < scene.triangles.size(); ++i) bvh.primitives.push_back(i);
    const Tracer tracer(scene, bvh, Kernel::binary);
    std::vector<Ray> rays = generate_random_rays(scene.bounds(), 2000, 6);
    EXPECT_EQ(disagreements_with_arbiter(scene, bvh, rays), "");
    // The builder's single-leaf tree of one triangle too.
    Scene one;
    one.triangles = {scene.triangles[0]};
    EXPECT_EQ(disagreements_with_arbiter(one, build_with(one, "binned"), rays), "");
}

// The binary layout turns a subtree whose triangles fit a pack into one leaf: a ray through the
// root of a two-level tree of four single-triangle leaves then tests the root's box pair only, and
// the two merged leaves' triangles. A subtree of more triangles than the layout merges stays as built.
TEST(Tracer, SmallSubtreesAreTestedAsOneLeaf) {
    for (const uint32_t per_leaf : {1u, 5u}) {
        Scene scene;
        scene.name = "small";
        for (uint32_t i = 0; i < 4 * per_leaf; ++i) {
            const float x = float(i);
            scene.triangles.push_back({{x, -1, -1}, {x, 1, -1}, {x, 0, 1}});
        }
        // Root: children [node 1, node 2]; node 1: leaves 0, 1; node 2: leaves 2, 3.
        Bvh bvh;
        bvh.builder = "hand-made";
        bvh.nodes.resize(7);
        auto triangles_box = [&](uint32_t first, uint32_t count) {
            AABB box = AABB::empty();
            for (uint32_t i = first; i < first + count; ++i) box.extend(scene.triangles[i].bounds());
            return box;
        };
        bvh.nodes[0] = {triangles_box(0, 4 * per_leaf), 1, 0};
        bvh.nodes[1] = {triangles_box(0, 2 * per_leaf), 3, 0};
        bvh.nodes[2] = {triangles_box(2 * per_leaf, 2 * per_leaf), 5, 0};
        for (uint32_t leaf = 0; leaf < 4; ++leaf) {
            bvh.nodes[3 + leaf] = {triangles_box(leaf * per_leaf, per_leaf), leaf * per_leaf, per_leaf};
        }
        for (uint32_t i = 0; i < 4 * per_leaf; ++i) bvh.primitives.push_back(i);
        const Tracer tracer(scene, bvh, Kernel::binary);
        Ray ray;
        ray.org = {-1.0f, 0.0f, 0.0f};
        ray.dir = {1.0f, 0.0f, 0.0f};
        TraversalStats stats;
        const Hit hit = tracer.intersect(ray, stats);
        EXPECT_EQ(hit.primitive, 0u);
        EXPECT_EQ(hit.t, 1.0f);
        if (per_leaf == 1) {
            EXPECT_EQ(stats.nodes_visited, 2u) << "the two pairs of leaves are merged into the root's children";
            // Both merged leaves are entered: 2 lanes, then 4 (the second shares the first's pack and
            // its lanes cover both; LeafPacker).
            EXPECT_EQ(stats.triangles_tested, 6u);
        } else {
            // Root and left child (its two leaves, entered, are tested); the right child is pushed
            // and skipped, entered beyond the hit.
            EXPECT_EQ(stats.nodes_visited, 4u) << "10 triangles are more than a merged leaf holds";
            EXPECT_EQ(stats.triangles_tested, 10u);
        }
        std::vector<Ray> rays = generate_random_rays(scene.bounds(), 500, 3);
        EXPECT_EQ(disagreements_with_arbiter(scene, bvh, rays), "");
    }
}

// A hand-made tree 1,000 levels deep (the builders' depth limit is 1,024) whose every level has two
// inner children with the same box, so the traversal stack holds one entry per level. Leaves hold
// kPerLeaf triangles, so that no pair of leaves is few enough for the binary layout to merge it
// into one leaf (trace::WideCost::max_merged_leaf).
TEST(Tracer, VeryDeepTreeWithAFullStackMatchesTheArbiter) {
    constexpr uint32_t kLevels = 1000;
    constexpr uint32_t kPerLeaf = 5;
    Scene scene;
    scene.name = "deep";
    SplitMix64 rng(21);
    for (uint32_t i = 0; i < (2 * kLevels + 1) * kPerLeaf; ++i) {
        const Vec3 c{8 * rng.uniform() - 4, 8 * rng.uniform() - 4, 8 * rng.uniform() - 4};
        scene.triangles.push_back({c, c + Vec3(0.4f, 0.1f, 0.0f), c + Vec3(0.0f, 0.3f, 0.4f)});
    }
    const AABB box = scene.bounds();
    Bvh bvh;
    bvh.builder = "hand-made";
    // Chain node i: children [chain node i + 1, pair node i]; pair node i: leaves 2i and 2i + 1 (leaf k
    // holds triangles k * kPerLeaf onwards);
    // the last chain node is the leaf {2 * kLevels}. Children are appended as pairs, left subtree first.
    auto leaf = [&](uint32_t index) {
        BvhNode node;
        node.bounds = box;
        node.first = uint32_t(bvh.primitives.size());
        node.reference_count = kPerLeaf;
        for (uint32_t k = 0; k < kPerLeaf; ++k) bvh.primitives.push_back(index * kPerLeaf + k);
        return node;
    };
    bvh.nodes.resize(1);
    uint32_t chain = 0;
    std::vector<uint32_t> pair_nodes;
    for (uint32_t level = 0; level < kLevels; ++level) {
        const uint32_t first = uint32_t(bvh.nodes.size());
        bvh.nodes.resize(first + 2);
        bvh.nodes[chain].bounds = box;
        bvh.nodes[chain].first = first;
        bvh.nodes[chain].reference_count = 0;
        pair_nodes.push_back(first + 1);
        chain = first;
    }
    bvh.nodes[chain] = leaf(2 * kLevels);
    // The pair nodes' leaves, deepest first so that primitives follow the depth-first order.
    for (uint32_t level = kLevels; level-- > 0;) {
        const uint32_t pair = pair_nodes[level];
        const uint32_t first = uint32_t(bvh.nodes.size());
        bvh.nodes.resize(first + 2);
        bvh.nodes[pair].bounds = box;
        bvh.nodes[pair].first = first;
        bvh.nodes[pair].reference_count = 0;
        bvh.nodes[first] = leaf(2 * level);
        bvh.nodes[first + 1] = leaf(2 * level + 1);
    }
    ASSERT_EQ(bvh.nodes.size(), 2 * (2 * kLevels + 1) - 1);
    const Tracer tracer(scene, bvh, Kernel::binary);
    std::vector<Ray> rays = generate_random_rays(box, 300, 7);
    EXPECT_EQ(disagreements_with_arbiter(scene, bvh, rays), "");
    TraversalStats stats;
    tracer.intersect(rays[0], stats);
    EXPECT_GE(stats.nodes_visited, 2u * kLevels);  // every level is entered
}

// Rays from inside a box aimed at its corners and edges, with origins far from the geometry and
// direction vectors of very different lengths: t scales with 1/|dir| and answers match the arbiter.
TEST(Tracer, DirectionLengthDoesNotChangeTheAnswer) {
    const IndexedMesh cube = grid_cube(4, -1.0f, 1.0f);
    const Scene scene = cube.scene("cube");
    const Bvh tree = build_with(scene, "binned", 2);
    const Tracer tracer(scene, tree, Kernel::binary);
    std::vector<Ray> rays;
    SplitMix64 rng(5);
    for (const Vec3& v : cube.vertices)
        for (float scale : {1e-3f, 1.0f, 1e3f}) {
            Ray ray;
            ray.org = {0.1f * rng.uniform(), 0.1f * rng.uniform(), 0.1f * rng.uniform()};
            ray.dir = (v - ray.org) * scale;
            rays.push_back(ray);
        }
    EXPECT_EQ(disagreements_with_arbiter(scene, tree, rays), "");
    size_t misses = 0;
    for (const Ray& ray : rays) misses += !tracer.intersect(ray).is_hit();
    EXPECT_EQ(misses, 0u);
}

INSTANTIATE_TEST_SUITE_P(All, TracerWithBuilder, ::testing::ValuesIn(builder_names()), param_name);
