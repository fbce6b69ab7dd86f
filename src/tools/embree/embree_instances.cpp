// SPDX-License-Identifier: MIT
// Embree's two-level scene (embree_instances.hpp).
#include "spacebvh/tools/embree_instances.hpp"

#include <chrono>
#include <string>

#include "spacebvh/error.hpp"
#include "tools/embree/embree_internal.hpp"

namespace spacebvh::tools {

using namespace embree_detail;

namespace {

// The placement's transforms as one, top first: parent = A0 (A1 (... local) + b1) + b0, in double,
// rounded to float once.
std::array<float, 12> composed(const std::vector<Affine>& transforms) {
    double m[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    for (const Affine& a : transforms) {  // m = m * a, as 4x4 matrices with last row (0, 0, 0, 1)
        double out[12];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                out[4 * r + c] = m[4 * r] * a.m[c] + m[4 * r + 1] * a.m[4 + c] + m[4 * r + 2] * a.m[8 + c] +
                                 (c == 3 ? m[4 * r + 3] : 0.0);
        std::copy(out, out + 12, m);
    }
    std::array<float, 12> rounded;
    for (int i = 0; i < 12; ++i) rounded[i] = float(m[i]);
    return rounded;
}

}  // namespace

EmbreeInstancedScene::EmbreeInstancedScene(std::span<const Scene> meshes, std::span<const MeshPlacement> placements,
                                           EmbreeQuality quality) {
    for (const Scene& mesh : meshes) {
        meshes_.push_back(std::make_shared<const EmbreeScene>(mesh, quality));
        mesh_build_ms_ += meshes_.back()->build_milliseconds();
    }
    build_top(placements, quality);
}

EmbreeInstancedScene::EmbreeInstancedScene(std::vector<std::shared_ptr<const EmbreeScene>> meshes,
                                           std::span<const MeshPlacement> placements)
    : meshes_(std::move(meshes)) {
    if (meshes_.empty()) throw Error("Embree two-level scene: no mesh");
    build_top(placements, meshes_.front()->quality());
}

void EmbreeInstancedScene::build_top(std::span<const MeshPlacement> placements, EmbreeQuality quality) {
    RTCDevice device = embree_device();
    top_ = rtcNewScene(device);
    check_embree(device, "rtcNewScene (the top level)");
    try {
        rtcSetSceneBuildQuality(top_, quality == EmbreeQuality::low      ? RTC_BUILD_QUALITY_LOW
                                      : quality == EmbreeQuality::medium ? RTC_BUILD_QUALITY_MEDIUM
                                                                         : RTC_BUILD_QUALITY_HIGH);
        const auto setup_start = std::chrono::steady_clock::now();
        for (size_t p = 0; p < placements.size(); ++p) {
            const MeshPlacement& placement = placements[p];
            if (placement.mesh >= meshes_.size())
                throw Error("Embree two-level scene: placement " + std::to_string(p) + " names mesh " +
                            std::to_string(placement.mesh) + " of " + std::to_string(meshes_.size()));
            if (!placement.visible(0xFFFFFFFFu)) continue;  // a zero mask on its chain: no ray sees it
            RTCGeometry instance = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
            rtcSetGeometryInstancedScene(instance, meshes_[placement.mesh]->handle());
            const std::array<float, 12> m = composed(placement.transforms);
            rtcSetGeometryTransform(instance, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, m.data());
            rtcCommitGeometry(instance);
            rtcAttachGeometryByID(top_, instance, unsigned(paths_.size()));
            rtcReleaseGeometry(instance);
            paths_.push_back(placement.path);
            geometries_.push_back(placement.geometry);
        }
        top_setup_ms_ =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - setup_start).count();
        check_embree(device, "setting up the instance geometries");
        if (paths_.empty()) throw Error("Embree two-level scene: no visible placement");
        const int64_t bytes_before = embree_allocated_bytes();
        const auto start = std::chrono::steady_clock::now();
        rtcCommitScene(top_);
        top_build_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        top_bytes_ = size_t(std::max<int64_t>(0, embree_allocated_bytes() - bytes_before));
        check_embree(device, "rtcCommitScene (the top level)");
    } catch (...) {
        rtcReleaseScene(top_);
        top_ = nullptr;
        throw;
    }
}

EmbreeInstancedScene::~EmbreeInstancedScene() {
    if (top_) rtcReleaseScene(top_);
}

size_t EmbreeInstancedScene::memory_bytes() const {
    size_t bytes = top_bytes_;
    for (const auto& mesh : meshes_) bytes += mesh->memory_bytes();
    return bytes;
}

SceneHit EmbreeInstancedScene::to_hit(unsigned instance, unsigned primitive, float t, float u, float v) const {
    SceneHit hit;
    if (instance == RTC_INVALID_GEOMETRY_ID) return hit;
    hit.t = t;
    hit.u = u;
    hit.v = v;
    hit.primitive = primitive;
    hit.geometry = geometries_[instance];
    hit.instance = paths_[instance];
    return hit;
}

SceneHit EmbreeInstancedScene::intersect(const Ray& ray) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rayhit;
    rayhit.ray = to_embree(ray);
    rayhit.hit.geomID = rayhit.hit.primID = rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(top_, &context, &rayhit);
    return to_hit(rayhit.hit.instID[0], rayhit.hit.primID, rayhit.ray.tfar, rayhit.hit.u, rayhit.hit.v);
}

bool EmbreeInstancedScene::occluded(const Ray& ray) const { return occluded1(top_, ray); }

void EmbreeInstancedScene::intersect(std::span<const Ray> rays, std::span<SceneHit> hits) const {
    answer_each(rays, hits, "intersect (two-level)", [this](const Ray& ray) { return intersect(ray); });
}

void EmbreeInstancedScene::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded_out) const {
    answer_each(rays, occluded_out, "occluded (two-level)",
                [this](const Ray& ray) { return uint8_t(occluded(ray) ? 1 : 0); });
}

void EmbreeInstancedScene::intersect16(std::span<const Ray> rays, std::span<SceneHit> hits) const {
    check_sizes(rays.size(), hits.size(), "intersect16 (two-level)");
    for_each_packet(rays, top_, [&](size_t group, int lanes, const RTCRayHit16& packet) {
        for (int i = 0; i < lanes; ++i)
            hits[group + i] = to_hit(packet.hit.instID[0][i], packet.hit.primID[i], packet.ray.tfar[i], packet.hit.u[i],
                                     packet.hit.v[i]);
    });
}

void EmbreeInstancedScene::occluded16(std::span<const Ray> rays, std::span<uint8_t> occluded_out) const {
    check_sizes(rays.size(), occluded_out.size(), "occluded16 (two-level)");
    for_each_occlusion_packet(rays, top_, [&](size_t group, int lanes, const RTCRay16& packet) {
        for (int i = 0; i < lanes; ++i) occluded_out[group + i] = packet.tfar[i] == -kInfinity ? 1 : 0;
    });
}

}  // namespace spacebvh::tools
