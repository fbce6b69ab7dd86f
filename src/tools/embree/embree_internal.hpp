// SPDX-License-Identifier: MIT
// What the Embree adapters share (embree_scene.cpp, embree_instances.cpp): our rays as Embree's, and
// the chunked oneTBB loop they trace batches in.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>

#include <embree3/rtcore.h>
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>

#include "spacebvh/error.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh::tools::embree_detail {

// Net bytes the process-wide device has allocated so far (its memory monitor): the difference over a
// commit is what the commit allocated, exact while no other Embree scene is built or released.
int64_t embree_allocated_bytes();

constexpr size_t kChunkRays = 1024;  // rays per oneTBB task

// Runs body(first, last) over chunks of exactly kChunkRays rays (the last one shorter), one task per
// chunk, in the caller's arena.
template <class Body>
void for_each_chunk(size_t count, Body body) {
    const size_t chunks = (count + kChunkRays - 1) / kChunkRays;
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, chunks, 1),
        [&](const tbb::blocked_range<size_t>& range) {
            for (size_t c = range.begin(); c != range.end(); ++c)
                body(c * kChunkRays, std::min(count, (c + 1) * kChunkRays));
        },
        tbb::simple_partitioner());
}

inline void check_sizes(size_t rays, size_t results, const char* what) {
    if (rays != results)
        throw Error(std::string("Embree ") + what + ": " + std::to_string(rays) + " rays but room for " +
                    std::to_string(results) + " results");
}

inline RTCRay to_embree(const Ray& ray) {
    RTCRay r;
    r.org_x = ray.org.x;
    r.org_y = ray.org.y;
    r.org_z = ray.org.z;
    r.tnear = ray.tmin;
    r.dir_x = ray.dir.x;
    r.dir_y = ray.dir.y;
    r.dir_z = ray.dir.z;
    r.time = 0.0f;
    r.tfar = ray.tmax;
    r.mask = ~0u;
    r.id = 0;
    r.flags = 0;
    return r;
}

// Lane `i` of a 16-wide packet.
inline void set_lane(RTCRay16& p, int i, const Ray& ray) {
    p.org_x[i] = ray.org.x;
    p.org_y[i] = ray.org.y;
    p.org_z[i] = ray.org.z;
    p.tnear[i] = ray.tmin;
    p.dir_x[i] = ray.dir.x;
    p.dir_y[i] = ray.dir.y;
    p.dir_z[i] = ray.dir.z;
    p.time[i] = 0.0f;
    p.tfar[i] = ray.tmax;
    p.mask[i] = ~0u;
    p.id[i] = uint32_t(i);
    p.flags[i] = 0;
}

// rtcOccluded1 of one ray.
inline bool occluded1(RTCScene scene, const Ray& ray) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay r = to_embree(ray);
    rtcOccluded1(scene, &context, &r);
    return r.tfar == -kInfinity;  // Embree marks an occluded ray with tfar = -inf
}

// out[i] = answer(rays[i]) for every ray, chunked as for_each_chunk; `what` names the call in the
// error for spans of different lengths.
template <class Out, class Answer>
void answer_each(std::span<const Ray> rays, std::span<Out> out, const char* what, Answer answer) {
    check_sizes(rays.size(), out.size(), what);
    for_each_chunk(rays.size(), [&](size_t first, size_t last) {
        for (size_t i = first; i < last; ++i) out[i] = answer(rays[i]);
    });
}

// Consecutive groups of 16 rays of `rays`, chunked as for_each_chunk: each lane set by
// `fill(packet, lane, ray)` (the last group's idle lanes masked, a copy of a valid ray), the packet
// traced by `trace(valid, context, packet)`, its answers read by `take(first ray, lanes, packet)`.
template <class Packet, class Fill, class Trace, class Take>
void for_each_group_of_16(std::span<const Ray> rays, Fill fill, Trace trace, Take take) {
    for_each_chunk(rays.size(), [&](size_t first, size_t last) {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        Packet packet;
        alignas(64) int valid[16];
        for (size_t group = first; group < last; group += 16) {
            const int lanes = int(std::min<size_t>(16, last - group));
            for (int i = 0; i < 16; ++i) {
                valid[i] = i < lanes ? -1 : 0;
                fill(packet, i, rays[group + std::min(i, lanes - 1)]);
            }
            trace(valid, &context, packet);
            take(group, lanes, const_cast<const Packet&>(packet));
        }
    });
}

// rtcIntersect16 over `rays` in groups of 16 (for_each_group_of_16).
template <class Take>
void for_each_packet(std::span<const Ray> rays, RTCScene scene, Take take) {
    for_each_group_of_16<RTCRayHit16>(
        rays,
        [](RTCRayHit16& packet, int i, const Ray& ray) {
            set_lane(packet.ray, i, ray);
            packet.hit.geomID[i] = packet.hit.primID[i] = packet.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        },
        [scene](int* valid, RTCIntersectContext* context, RTCRayHit16& packet) {
            rtcIntersect16(valid, scene, context, &packet);
        },
        take);
}

// rtcOccluded16 likewise.
template <class Take>
void for_each_occlusion_packet(std::span<const Ray> rays, RTCScene scene, Take take) {
    for_each_group_of_16<RTCRay16>(
        rays, [](RTCRay16& packet, int i, const Ray& ray) { set_lane(packet, i, ray); },
        [scene](int* valid, RTCIntersectContext* context, RTCRay16& packet) {
            rtcOccluded16(valid, scene, context, &packet);
        },
        take);
}

}  // namespace spacebvh::tools::embree_detail
