// SPDX-License-Identifier: MIT
// Ray sets and result files exactly as docs/rays.md, so that outside tools can check our
// answers ray by ray. The generators are compiled with -ffp-contract=off (no fused multiply-add) to
// reproduce the spec's rays bit for bit.
// Implemented in src/tools/rays/ray_generation.cpp (ray sets) and src/tools/rays/ray_files.cpp (files).
#pragma once

#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/geometry.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::tools {

enum class RayKind { random, primary, diffuse };
RayKind parse_ray_kind(const std::string& text);  // throws Error
const char* to_string(RayKind kind);

// splitmix64 (Steele, Lea & Flood 2014) with the spec's uniform() and disk().
class SplitMix64 {
public:
    explicit SplitMix64(uint64_t seed) : state_(seed) {}
    uint64_t next();
    float uniform();                          // [0, 1), exact in float32
    void disk(float& a, float& b, float& s);  // rejection sample of the unit disk, s = a*a + b*b < 1
private:
    uint64_t state_;
};

std::vector<Ray> generate_random_rays(const AABB& scene_bounds, size_t count, uint64_t seed);
// The largest image side of primary rays and renders (16384^2 rays are 8 GiB already).
inline constexpr uint32_t kMaxImageSide = 16384;
// Row by row from the top; throws Error for a side of 0 or above kMaxImageSide, or a bad camera.
std::vector<Ray> generate_primary_rays(const Camera& camera, uint32_t width, uint32_t height);
// One ray per primary ray that hits, in primary order. epsilon <= 0 means the spec's default
// 1e-4 * |scene diagonal|.
std::vector<Ray> generate_diffuse_rays(const Scene& scene, std::span<const Ray> primary_rays,
                                       std::span<const Hit> primary_hits, uint64_t seed, float epsilon = 0.0f);

// A hit file record: t (+inf for a miss) and the primitive (kInvalidIndex for a miss). Occlusion
// answers: t = 0 for occluded, +inf for unoccluded, primitive = kInvalidIndex.
struct HitRecord {
    float t = kInfinity;
    uint32_t primitive = kInvalidIndex;
    bool is_hit() const { return t != kInfinity; }
};
HitRecord to_record(const Hit& hit);
HitRecord occlusion_record(bool occluded);

// Why no kernel can trace `ray` (a non-finite origin or direction, a NaN t range, a zero direction),
// or nullptr when it can. Ray files and the Python module refuse such rays with this reason.
const char* untraceable_ray_reason(const Ray& ray);

void write_ray_file(const std::string& path, std::span<const Ray> rays);
std::vector<Ray> read_ray_file(const std::string& path);  // throws Error naming the file and record
void write_hit_file(const std::string& path, std::span<const HitRecord> hits);
std::vector<HitRecord> read_hit_file(const std::string& path);
// The same from a stream open for reading at its start (a pipe cannot do: the size is checked
// first), e.g. fmemopen over bytes in memory; the readers close it. `name` starts every message.
std::vector<Ray> read_ray_file(std::FILE* file, const std::string& name);
std::vector<HitRecord> read_hit_file(std::FILE* file, const std::string& name);

}  // namespace spacebvh::tools
