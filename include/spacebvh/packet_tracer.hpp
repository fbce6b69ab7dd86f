// Coherent ray packets with frustum culling (Wald, Boulos, Shirley 2007): consecutive groups of rays
// traced together through an 8-wide BVH, for primary rays of image tiles. Answers equal the
// single-ray kernels' exactly; see src/trace/packet_kernel.inl.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "spacebvh/wide_tracer.hpp"

namespace spacebvh {

class PacketTracer final : public Tracer {
public:
    // `packet_size` consecutive rays of a batch form a packet (1..256; 64 = an 8x8 tile, 256 = 16x16
    // when the rays are in tile_order). Node tests: scalar, avx2 or avx512 (8-wide nodes).
    PacketTracer(const Scene& scene, const Bvh& bvh, uint32_t packet_size = 64, NodeTest test = NodeTest::best,
                 WideCollapse collapse = WideCollapse::sah_optimal);
    ~PacketTracer() override;
    PacketTracer(PacketTracer&&) noexcept;
    PacketTracer& operator=(PacketTracer&&) noexcept;

    // Single rays use the 8-wide single-ray kernel.
    Hit intersect(const Ray& ray) const override;
    Hit intersect(const Ray& ray, TraversalStats& stats) const override;
    bool occluded(const Ray& ray) const override;
    bool occluded(const Ray& ray, TraversalStats& stats) const override;
    // Batches go packet by packet; a packet whose rays do not share direction signs goes ray by ray.
    void intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats = nullptr) const override;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats = nullptr) const override;
    size_t memory_bytes() const override;
    std::string name() const override;  // e.g. "packet8-avx512" (8x8 = 64 rays)

    uint32_t packet_size() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

// The order that groups the rays of a row-major width x height image (../shared/spec/rays.md's primary
// rays) into tile x tile blocks, blocks row-major; edge blocks are smaller. order[k] is the index of
// the k-th ray to trace.
std::vector<uint32_t> tile_order(uint32_t width, uint32_t height, uint32_t tile);

}  // namespace spacebvh
