// SPDX-License-Identifier: MIT
// Embree 3 adapter (see embree_scene.hpp).
#include "spacebvh/tools/embree_scene.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <string>
#include <utility>

#include "spacebvh/error.hpp"
#include "tools/embree/embree_internal.hpp"

namespace spacebvh::tools {

using namespace embree_detail;

namespace {

// Embree reports errors through a callback on the thread that made the failing call; we keep the
// message there and turn it into an Error after the call (throwing through Embree's C API is not safe).
thread_local std::string t_last_embree_message;

void on_embree_error(void*, RTCError code, const char* message) { t_last_embree_message = message ? message : ""; }

// Net bytes the device has allocated (Embree reports before allocating, after freeing).
std::atomic<int64_t> g_embree_bytes{0};

bool on_embree_memory(void*, ssize_t bytes, bool /*post*/) {
    g_embree_bytes.fetch_add(int64_t(bytes), std::memory_order_relaxed);
    return true;  // never refuse an allocation
}

const char* error_name(RTCError code) {
    switch (code) {
        case RTC_ERROR_NONE:
            return "none";
        case RTC_ERROR_UNKNOWN:
            return "unknown error";
        case RTC_ERROR_INVALID_ARGUMENT:
            return "invalid argument";
        case RTC_ERROR_INVALID_OPERATION:
            return "invalid operation";
        case RTC_ERROR_OUT_OF_MEMORY:
            return "out of memory";
        case RTC_ERROR_UNSUPPORTED_CPU:
            return "unsupported CPU";
        case RTC_ERROR_CANCELLED:
            return "cancelled";
    }
    return "error";
}

}  // namespace

int64_t embree_detail::embree_allocated_bytes() { return g_embree_bytes.load(); }

// Throws Error if the last Embree call on this thread failed.
void check_embree(RTCDevice device, const char* what) {
    const RTCError code = rtcGetDeviceError(device);
    if (code == RTC_ERROR_NONE) return;
    std::string message = std::string("Embree: ") + what + " failed: " + error_name(code);
    if (!t_last_embree_message.empty()) message += " (" + t_last_embree_message + ")";
    t_last_embree_message.clear();
    throw Error(message);
}

const char* to_string(EmbreeQuality quality) {
    switch (quality) {
        case EmbreeQuality::low:
            return "low";
        case EmbreeQuality::medium:
            return "medium";
        case EmbreeQuality::high:
            return "high";
    }
    return "unknown";
}

EmbreeQuality parse_embree_quality(const std::string& text) {
    if (text == "low") return EmbreeQuality::low;
    if (text == "medium") return EmbreeQuality::medium;
    if (text == "high") return EmbreeQuality::high;
    throw Error("unknown Embree build quality '" + text + "' (expected low, medium or high)");
}

RTCDevice embree_device() {
    // Created once (thread-safe static initialisation) and deliberately never released: releasing it
    // during static destruction could race with oneTBB's own shutdown.
    static const RTCDevice device = [] {
        // SPACEBVH_EMBREE_CONFIG: Embree's own device configuration, for studying its side (e.g.
        // "verbose=3" prints the statistics of every BVH it builds: SAH, nodes, fill, depth).
        const char* config = std::getenv("SPACEBVH_EMBREE_CONFIG");
        RTCDevice d = rtcNewDevice(config);
        if (!d)
            throw Error("Embree: cannot create a device" +
                        (config ? " with SPACEBVH_EMBREE_CONFIG='" + std::string(config) + "'" : std::string()) +
                        " (error " + std::string(error_name(rtcGetDeviceError(nullptr))) + ")");
        rtcSetDeviceErrorFunction(d, on_embree_error, nullptr);
        rtcSetDeviceMemoryMonitorFunction(d, on_embree_memory, nullptr);
        return d;
    }();
    return device;
}

EmbreeScene::EmbreeScene(const Scene& scene, EmbreeQuality quality) : quality_(quality) {
    const size_t triangle_count = scene.triangles.size();
    if (triangle_count == 0) throw Error("Embree: the scene '" + scene.name + "' has no triangles");
    if (triangle_count > size_t(UINT32_MAX) / 3)
        throw Error("Embree: the scene '" + scene.name + "' has too many triangles for 32-bit indices");

    // A triangle soup, 3 vertices per triangle: index i*3+k is vertex k of triangle i. Embree reads
    // vertices with 16-byte loads, so the buffer carries 16 bytes of padding after the last vertex.
    vertices_.assign(triangle_count * 9 + 4, 0.0f);
    indices_.resize(triangle_count * 3);
    for (size_t i = 0; i < triangle_count; ++i) {
        const Triangle& tri = scene.triangles[i];
        for (int k = 0; k < 3; ++k) {
            const Vec3 v = tri.vertex(k);
            vertices_[i * 9 + k * 3 + 0] = v.x;
            vertices_[i * 9 + k * 3 + 1] = v.y;
            vertices_[i * 9 + k * 3 + 2] = v.z;
            indices_[i * 3 + k] = uint32_t(i * 3 + k);
        }
    }

    RTCDevice device = embree_device();
    scene_ = rtcNewScene(device);
    check_embree(device, "rtcNewScene");
    try {
        const RTCBuildQuality build_quality = quality == EmbreeQuality::low      ? RTC_BUILD_QUALITY_LOW
                                              : quality == EmbreeQuality::medium ? RTC_BUILD_QUALITY_MEDIUM
                                                                                 : RTC_BUILD_QUALITY_HIGH;
        rtcSetSceneBuildQuality(scene_, build_quality);
        rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_NONE);  // static scene, Embree's default (non-robust) kernels

        RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        check_embree(device, "rtcNewGeometry");
        rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices_.data(), 0,
                                   3 * sizeof(float), triangle_count * 3);
        rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices_.data(), 0,
                                   3 * sizeof(uint32_t), triangle_count);
        rtcCommitGeometry(geometry);
        rtcAttachGeometryByID(scene_, geometry, 0);  // geomID 0, so primID is our triangle index
        rtcReleaseGeometry(geometry);
        check_embree(device, "setting up the triangle geometry");

        const int64_t bytes_before = g_embree_bytes.load();
        const auto start = std::chrono::steady_clock::now();
        rtcCommitScene(scene_);
        const auto stop = std::chrono::steady_clock::now();
        const int64_t bytes_after = g_embree_bytes.load();
        check_embree(device, "rtcCommitScene");
        build_ms_ = std::chrono::duration<double, std::milli>(stop - start).count();
        memory_bytes_ = size_t(std::max<int64_t>(0, bytes_after - bytes_before));
    } catch (...) {
        release();
        throw;
    }
}

