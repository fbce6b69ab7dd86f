// SPDX-License-Identifier: MIT
#include "spacebvh/packet_tracer.hpp"

#include "spacebvh/error.hpp"
#include "trace/kernels.hpp"
#include "trace/traversal_common.hpp"
#include "trace/wide_layout.hpp"

namespace spacebvh {

struct PacketTracer::Impl {
    uint32_t packet_size;
    NodeTest test;
    WideCollapse collapse;
    trace::WideLayout<8> layout;
    trace::SingleRayKernels single;
    trace::PacketKernels packets;
};

PacketTracer::PacketTracer(const Scene& scene, const Bvh& bvh, uint32_t packet_size, NodeTest test, WideCollapse collapse) {
    if (packet_size < 1 || packet_size > trace::kMaxPacket)
        throw Error("packet size must be in [1, " + std::to_string(trace::kMaxPacket) + "], got " + std::to_string(packet_size));
    if (test == NodeTest::best) test = supported_node_tests(8).back();
    if (!trace::width_has(8, test)) throw Error(std::string("packets have no node test '") + to_string(test) + "'");
    if (!trace::cpu_has(test)) throw Error(std::string("this CPU lacks the instructions of node test '") + to_string(test) + "'");
    impl_ = std::make_unique<Impl>();
    impl_->packet_size = packet_size;
    impl_->test = test;
    impl_->collapse = collapse;
    impl_->layout = trace::collapse_to_wide<8>(scene, bvh, collapse);
    impl_->single = trace::single_ray_kernels(8, test);
    impl_->packets = trace::packet_kernels(test);
}

PacketTracer::~PacketTracer() = default;
PacketTracer::PacketTracer(PacketTracer&&) noexcept = default;
PacketTracer& PacketTracer::operator=(PacketTracer&&) noexcept = default;

Hit PacketTracer::intersect(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    impl_->single.closest(&impl_->layout, ray, hit);
    return hit;
}

Hit PacketTracer::intersect(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    impl_->single.closest_stats(&impl_->layout, ray, hit, &stats);
    return hit;
}

bool PacketTracer::occluded(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return impl_->single.occluded(&impl_->layout, ray, unused);
}

bool PacketTracer::occluded(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return impl_->single.occluded_stats(&impl_->layout, ray, unused, &stats);
}

namespace {
// Runs `trace(first, count, stats)` for every packet of `size` consecutive rays, in parallel.
template <typename Trace>
void for_each_packet(size_t ray_count, size_t size, TraversalStats* stats, Trace&& trace) {
    const size_t packets = (ray_count + size - 1) / size;
    trace::for_each_range(packets, 16, stats, [&](size_t begin, size_t end, TraversalStats& local) {
        for (size_t p = begin; p < end; ++p)
            trace(p * size, uint32_t(std::min(size, ray_count - p * size)), stats ? &local : nullptr);
    });
}
}  // namespace

void PacketTracer::intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats) const {
    for_each_packet(rays.size(), impl_->packet_size, stats, [&](size_t first, uint32_t count, TraversalStats* s) {
        impl_->packets.closest(&impl_->layout, &rays[first], count, &hits[first], s);
    });
}

void PacketTracer::occluded(std::span<const Ray> rays, std::span<uint8_t> result, TraversalStats* stats) const {
    for_each_packet(rays.size(), impl_->packet_size, stats, [&](size_t first, uint32_t count, TraversalStats* s) {
        impl_->packets.occluded(&impl_->layout, &rays[first], count, &result[first], s);
    });
}

size_t PacketTracer::memory_bytes() const {
    return impl_->layout.nodes.size() * sizeof(trace::WideNode<8>) + impl_->layout.packs.size() * sizeof(trace::TrianglePack);
}

std::string PacketTracer::name() const {
    // "packet8" for an 8x8 tile's 64 rays; other sizes by their count, "packet-x100".
    uint32_t tile = 1;
    while ((tile + 1) * (tile + 1) <= impl_->packet_size) ++tile;
    std::string shape = std::to_string(tile);
    if (tile * tile != impl_->packet_size) shape = "-x" + std::to_string(impl_->packet_size);
    return "packet" + shape + "-" + to_string(impl_->test) + collapse_suffix(impl_->collapse);
}

uint32_t PacketTracer::packet_size() const { return impl_->packet_size; }

std::vector<uint32_t> tile_order(uint32_t width, uint32_t height, uint32_t tile) {
    if (tile == 0) throw Error("tile size must be at least 1");
    std::vector<uint32_t> order;
    order.reserve(size_t(width) * height);
    for (uint32_t ty = 0; ty < height; ty += tile)
        for (uint32_t tx = 0; tx < width; tx += tile)
            for (uint32_t y = ty; y < std::min(height, ty + tile); ++y)
                for (uint32_t x = tx; x < std::min(width, tx + tile); ++x) order.push_back(y * width + x);
    return order;
}

}  // namespace spacebvh
