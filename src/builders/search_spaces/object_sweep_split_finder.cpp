// SPDX-License-Identifier: MIT
#include "builders/search_spaces/object_sweep_split_finder.hpp"

#include <immintrin.h>

#include <algorithm>
#include <array>
#include <bit>
#include <utility>
#include <vector>

#include "builders/driver/simd_box.hpp"

namespace spacebvh::builders {
namespace {

struct KeyedReference {
    uint64_t key;
    uint32_t index;
};

// Least-significant-digit radix sort on the low `key_bits` bits of the keys, 11 bits per pass (2048
// buckets, which stay in the L1/L2 cache), stable. One counting pass makes all histograms; a digit
// that is the same for every key (the high bits of the centroids in a small node, often) is skipped.
void radix_sort(std::vector<KeyedReference>& items, int key_bits) {
    constexpr int kDigitBits = 11;
    constexpr uint32_t kBuckets = 1u << kDigitBits, kMask = kBuckets - 1;
    const int digits = (key_bits + kDigitBits - 1) / kDigitBits;
    const size_t count = items.size();
    std::vector<std::array<uint32_t, kBuckets>> histograms(digits, std::array<uint32_t, kBuckets>{});
    for (const KeyedReference& item : items)
        for (int digit = 0; digit < digits; ++digit) ++histograms[digit][(item.key >> (kDigitBits * digit)) & kMask];
    std::vector<KeyedReference> scratch(count);
    for (int digit = 0; digit < digits; ++digit) {
        std::array<uint32_t, kBuckets>& histogram = histograms[digit];
        const int shift = kDigitBits * digit;
        if (histogram[(items[0].key >> shift) & kMask] == count) continue;
        uint32_t offset = 0;
        for (uint32_t& bucket : histogram) offset += std::exchange(bucket, offset);
        for (const KeyedReference& item : items) scratch[histogram[(item.key >> shift) & kMask]++] = item;
        items.swap(scratch);
    }
}

// Sorts the references by CentroidOrder{axis}, but on precomputed integer keys instead of computing
// two centroids per comparison and moving 28-byte references: (centroid as an order-preserving
// integer, primitive) in 32 + B bits, B the bit width of the node's largest primitive id (fewer radix
// passes than a fixed 64-bit key), then one gather. The primitive must be in the key: most
// references share their centroid with another (the two triangles of a quad, coplanar triangles on an
// axis-aligned plane; most references of architectural scenes). Only references equal on both
// (pieces of one triangle with the same centroid) are compared by CentroidOrder itself, so the order
// is the same total order.
}  // namespace

void sort_in_centroid_order(std::span<const Reference> references, int axis, std::vector<Reference>& sorted) {
    const size_t count = references.size();
    const CentroidOrder order{axis};
    if (count <= 64) {
        sorted.assign(references.begin(), references.end());
        std::sort(sorted.begin(), sorted.end(), order);
        return;
    }
    uint32_t largest_primitive = 0;
    for (const Reference& reference : references) largest_primitive = std::max(largest_primitive, reference.primitive);
    const int primitive_bits = std::bit_width(largest_primitive);
    std::vector<KeyedReference> keyed(count);
    for (size_t i = 0; i < count; ++i) {
        // + 0.0f turns -0 into +0 (they compare equal as floats); input coordinates are finite.
        const uint32_t bits = std::bit_cast<uint32_t>(references[i].centroid(axis) + 0.0f);
        const uint32_t ordered = (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);
        keyed[i] = {(uint64_t(ordered) << primitive_bits) | references[i].primitive, uint32_t(i)};
    }
    if (count > 256) {  // below, std::sort beats clearing the histograms
        radix_sort(keyed, 32 + primitive_bits);
    } else {
        std::sort(keyed.begin(), keyed.end(),
                  [](const KeyedReference& a, const KeyedReference& b) { return a.key < b.key; });
    }
    for (size_t begin = 0; begin < count;) {
        size_t end = begin + 1;
        while (end < count && keyed[end].key == keyed[begin].key) ++end;
        if (end - begin > 1)
            std::sort(keyed.begin() + begin, keyed.begin() + end,
                      [&](const KeyedReference& a, const KeyedReference& b) {
                          return order(references[a.index], references[b.index]);
                      });
        begin = end;
    }
    sorted.resize(count);
    for (size_t i = 0; i < count; ++i) sorted[i] = references[keyed[i].index];
}

void sort_in_centroid_order(std::span<Reference> references, int axis) {
    std::vector<Reference> sorted;
    sort_in_centroid_order(references, axis, sorted);
    std::copy(sorted.begin(), sorted.end(), references.begin());
}

namespace {

// The axes a node can be cut on (its centroids not all equal there), in the order to sweep them:
// first one on which its references are already sorted, then the others. Without the driver's
// orders (the lookahead's subtrees) a node arrives in its parent's order, which apply_split keeps
// and SplitSearch::order_for_apply makes the x order, so one of its three sorts is skipped (the
// check is linear and stops at the first reference out of order). The sweep's answer does not
// depend on this order: CheapestSplit and SplitCandidates break ties by axis, not by the order of
// offers across axes.
struct SweepOrder {
    std::array<int, 3> axes{};
    int count = 0;
    bool first_sorted = false;  // axes[0] needs no sort
};
// With the driver's orders (`presorted`) every axis is sorted already and nothing is checked.
SweepOrder sweep_order(std::span<const Reference> references, const ReferenceSummary& node, bool presorted) {
    SweepOrder order;
    for (int axis = 0; axis < 3; ++axis) {
        if (node.centroid_bounds.lo[axis] == node.centroid_bounds.hi[axis]) continue;  // no cut separates
        order.axes[order.count++] = axis;
        if (!presorted && !order.first_sorted &&
            std::is_sorted(references.begin(), references.end(), CentroidOrder{axis})) {
            order.first_sorted = true;
            std::rotate(order.axes.begin(), order.axes.begin() + order.count - 1, order.axes.begin() + order.count);
        }
    }
    return order;
}

// Offers every cut that beats the sink's threshold (CheapestSplit or SplitCandidates). Boxes are
// swept in SSE registers (SimdBox: the same bytes and areas as AABBs), and without an overlap
// penalty a cut is priced from the areas alone: the suffix areas come from the right-to-left pass,
// and boxes are made only for the cuts offered to the sink.
template <typename Sink>
void sweep(const NodeContext& context, const CostModel& cost, Sink& sink) {
    const std::span<const Reference> references = context.references;
    const ReferenceSummary& node = context.summary;
    const size_t count = references.size();
    if (count < 2) return;
    const float node_area = node.bounds.area();
    const bool penalised = cost.overlap_penalty != 0.0f;
    const __m128 node_extent = _mm_sub_ps(simd(node.bounds.hi), simd(node.bounds.lo));
    // Right-to-left suffix boxes and their areas; reused across axes.
    std::vector<SimdBox> suffix_bounds(count);
    std::vector<float> suffix_area(count);
    const bool presorted = std::ranges::all_of(context.sorted, [&](auto sorted) { return sorted.size() == count; });
    const SweepOrder order = sweep_order(references, node, presorted);
    std::vector<Reference> scratch;  // a sorted copy: the node's references keep their order
    for (int k = 0; k < order.count; ++k) {
        const int axis = order.axes[k];
        // The order is total, so the sort gives one answer: the driver's sorted copy, or this one.
        std::span<const Reference> sorted = references;
        if (presorted) {
            sorted = context.sorted[axis];
        } else if (k > 0 || !order.first_sorted) {
            sort_in_centroid_order(references, axis, scratch);
            sorted = scratch;
        }

        SimdBox right;
        for (size_t i = count; i-- > 1;) {
            right.extend_as_aabb(sorted[i].bounds);
            suffix_bounds[i] = right;
            suffix_area[i] = right.area();
        }
        SimdBox left;
        for (size_t i = 1; i < count; ++i) {
            left.extend_as_aabb(sorted[i - 1].bounds);
            // As CostModel::split_cost prices the cut. The overlap factor is >= 1 and multiplies a
            // non-negative term, so the plain SAH price is a lower bound, to the bit: a cut that loses
            // without the penalty needs no overlap (three divisions).
            const float left_area = left.area();
            float split_cost = cost.split_cost_of_areas(node_area, left_area, i, suffix_area[i], count - i);
            if (!(split_cost < sink.threshold(axis))) continue;
            if (penalised) {
                const float overlap_factor = cost.overlap_factor(overlap_fraction(node_extent, left, suffix_bounds[i]));
                if (overlap_factor == kInfinity) continue;  // C_o = inf: disjoint children only
                split_cost =
                    cost.split_cost_of_areas(node_area, left_area, i, suffix_area[i], count - i, overlap_factor);
                if (!(split_cost < sink.threshold(axis))) continue;
            }
            Split split = make_split(SplitKind::object_sorted, split_cost, axis, left.aabb(), uint32_t(i),
                                     suffix_bounds[i].aabb(), uint32_t(count - i));
            split.tie = sorted[i];
            sink.offer(split);
        }
    }
}

}  // namespace

Split ObjectSweepSplitFinder::find(const NodeContext& context, const CostModel& cost) const {
    CheapestSplit cheapest;
    sweep(context, cost, cheapest);
    return cheapest.best;
}

std::vector<Split> ObjectSweepSplitFinder::find_candidates(const NodeContext& context, const CostModel& cost,
                                                           uint32_t per_axis) const {
    SplitCandidates candidates(per_axis);
    sweep(context, cost, candidates);
    return candidates.all();
}

}  // namespace spacebvh::builders
