// SPDX-License-Identifier: MIT
// The top level's build: a binned SAH tree over the items' boxes, one item per leaf, written straight
// into a Bvh. Large nodes bin and partition in fixed-size chunks across oneTBB, large subtrees are
// built as tasks; every node's place in the arrays follows from the item counts alone, so the tree
// is the same for any thread count.
#include <immintrin.h>

#include <algorithm>
#include <bit>
#include <memory>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "trace/scene/top_level.hpp"

namespace spacebvh::scene {
namespace {

constexpr int kBins = 32;
constexpr size_t kChunk = size_t(1) << 12;        // items per chunk of a chunked pass (fixed: determinism)
constexpr size_t kChunkedPass = size_t(1) << 15;  // nodes this large bin and partition in chunks
constexpr size_t kTaskItems = size_t(1) << 10;    // subtrees this large are built as tasks
constexpr uint32_t kMaxDepth = 63;                // the walks' stacks hold 64 levels (top_level_wide.hpp)

// An item's box and, in lo's fourth lane, its index (bits); hi's fourth lane is 0.
struct alignas(16) Ref {
    __m128 lo, hi;
};
static_assert(2 * sizeof(Ref) + 1 == kTopLevelBuildBytesPerItem);

// Clears the fourth lane: arithmetic on an index's bits (a denormal float for most indices) would
// take the processor's slow path; min and max on them are harmless.
__m128 xyz(__m128 v) { return _mm_and_ps(v, _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0))); }

__m128 centroid(const Ref& r) {
    return _mm_add_ps(_mm_mul_ps(xyz(r.lo), _mm_set1_ps(0.5f)), _mm_mul_ps(r.hi, _mm_set1_ps(0.5f)));
}

// A box and a centroid box, grown by min and max (exact, so any merge order gives the same result).
struct Bounds {
    __m128 lo = _mm_set1_ps(kInfinity), hi = _mm_set1_ps(-kInfinity);
    __m128 clo = _mm_set1_ps(kInfinity), chi = _mm_set1_ps(-kInfinity);
    size_t count = 0;

    void add(const Ref& r) {
        const __m128 c = centroid(r);
        lo = _mm_min_ps(lo, r.lo), hi = _mm_max_ps(hi, r.hi);
        clo = _mm_min_ps(clo, c), chi = _mm_max_ps(chi, c);
        ++count;
    }
    void merge(const Bounds& o) {
        lo = _mm_min_ps(lo, o.lo), hi = _mm_max_ps(hi, o.hi);
        clo = _mm_min_ps(clo, o.clo), chi = _mm_max_ps(chi, o.chi);
        count += o.count;
    }
    AABB box() const {
        alignas(16) float l[4], h[4];
        _mm_store_ps(l, lo), _mm_store_ps(h, hi);
        return AABB{{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
    }
};

float half_area(__m128 lo, __m128 hi) {
    alignas(16) float d[4];
    _mm_store_ps(d, _mm_max_ps(_mm_sub_ps(xyz(hi), xyz(lo)), _mm_setzero_ps()));
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

// The centroid's bin on each axis (lanes 0..2), as both the binning and the partition compute it.
struct Binner {
    int count;  // bins per axis: kBins, or fewer for a node of fewer items
    __m128 origin, scale, last;
    Binner(const Bounds& b, int bins) : count(bins), origin(b.clo), last(_mm_set1_ps(float(bins - 1))) {
        alignas(16) float extent[4], s[4];
        _mm_store_ps(extent, _mm_sub_ps(b.chi, b.clo));
        for (int i = 0; i < 4; ++i) s[i] = extent[i] > 0.0f ? float(bins) * 0.99999f / extent[i] : 0.0f;
        scale = _mm_load_ps(s);
    }
    __m128i bins(const Ref& r) const {
        const __m128 p = _mm_mul_ps(_mm_sub_ps(centroid(r), origin), scale);
        return _mm_cvttps_epi32(_mm_min_ps(_mm_max_ps(p, _mm_setzero_ps()), last));
    }
};

// Only the first `used` bins of each axis are live: a small node pays for its bins, not for kBins.
struct Bins {
    int used;
    __m128 lo[3][kBins], hi[3][kBins];
    uint32_t count[3][kBins];

    explicit Bins(int bins) : used(bins) {
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < used; ++b)
                lo[a][b] = _mm_set1_ps(kInfinity), hi[a][b] = _mm_set1_ps(-kInfinity), count[a][b] = 0;
    }
    void add(const Binner& binner, const Ref* refs, size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            alignas(16) int32_t bin[4];
            _mm_store_si128(reinterpret_cast<__m128i*>(bin), binner.bins(refs[i]));
            for (int a = 0; a < 3; ++a) {
                lo[a][bin[a]] = _mm_min_ps(lo[a][bin[a]], refs[i].lo);
                hi[a][bin[a]] = _mm_max_ps(hi[a][bin[a]], refs[i].hi);
                ++count[a][bin[a]];
            }
        }
    }
    void merge(const Bins& o) {
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < used; ++b) {
                lo[a][b] = _mm_min_ps(lo[a][b], o.lo[a][b]), hi[a][b] = _mm_max_ps(hi[a][b], o.hi[a][b]);
                count[a][b] += o.count[a][b];
            }
    }
};

