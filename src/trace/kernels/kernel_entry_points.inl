// SPDX-License-Identifier: MIT
// Included after wide_kernel.inl and packet_kernel.inl; see kernel_instances.cpp.

// The entry points of both kernels, which kernel_instances.cpp puts in its tables.
template <class S>
struct Kernels {
    static bool closest(const void* layout, const Ray& ray, Hit& hit) {
        return traverse<S, false, false>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, nullptr);
    }
    static bool closest_stats(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
        return traverse<S, false, true>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, stats);
    }
    static bool occluded(const void* layout, const Ray& ray, Hit& hit) {
        return traverse<S, true, false>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, nullptr);
    }
    static bool occluded_stats(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
        return traverse<S, true, true>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, stats);
    }
    // The same over the moller leaf test (moller_filter.hpp).
    static bool closest_moller(const void* layout, const Ray& ray, Hit& hit) {
        return traverse<S, false, false, true>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, nullptr);
    }
    static bool closest_moller_stats(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
        return traverse<S, false, true, true>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, stats);
    }
    static bool occluded_moller(const void* layout, const Ray& ray, Hit& hit) {
        return traverse<S, true, false, true>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, nullptr);
    }
    static bool occluded_moller_stats(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
        return traverse<S, true, true, true>(*static_cast<const WideLayout<S::kLanes>*>(layout), ray, hit, stats);
    }
    // Over quantized nodes (quantized_layout.hpp), either leaf test; 8-wide policies only.
    template <bool kMoller>
    static bool quantized_closest(const void* layout, const Ray& ray, Hit& hit) {
        return traverse<S, false, false, kMoller>(*static_cast<const QuantizedLayout8*>(layout), ray, hit, nullptr);
    }
    template <bool kMoller>
    static bool quantized_closest_stats(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
        return traverse<S, false, true, kMoller>(*static_cast<const QuantizedLayout8*>(layout), ray, hit, stats);
    }
    template <bool kMoller>
    static bool quantized_occluded(const void* layout, const Ray& ray, Hit& hit) {
        return traverse<S, true, false, kMoller>(*static_cast<const QuantizedLayout8*>(layout), ray, hit, nullptr);
    }
    template <bool kMoller>
    static bool quantized_occluded_stats(const void* layout, const Ray& ray, Hit& hit, TraversalStats* stats) {
        return traverse<S, true, true, kMoller>(*static_cast<const QuantizedLayout8*>(layout), ray, hit, stats);
    }
    static void packet_closest(const void* layout, const Ray* rays, uint32_t count, Hit* hits, TraversalStats* stats) {
        const auto& wide = *static_cast<const WideLayout<S::kLanes>*>(layout);
        if (stats)
            trace_packet<S, false, true>(wide, rays, count, hits, nullptr, stats);
        else
            trace_packet<S, false, false>(wide, rays, count, hits, nullptr, nullptr);
    }
    static void packet_occluded(const void* layout, const Ray* rays, uint32_t count, uint8_t* occluded,
                                TraversalStats* stats) {
        const auto& wide = *static_cast<const WideLayout<S::kLanes>*>(layout);
        if (stats)
            trace_packet<S, true, true>(wide, rays, count, nullptr, occluded, stats);
        else
            trace_packet<S, true, false>(wide, rays, count, nullptr, occluded, nullptr);
    }
};
