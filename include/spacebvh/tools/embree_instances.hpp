// SPDX-License-Identifier: MIT
// Embree's two-level scene as the yardstick of instanced scenes: one Embree scene per mesh (its
// RTC_BUILD_QUALITY), and a top scene of instance geometries (rtcSetGeometryInstancedScene,
// rtcSetGeometryTransform), traced with rtcIntersect1/rtcOccluded1 and rtcIntersect16/rtcOccluded16.
// Embree 3 is built here with one instance level, so a placement nested several levels deep is one
// Embree instance whose transform is the levels' product (in double, rounded to float once); the
// answers still name the placement's own instance path.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "spacebvh/scene.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/tools/scene_arbiter.hpp"

namespace spacebvh::tools {

class EmbreeInstancedScene {
public:
    // Builds (commits) a scene per mesh, then the top scene over `placements`; `meshes` are copied
    // into Embree's buffers and need not outlive it. Throws Error for an empty mesh or no placement.
    EmbreeInstancedScene(std::span<const Scene> meshes, std::span<const MeshPlacement> placements,
                         EmbreeQuality quality);
    // The same over meshes already built (shared, e.g. between top levels a benchmark times); the
    // top scene takes `meshes`' build quality... of the first mesh.
    EmbreeInstancedScene(std::vector<std::shared_ptr<const EmbreeScene>> meshes,
                         std::span<const MeshPlacement> placements);
    ~EmbreeInstancedScene();
    EmbreeInstancedScene(const EmbreeInstancedScene&) = delete;
    EmbreeInstancedScene& operator=(const EmbreeInstancedScene&) = delete;

    // The meshes' commits plus the top scene's; the top scene's alone.
    double build_milliseconds() const { return mesh_build_ms_ + top_build_ms_; }
    double top_build_milliseconds() const { return top_build_ms_; }
    // Creating the instance geometries (rtcNewGeometry, rtcSetGeometryInstancedScene,
    // rtcSetGeometryTransform, rtcCommitGeometry) and attaching them, before the top level's commit.
    double top_setup_milliseconds() const { return top_setup_ms_; }
    // What the commits allocated (EmbreeScene::memory_bytes), meshes and top scene.
    size_t memory_bytes() const;

    // Single rays: rtcIntersect1 / rtcOccluded1; hits name the placement's path, geometry and
    // triangle as RenderScene does. Batches in oneTBB chunks of 1024 rays (EmbreeScene's).
    SceneHit intersect(const Ray& ray) const;
    bool occluded(const Ray& ray) const;
    void intersect(std::span<const Ray> rays, std::span<SceneHit> hits) const;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const;
    // Packets: rtcIntersect16 / rtcOccluded16 over consecutive groups of 16 rays.
    void intersect16(std::span<const Ray> rays, std::span<SceneHit> hits) const;
    void occluded16(std::span<const Ray> rays, std::span<uint8_t> occluded) const;

private:
    SceneHit to_hit(unsigned instance, unsigned primitive, float t, float u, float v) const;

    void build_top(std::span<const MeshPlacement> placements, EmbreeQuality quality);

    std::vector<std::shared_ptr<const EmbreeScene>> meshes_;
    std::vector<std::array<uint32_t, kMaxInstanceLevels>> paths_;  // per Embree instance id
    std::vector<uint32_t> geometries_;
    RTCScene top_ = nullptr;
    double mesh_build_ms_ = 0.0, top_build_ms_ = 0.0, top_setup_ms_ = 0.0;
    size_t top_bytes_ = 0;
};

}  // namespace spacebvh::tools