struct Split {
    int axis = -1;  // -1: no binned split separates the items
    int bin = 0;    // items in bins <= bin go left
};

// The cheapest split between bins by the surface area heuristic (left area x count + right area x
// count), first axis and then first bin on ties.
Split cheapest(const Bins& bins) {
    Split best;
    float best_cost = kInfinity;
    for (int a = 0; a < 3; ++a) {
        float right_cost[kBins];
        __m128 lo = _mm_set1_ps(kInfinity), hi = _mm_set1_ps(-kInfinity);
        uint32_t n = 0;
        for (int b = bins.used - 1; b > 0; --b) {
            lo = _mm_min_ps(lo, bins.lo[a][b]), hi = _mm_max_ps(hi, bins.hi[a][b]);
            n += bins.count[a][b];
            right_cost[b] = n ? half_area(lo, hi) * float(n) : -1.0f;
        }
        lo = _mm_set1_ps(kInfinity), hi = _mm_set1_ps(-kInfinity);
        n = 0;
        for (int b = 0; b < bins.used - 1; ++b) {
            lo = _mm_min_ps(lo, bins.lo[a][b]), hi = _mm_max_ps(hi, bins.hi[a][b]);
            n += bins.count[a][b];
            if (n == 0 || right_cost[b + 1] < 0.0f) continue;
            const float cost = half_area(lo, hi) * float(n) + right_cost[b + 1];
            if (cost < best_cost) best_cost = cost, best = {a, b};
        }
    }
    return best;
}

struct Builder {
    Ref* refs;
    Ref* scratch;  // as many as refs; a node uses its own range
    Bvh& bvh;

    struct Node {
        size_t begin, end;
        uint32_t index;      // of this node in bvh.nodes
        uint32_t next_free;  // its descendants take bvh.nodes[next_free, next_free + 2 (end - begin) - 2)
        uint32_t depth;
        Bounds bounds;
    };

    Bins bin(const Node& n, const Binner& binner) const {
        if (n.end - n.begin < kChunkedPass) {
            Bins bins(binner.count);
            bins.add(binner, refs, n.begin, n.end);
            return bins;
        }
        return tbb::parallel_reduce(
            tbb::blocked_range<size_t>(n.begin, n.end, kChunk), Bins(binner.count),
            [&](const tbb::blocked_range<size_t>& r, Bins bins) {
                bins.add(binner, refs, r.begin(), r.end());
                return bins;
            },
            [](Bins a, const Bins& b) {
                a.merge(b);
                return a;
            });
    }

    // Moves the items going left to the front of the node's range; their bounds and the others'.
    size_t partition(const Node& n, const Binner& binner, Split split, Bounds& left, Bounds& right) const {
        const auto goes_left = [&](const Ref& r) {
            alignas(16) int32_t b[4];
            _mm_store_si128(reinterpret_cast<__m128i*>(b), binner.bins(r));
            return b[split.axis] <= split.bin;
        };
        if (n.end - n.begin >= kChunkedPass) return partition_chunked(n, goes_left, left, right);
        size_t i = n.begin, j = n.end;
        for (;;) {
            while (i < j && goes_left(refs[i])) left.add(refs[i++]);
            while (i < j && !goes_left(refs[j - 1])) right.add(refs[--j]);
            if (i >= j) return i;
            right.add(refs[i]), left.add(refs[j - 1]);
            std::swap(refs[i++], refs[--j]);
        }
    }

