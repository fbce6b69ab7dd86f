// SPDX-License-Identifier: MIT
// The compiled kernels (kernel_instances.cpp): one copy per instruction set, looked up at run time.
// A Tracer holds the table of the kernel and node test it was asked for.
#pragma once

#include <cstdint>

#include "spacebvh/trace.hpp"

namespace spacebvh::trace {

bool cpu_has(NodeTest test);
bool width_has(int width, NodeTest test);

// Single rays over a WideLayout<width>, or a QuantizedLayout8 for NodeFormat::quantized (passed as
// const void*). Stats may not be null in *_stats.
struct SingleRayKernels {
    bool (*closest)(const void* layout, const Ray& ray, Hit& hit);
    bool (*closest_stats)(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats);
    bool (*occluded)(const void* layout, const Ray& ray, Hit& hit);
    bool (*occluded_stats)(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats);
};
SingleRayKernels single_ray_kernels(int width, NodeTest test, LeafTest leaf_test = LeafTest::watertight,
                                    NodeFormat format = NodeFormat::full);

// A packet of `count` (<= kMaxPacket) rays over a WideLayout<8>. Stats may be null.
inline constexpr uint32_t kMaxPacket = 256;
struct PacketKernels {
    void (*closest)(const void* layout, const Ray* rays, uint32_t count, Hit* hits, TraversalStats* stats);
    void (*occluded)(const void* layout, const Ray* rays, uint32_t count, uint8_t* occluded, TraversalStats* stats);
};
PacketKernels packet_kernels(NodeTest test);

// One tracer's single-ray kernel as a caller that traces many rays through many tracers calls it
// (a scene, per instance entered): the functions and the layout they take, with none of
// Tracer::intersect's per-call work. The caller keeps the standard floating-point mode
// (StandardFloatingPointMode) around the calls, as Tracer::intersect does per call. Valid as long
// as the tracer lives, refits included (Tracer::refit keeps its layout's address).
struct KernelEntry {
    bool (*closest)(const void* layout, const Ray& ray, Hit& hit) = nullptr;
    bool (*occluded)(const void* layout, const Ray& ray, Hit& hit) = nullptr;
    const void* layout = nullptr;
};

}  // namespace spacebvh::trace
