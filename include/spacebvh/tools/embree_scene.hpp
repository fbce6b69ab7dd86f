// SPDX-License-Identifier: MIT
// Embree 3 as the yardstick: the same scene, the same rays, Embree's own BVHs and kernels.
// Single rays through rtcIntersect1 / rtcOccluded1 in oneTBB chunks of 1024 rays, and 16-ray packets.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <embree3/rtcore.h>

#include "spacebvh/geometry.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::tools {

// RTC_BUILD_QUALITY_LOW / MEDIUM / HIGH on the scene. HIGH is Embree's BVH8 (on AVX/AVX-512) with
// spatial splits: the yardstick of `spacebvh compare --embree high`.
enum class EmbreeQuality { low, medium, high };
const char* to_string(EmbreeQuality quality);
EmbreeQuality parse_embree_quality(const std::string& text);  // "low", "medium", "high"; throws Error

// The process-wide Embree device, created on first use (thread-safe). Embree schedules its build
// tasks with oneTBB in the caller's arena, like our builders. Errors reported by Embree become Error.
RTCDevice embree_device();

// Throws Error if the last Embree call on this thread failed, with Embree's own message.
void check_embree(RTCDevice device, const char* what);

// One static Embree scene holding a single triangle geometry: primID = our triangle index in file
// order. Degenerate triangles are handed to Embree as they are (it skips them itself).
//
// The constructor uploads the triangles and commits (builds) the scene; build_milliseconds() is the
// time of rtcCommitScene alone (the "embree build ms" of `compare`). For a median of several
// builds, construct several times.
//
// Queries are const and thread-safe. Rays follow docs/rays.md: t in [tmin, tmax] in units
// of |dir| (Embree's tnear/tfar), so Hit::t is directly comparable with ours.
class EmbreeScene {
public:
    EmbreeScene(const Scene& scene, EmbreeQuality quality);
    ~EmbreeScene();
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;
    EmbreeScene(EmbreeScene&& other) noexcept;
    EmbreeScene& operator=(EmbreeScene&& other) noexcept;

    EmbreeQuality quality() const { return quality_; }
    double build_milliseconds() const { return build_ms_; }

    // Memory Embree allocated (net) while committing: its BVH with the triangle data in its leaves
    // plus build leftovers it keeps. Measured with a device-wide memory monitor, so it is only exact
    // when no other Embree scene is built or destroyed at the same time. Excludes buffer_bytes().
    size_t memory_bytes() const { return memory_bytes_; }
    // Our vertex and index buffers shared with Embree.
    size_t buffer_bytes() const;

    // Single rays: rtcIntersect1 / rtcOccluded1.
    Hit intersect(const Ray& ray) const;
    bool occluded(const Ray& ray) const;

    // Batches of single rays, oneTBB parallel_for over chunks of 1024 rays in the caller's arena.
    void intersect(std::span<const Ray> rays, std::span<Hit> hits) const;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const;

    // Packet batches: rtcIntersect16 / rtcOccluded16 over consecutive groups of 16 rays (the last
    // group masked), same chunking. Results equal the single-ray ones.
    void intersect16(std::span<const Ray> rays, std::span<Hit> hits) const;
    void occluded16(std::span<const Ray> rays, std::span<uint8_t> occluded) const;

    RTCScene handle() const { return scene_; }

private:
    void release() noexcept;

    EmbreeQuality quality_ = EmbreeQuality::medium;
    RTCScene scene_ = nullptr;
    std::vector<float> vertices_;    // 3 floats per vertex, 3 vertices per triangle, + padding
    std::vector<uint32_t> indices_;  // 0, 1, 2, 3, ...
    double build_ms_ = 0.0;
    size_t memory_bytes_ = 0;
};

}  // namespace spacebvh::tools
