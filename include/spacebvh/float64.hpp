// SPDX-License-Identifier: MIT
// Float64 meshes and rays traced exactly: answers are those of the mesh and rays as given (closed
// triangles, exact edge and range decisions in float64; docs/float64.md). The tree is built by the
// ordinary builders over float32 triangles in a local frame centred on the mesh, its boxes then
// widened to contain the float64 triangles.
// Implemented in src/trace/float64.cpp, on the exact float64 predicates of src/core/exact_float64.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/mesh.hpp"

namespace spacebvh {

using Vec3d = std::array<double, 3>;

struct Triangle64 {
    Vec3d v0, v1, v2;
};

// A ray in float64: t is measured in units of |dir|, hits count for t in [tmin, tmax]. Supported range
// (where every decision is exact; Tracer64 throws Error naming the ray otherwise): org and dir
// components are 0 or of magnitude in [2^-200, 2^128] (dir up to 2^200), dir is not zero, tmin and
// tmax are 0, +-inf or of magnitude in [2^-200, 2^500].
struct Ray64 {
    Vec3d org{};
    Vec3d dir{};
    double tmin = 0.0;
    double tmax = std::numeric_limits<double>::infinity();
};

struct Hit64 {
    double t = std::numeric_limits<double>::infinity();  // +inf for a miss
    uint32_t primitive = kInvalidIndex;                  // triangle id in mesh order
    double u = 0.0, v = 0.0;                             // barycentrics of v1 and v2

    bool is_hit() const { return primitive != kInvalidIndex; }
};

// The mesh's float32 stand-in that trees for Tracer64 are built over: every vertex minus `origin`
// (the centre of the float64 bounds rounded to float), rounded to float. Same numbering as the mesh.
struct LocalFrameMesh {
    Vec3d origin{};
    std::vector<Triangle> triangles;
};
LocalFrameMesh local_frame_mesh(const MeshView& mesh);

// The exact test of one ray against one triangle (the arbiter's and the tracer's leaf test); t is
// rounded, everything else exact. Nothing for a miss.
Hit64 intersect_exact(const Ray64& ray, const Triangle64& triangle, uint32_t primitive);

class Tracer64 {
public:
    // Builds the tree with `config` over local_frame_mesh(mesh). Throws Error for an empty or malformed
    // mesh, or a vertex coordinate that is neither 0 nor of magnitude >= 2^-200 (outside the exact range).
    explicit Tracer64(const MeshView& mesh, const BuildConfig& config = BuildConfig::for_quality(Quality::balanced));
    // With a tree already built over local_frame_mesh(mesh).triangles (any builder); throws Error when
    // a leaf box misses a triangle it holds (a tree built over other triangles).
    Tracer64(const MeshView& mesh, const Bvh& local_frame_bvh);
    ~Tracer64();
    Tracer64(Tracer64&&) noexcept;
    Tracer64& operator=(Tracer64&&) noexcept;

    // Closest hit and any hit, exact for t in [ray.tmin, ray.tmax]. Throw Error for a ray outside the
    // supported range (Ray64).
    Hit64 intersect(const Ray64& ray) const;
    bool occluded(const Ray64& ray) const;
    // Batches across the calling thread's oneTBB arena.
    void intersect(std::span<const Ray64> rays, std::span<Hit64> hits) const;
    void occluded(std::span<const Ray64> rays, std::span<uint8_t> occluded) const;

    // The tree traversed: boxes in the local frame, widened to contain the float64 triangles.
    const Bvh& bvh() const;
    const Vec3d& frame_origin() const;
    // Triangles tested for every ray: non-degenerate in float64 but not reliably in the tree (their
    // float32 stand-in has zero area, or no leaf holds them).
    size_t unindexed_count() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace spacebvh