EmbreeScene::~EmbreeScene() { release(); }

void EmbreeScene::release() noexcept {
    if (scene_) rtcReleaseScene(scene_);
    scene_ = nullptr;
}

// Moving keeps the buffers' heap storage (std::vector move), so Embree's pointers stay valid.
EmbreeScene::EmbreeScene(EmbreeScene&& other) noexcept
    : quality_(other.quality_),
      scene_(std::exchange(other.scene_, nullptr)),
      vertices_(std::move(other.vertices_)),
      indices_(std::move(other.indices_)),
      build_ms_(other.build_ms_),
      memory_bytes_(other.memory_bytes_) {}

EmbreeScene& EmbreeScene::operator=(EmbreeScene&& other) noexcept {
    if (this != &other) {
        release();
        quality_ = other.quality_;
        scene_ = std::exchange(other.scene_, nullptr);
        vertices_ = std::move(other.vertices_);
        indices_ = std::move(other.indices_);
        build_ms_ = other.build_ms_;
        memory_bytes_ = other.memory_bytes_;
    }
    return *this;
}

size_t EmbreeScene::buffer_bytes() const {
    return vertices_.size() * sizeof(float) + indices_.size() * sizeof(uint32_t);
}

Hit EmbreeScene::intersect(const Ray& ray) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rayhit;
    rayhit.ray = to_embree(ray);
    rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rayhit.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &context, &rayhit);
    Hit hit;
    if (rayhit.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        hit.t = rayhit.ray.tfar;
        hit.primitive = rayhit.hit.primID;
        hit.u = rayhit.hit.u;
        hit.v = rayhit.hit.v;
    }
    return hit;
}

bool EmbreeScene::occluded(const Ray& ray) const { return occluded1(scene_, ray); }

void EmbreeScene::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
    answer_each(rays, hits, "intersect", [this](const Ray& ray) { return intersect(ray); });
}

void EmbreeScene::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded_out) const {
    answer_each(rays, occluded_out, "occluded", [this](const Ray& ray) { return uint8_t(occluded(ray) ? 1 : 0); });
}

void EmbreeScene::intersect16(std::span<const Ray> rays, std::span<Hit> hits) const {
    check_sizes(rays.size(), hits.size(), "intersect16");
    for_each_packet(rays, scene_, [&](size_t group, int lanes, const RTCRayHit16& packet) {
        for (int i = 0; i < lanes; ++i) {
            Hit hit;
            if (packet.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID) {
                hit.t = packet.ray.tfar[i];
                hit.primitive = packet.hit.primID[i];
                hit.u = packet.hit.u[i];
                hit.v = packet.hit.v[i];
            }
            hits[group + i] = hit;
        }
    });
}

void EmbreeScene::occluded16(std::span<const Ray> rays, std::span<uint8_t> occluded_out) const {
    check_sizes(rays.size(), occluded_out.size(), "occluded16");
    for_each_occlusion_packet(rays, scene_, [&](size_t group, int lanes, const RTCRay16& packet) {
        for (int i = 0; i < lanes; ++i) occluded_out[group + i] = packet.tfar[i] == -kInfinity ? 1 : 0;
    });
}

}  // namespace spacebvh::tools