    // A stable partition in chunks: count each chunk's left items, then scatter through `scratch`.
    template <class GoesLeft>
    size_t partition_chunked(const Node& n, const GoesLeft& goes_left, Bounds& left, Bounds& right) const {
        const size_t chunks = (n.end - n.begin + kChunk - 1) / kChunk;
        std::vector<Bounds> lefts(chunks), rights(chunks);
        std::vector<uint8_t> side(n.end - n.begin);
        tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
            for (size_t i = n.begin + c * kChunk, end = std::min(n.end, i + kChunk); i < end; ++i) {
                const bool l = goes_left(refs[i]);
                side[i - n.begin] = l;
                (l ? lefts[c] : rights[c]).add(refs[i]);
            }
        });
        std::vector<size_t> at_left(chunks), at_right(chunks);
        size_t l = n.begin;
        for (size_t c = 0; c < chunks; ++c) at_left[c] = l, l += lefts[c].count;
        size_t r = l;
        for (size_t c = 0; c < chunks; ++c) {
            at_right[c] = r, r += rights[c].count;
            left.merge(lefts[c]), right.merge(rights[c]);
        }
        tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
            size_t to_left = at_left[c], to_right = at_right[c];
            for (size_t i = n.begin + c * kChunk, end = std::min(n.end, i + kChunk); i < end; ++i)
                scratch[side[i - n.begin] ? to_left++ : to_right++] = refs[i];
        });
        tbb::parallel_for(tbb::blocked_range<size_t>(n.begin, n.end, kChunk), [&](const tbb::blocked_range<size_t>& b) {
            std::copy(scratch + b.begin(), scratch + b.end(), refs + b.begin());
        });
        return l;
    }

    // The items in their current order, halved: a split that always progresses, for items whose
    // centroids coincide and for nodes too deep to leave the SAH its way.
    size_t halve(const Node& n, Bounds& left, Bounds& right) const {
        const size_t mid = n.begin + (n.end - n.begin) / 2;
        for (size_t i = n.begin; i < mid; ++i) left.add(refs[i]);
        for (size_t i = mid; i < n.end; ++i) right.add(refs[i]);
        return mid;
    }

    void build(const Node& n) const {
        const size_t count = n.end - n.begin;
        BvhNode& node = bvh.nodes[n.index];
        node.bounds = n.bounds.box();
        if (count == 1) {
            node.first = uint32_t(n.begin);
            node.reference_count = 1;
            alignas(16) uint32_t lanes[4];
            _mm_store_ps(reinterpret_cast<float*>(lanes), refs[n.begin].lo);
            bvh.primitives[n.begin] = lanes[3];
            return;
        }
        node.first = n.next_free;
        node.reference_count = 0;
        Bounds left, right;
        size_t mid = n.begin;
        // Halving needs ceil(log2(count)) more levels: once the depth leaves only that, halve.
        if (count > 2 && n.depth + uint32_t(std::bit_width(count - 1)) < kMaxDepth) {
            const Binner binner(n.bounds, int(std::min<size_t>(count, kBins)));
            const Split split = cheapest(bin(n, binner));
            if (split.axis >= 0) mid = partition(n, binner, split, left, right);
        }
        if (mid == n.begin || mid == n.end) {
            left = right = Bounds();
            mid = halve(n, left, right);
        }
        const uint32_t left_nodes = uint32_t(2 * (mid - n.begin) - 2);
        const Node l{n.begin, mid, n.next_free, n.next_free + 2, n.depth + 1, left};
        const Node r{mid, n.end, n.next_free + 1, n.next_free + 2 + left_nodes, n.depth + 1, right};
        if (count >= kTaskItems)
            tbb::parallel_invoke([&] { build(l); }, [&] { build(r); });
        else
            build(l), build(r);
    }
};

}  // namespace

TopLevel build_top_level(std::span<const TopLevelItem> items) {
    const size_t n = items.size();
    if (n == 0 || n >= kInvalidIndex / 2) throw Error("top level: " + std::to_string(n) + " items (1 .. 2^31 - 1)");
    // Left uninitialised (a Ref has no initialisers): each page is first written by the pass that
    // fills it, in parallel, not zeroed beforehand by this thread.
    const std::unique_ptr<Ref[]> refs(new Ref[n]), scratch(new Ref[n]);
    const Bounds all = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, n, kChunk), Bounds(),
        [&](const tbb::blocked_range<size_t>& r, Bounds b) {
            for (size_t i = r.begin(); i != r.end(); ++i) {
                const AABB& box = items[i].box;
                refs[i].lo = _mm_setr_ps(box.lo.x, box.lo.y, box.lo.z, std::bit_cast<float>(uint32_t(i)));
                refs[i].hi = _mm_setr_ps(box.hi.x, box.hi.y, box.hi.z, 0.0f);
                b.add(refs[i]);
            }
            return b;
        },
        [](Bounds a, const Bounds& b) {
            a.merge(b);
            return a;
        });
    TopLevel top;
    top.bvh.nodes.resize(2 * n - 1);
    top.bvh.primitives.resize(n);
    top.bvh.builder = "binned";
    top.bvh.cost = BuildConfig::for_preset(Preset::binned).cost;
    Builder{refs.get(), scratch.get(), top.bvh}.build({0, n, 0, 1, 0, all});
    measure_top_level(top, items);
    return top;
}

}  // namespace spacebvh::scene
