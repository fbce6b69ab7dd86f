// SPDX-License-Identifier: MIT
// Exact multi-hit queries (queries.hpp, docs/queries.md).
//
// Decision for one ray and one triangle, in three stages:
//  1. the float edge functions of the watertight test with their error bound (triangle_pack.hpp):
//     most triangles are clearly missed, and a clear crossing of the interior needs nothing more;
//  2. otherwise the sign of each edge function, exactly, under one symbolic perturbation of the
//     ray (perturbed_triangle.hpp: crosses_perturbed);
//  3. the distance: t in [tmin, tmax] decided exactly, t itself in double (crossing_in_range).
#include "spacebvh/queries.hpp"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "spacebvh/error.hpp"
#include "spacebvh/trace.hpp"
#include "trace/leaf_tests/perturbed_triangle.hpp"
#include "trace/traversal/traversal_common.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"
#include "trace/layout/wide_layout.hpp"
#include "trace/leaf_tests/watertight_triangle.hpp"

namespace spacebvh {

namespace {

using trace::perturbed::crosses_perturbed;
using trace::perturbed::crossing_in_range;
using trace::perturbed::make_hit;

// ---------------------------------------------------------------------------------------------
// The layout: binary nodes with both child boxes side by side, leaves as packs of four triangles.

constexpr uint32_t kEmptySlot = 0xFFFFFFFFu;

struct alignas(64) QueryNode {
    float planes[3][4];  // per axis: lo of child 0, lo of child 1, hi of child 0, hi of child 1
    uint32_t child[2];   // inner child: node index; leaf: first pack
    uint32_t count[2];   // 0: inner child; kEmptySlot: no child; else the leaf's lanes
};

typedef double Double4 __attribute__((vector_size(32)));
typedef float Float4 __attribute__((vector_size(16)));

// Per-ray constants of the two-box slab test, in double: t = (plane - o) * inv + bias. An axis the ray
// does not move along gets a huge inverse and a bias that opens its slab to +-2^300 when the origin is
// inside (including on a plane), and keeps it shut otherwise: no 0 * inf.
struct SlabRay {
    Double4 org[3], inv[3], bias[3];
    explicit SlabRay(const Ray& ray) {
        for (int a = 0; a < 3; ++a) {
            const double d = ray.dir[a];
            const bool parallel = d == 0.0;
            const double o = ray.org[a];
            org[a] = Double4{o, o, o, o};
            const double inverse = parallel ? 0x1p600 : 1.0 / d;
            inv[a] = Double4{inverse, inverse, inverse, inverse};
            const double b = parallel ? 0x1p300 : 0.0;
            bias[a] = Double4{-b, -b, b, b};
        }
    }
};

// The relative widening of the slab distances: the difference, reciprocal and product each round once
// (relative 2^-53); 1e-15 is over 9 of those.
constexpr double kWiden = 1e-15;

// Which of the node's two children the ray enters within [tmin, tmax] (bit i: child i), and their entry
// distances.
inline unsigned enter_children(const QueryNode& node, const SlabRay& s, double tmin, double tmax, double near_out[2]) {
    // Clamped to +-2^400: a crossing inside a box lies within the box's slab on an axis the ray moves
    // along, so |t| <= 2^129 / 2^-149 there; a parallel axis whose slab misses the origin gives
    // distances beyond 2^450 and is culled even when tmax is infinite.
    const double low = std::max(tmin, -0x1p400), high = std::min(tmax, 0x1p400);
    Double4 near = {low, low, low, low}, far = {high, high, high, high};
    for (int a = 0; a < 3; ++a) {
        Float4 pf;
        std::memcpy(&pf, node.planes[a], sizeof pf);
        const Double4 p = __builtin_convertvector(pf, Double4);
        const Double4 t = (p - s.org[a]) * s.inv[a] + s.bias[a];
        const Double4 swapped = __builtin_shufflevector(t, t, 2, 3, 0, 1);
        const Double4 lo = t < swapped ? t : swapped;
        const Double4 hi = t < swapped ? swapped : t;
        near = near > lo ? near : lo;
        far = far < hi ? far : hi;
    }
    unsigned mask = 0;
    for (int i = 0; i < 2; ++i) {
        const double n = near[i] - std::fabs(near[i]) * kWiden, f = far[i] + std::fabs(far[i]) * kWiden;
        if (node.count[i] != kEmptySlot && n <= f) mask |= 1u << i;
        near_out[i] = n;
    }
    return mask;
}

constexpr int kStackSize = 2048;

}  // namespace

struct RayQueries::Layout {
    std::vector<QueryNode> nodes;
    trace::TrianglePacks packs;
    size_t triangle_count = 0;
    AABB bounds;  // of every triangle: the grid containment batches are ordered on (coherent_order)
#if defined(__AVX2__) && defined(__FMA__)
    // The same tree collapsed to eight-wide nodes (wide_layout.hpp): the walk of every crossing visits
    // a third of the nodes it visits in the binary layout. Rays with tmin >= 0 only (FusedSlabs).
    trace::WideLayout<8> wide;
    bool has_wide = false;
#endif
};

namespace {

using Layout = RayQueries::Layout;

// Appends the leaf's live triangles as packs of its own; returns {first pack, lanes} or an empty slot.
std::pair<uint32_t, uint32_t> add_leaf(Layout& layout, std::span<const Triangle> triangles, const Bvh& bvh,
                                       const BvhNode& leaf) {
    std::vector<uint32_t> live;
    for (uint32_t i = leaf.first; i < leaf.first + leaf.reference_count; ++i) {
        const uint32_t id = bvh.primitives[i];
        if (id >= triangles.size())
            throw Error("queries: the tree refers to triangle " + std::to_string(id) + " of " +
                        std::to_string(triangles.size()));
        if (!triangles[id].is_degenerate()) live.push_back(id);
    }
    if (live.empty()) return {0, kEmptySlot};
    const uint32_t first = uint32_t(layout.packs.size());
    for (size_t k = 0; k < live.size(); ++k) {
        if (k % 4 == 0) layout.packs.emplace_back();
        trace::TrianglePack& pack = layout.packs.back();  // value-initialised: unused lanes are zero
        const Triangle& tri = triangles[live[k]];
        const int lane = int(k % 4);
        for (int v = 0; v < 3; ++v)
            for (int a = 0; a < 3; ++a) pack.vertex[v][a][lane] = tri.vertex(v)[a];
        pack.primitive[lane] = live[k];
    }
    return {first, uint32_t(live.size())};
}

void set_slot(QueryNode& node, int slot, const AABB& box, uint32_t child, uint32_t count) {
    for (int a = 0; a < 3; ++a) {
        node.planes[a][slot] = box.lo[a];
        node.planes[a][slot + 2] = box.hi[a];
    }
    node.child[slot] = child;
    node.count[slot] = count;
}

// Lays out the subtree under bvh node `index` as the children of a new query node; returns its index.
uint32_t add_node(Layout& layout, std::span<const Triangle> triangles, const Bvh& bvh, uint32_t index, int depth) {
    if (depth > kStackSize / 2)
        throw Error("queries: the tree is deeper than " + std::to_string(kStackSize / 2) + " levels");
    const uint32_t at = uint32_t(layout.nodes.size());
    layout.nodes.emplace_back();
    const BvhNode& node = bvh.nodes[index];
    const uint32_t children[2] = {node.first, node.first + 1};
    for (int slot = 0; slot < 2; ++slot) {
        if (children[slot] >= bvh.nodes.size()) throw Error("queries: a tree node refers to a missing child");
        const BvhNode& child = bvh.nodes[children[slot]];
        if (child.is_leaf()) {
            const auto [first, lanes] = add_leaf(layout, triangles, bvh, child);
            set_slot(layout.nodes[at], slot, child.bounds, first, lanes);
        } else {
            const uint32_t inner = add_node(layout, triangles, bvh, children[slot], depth + 1);
            set_slot(layout.nodes[at], slot, child.bounds, inner, 0);
        }
    }
    return at;
}

// The per-ray constants of the triangle test, made when the ray reaches its first leaf (three
// divisions that many rays, random rays around a small object, never need).
struct RayContext {
    const Ray& ray;
    trace::WatertightRay shear{};
    trace::PackRay pack_ray{};
    bool sheared = false;
    explicit RayContext(const Ray& r) : ray(r) {}
    const trace::PackRay& leaf_ray() {
        if (!sheared) {
            shear = trace::WatertightRay(ray);
            pack_ray = trace::PackRay(shear);
            sheared = true;
        }
        return pack_ray;
    }
};

// Tests a leaf's lanes; calls on_crossing(id, v0, v1, v2) for each triangle the perturbed ray crosses
// transversally (the distance is left to the caller). Returns true when on_crossing asks to stop.
template <class OnCrossing>
inline bool visit_leaf(const trace::TrianglePack* packs, RayContext& r, uint32_t first, uint32_t count,
                       OnCrossing&& on_crossing) {
    for (uint32_t p = 0; p * 4 < count; ++p) {
        const trace::TrianglePack& pack = packs[first + p];
        const uint32_t lanes = count - p * 4 < 4 ? count - p * 4 : 4;
        trace::PackEdges edges;
        trace::pack_edges(pack, r.leaf_ray(), edges);
        unsigned candidates = unsigned(~edges.outside) & ((1u << lanes) - 1);
        while (candidates) {
            const int lane = __builtin_ctz(candidates);
            candidates &= candidates - 1;
            Vec3 v[3];
            trace::pack_triangle(pack, lane, v);
            if (!((edges.inside >> lane) & 1) && !crosses_perturbed(r.ray, v[0], v[1], v[2])) continue;
            if (on_crossing(pack.primitive[lane], v[0], v[1], v[2])) return true;
        }
    }
    return false;
}

#if defined(__AVX2__) && defined(__FMA__)
// Eight-wide node test with the kernels' fused slab constants (traversal_common.hpp, FusedSlabs: why it
// is conservative, and why a NaN from an axis the ray does not move along leaves the bounds alone by
// the operand order of min and max). Empty slots hold empty boxes, which no ray enters.
struct WideRay {
    __m256 entry_scale[3], entry_offset[3], exit_scale[3], exit_offset[3];
    int entry_plane[3], exit_plane[3];
    explicit WideRay(const Ray& ray) {
        const trace::FusedSlabs slabs(ray);
        for (int axis = 0; axis < 3; ++axis) {
            entry_scale[axis] = _mm256_set1_ps(trace::FusedSlabs::lane(slabs.entry_scale, axis));
            entry_offset[axis] = _mm256_set1_ps(trace::FusedSlabs::lane(slabs.entry_offset, axis));
            exit_scale[axis] = _mm256_set1_ps(trace::FusedSlabs::lane(slabs.exit_scale, axis));
            exit_offset[axis] = _mm256_set1_ps(trace::FusedSlabs::lane(slabs.exit_offset, axis));
            const bool negative = (slabs.negative >> axis) & 1u;
            entry_plane[axis] = 2 * axis + (negative ? 1 : 0);
            exit_plane[axis] = 2 * axis + (negative ? 0 : 1);
        }
    }
};

inline unsigned wide_children(const trace::WideNode<8>& node, const WideRay& ray, float tmin, float tmax,
                              __m256& near) {
    near = _mm256_set1_ps(tmin);
    __m256 far = _mm256_set1_ps(tmax);
    for (int axis = 0; axis < 3; ++axis) {
        const __m256 t_entry = _mm256_fmsub_ps(_mm256_load_ps(node.planes[ray.entry_plane[axis]]),
                                               ray.entry_scale[axis], ray.entry_offset[axis]);
        const __m256 t_exit = _mm256_fmsub_ps(_mm256_load_ps(node.planes[ray.exit_plane[axis]]), ray.exit_scale[axis],
                                              ray.exit_offset[axis]);
        near = _mm256_max_ps(t_entry, near);
        far = _mm256_min_ps(t_exit, far);
    }
    return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(near, far, _CMP_LE_OQ)));
}

// Visits the leaves of the boxes the ray enters within [tmin, tmax] in slot order (every leaf on the
// ray is visited anyway by the all-hits walks, and the any-hit walk stops at the first crossing).
template <class OnLeaf>
inline void traverse_wide(const trace::WideLayout<8>& wide, const Ray& ray, OnLeaf&& on_leaf) {
    const WideRay boxes(ray);
    uint32_t stack[kStackSize * 4];  // at most seven pushes per level
    int top = 0;
    stack[top++] = 0;
    const trace::TrianglePack* packs = wide.packs.data();
    while (top > 0) {
        const trace::WideNode<8>& node = wide.nodes[stack[--top]];
        __m256 near;
        const unsigned mask = wide_children(node, boxes, ray.tmin, ray.tmax, near);
        unsigned leaves = 0;
        for (unsigned m = mask; m; m &= m - 1) {
            const int slot = __builtin_ctz(m);
            if (node.count[slot] == 0) {
                __builtin_prefetch(&wide.nodes[node.child[slot]]);
                stack[top++] = node.child[slot];
            } else {
                __builtin_prefetch(&packs[node.child[slot]]);
                leaves |= 1u << slot;
            }
        }
        for (; leaves; leaves &= leaves - 1) {
            const int slot = __builtin_ctz(leaves);
            if (on_leaf(packs, node.child[slot], node.count[slot])) return;
        }
    }
}

// The walk of the first crossing, as the closest-hit kernels walk (wide_kernel.inl): the children a
// ray enters are visited nearest first, leaves and inner nodes alike; the nearest is followed at once,
// the others pushed with their entry distance, so a subtree or leaf entered beyond the crossing found
// since is dropped when popped. `tmax` shrinks as crossings are found (a float at or above the best t
// so far: boxes are entered conservatively up to it).
template <class OnLeaf>
inline void traverse_wide_nearest_first(const trace::WideLayout<8>& wide, const Ray& ray, const float& tmax,
                                        OnLeaf&& on_leaf) {
    const WideRay boxes(ray);
    struct Entry {
        uint32_t child, count;
        float entry;
    };
    Entry stack[kStackSize * 4];  // at most seven pushes per level
    int top = 0;
    const trace::WideNode<8>* nodes = wide.nodes.data();
    const trace::TrianglePack* packs = wide.packs.data();
    Entry current{0, 0, ray.tmin};
    while (true) {
        if (current.count != 0) {
            on_leaf(packs, current.child, current.count);
        } else {
            const trace::WideNode<8>& node = nodes[current.child];
            __m256 near;
            unsigned mask = wide_children(node, boxes, ray.tmin, tmax, near);
            if (mask != 0) {
                alignas(32) float entry[8];
                _mm256_store_ps(entry, near);
                int nearest = __builtin_ctz(mask);
                for (unsigned rest = mask & (mask - 1); rest; rest &= rest - 1) {
                    const int slot = __builtin_ctz(rest);
                    if (entry[slot] < entry[nearest]) nearest = slot;
                }
                // The others farthest first below the top, so they pop nearest first.
                const int base = top;
                for (unsigned rest = mask & ~(1u << nearest); rest; rest &= rest - 1) {
                    const int slot = __builtin_ctz(rest);
                    int k = top++;
                    while (k > base && stack[k - 1].entry < entry[slot]) {
                        stack[k] = stack[k - 1];
                        --k;
                    }
                    stack[k] = {node.child[slot], node.count[slot], entry[slot]};
                }
                current = {node.child[nearest], node.count[nearest], entry[nearest]};
                if (current.count == 0)
                    __builtin_prefetch(&nodes[current.child]);
                else
                    __builtin_prefetch(&packs[current.child]);
                continue;
            }
        }
        do {
            if (top == 0) return;
            current = stack[--top];
        } while (current.entry > tmax);
    }
}
#endif

// Visits every leaf the ray may cross within [tmin, tmax]. on_leaf(packs, first, count) returns true
// to stop. A leaf may hold triangles of its neighbours too (LeafPacker): they are real triangles,
// tested like the others, and the callers drop the repeats.
template <class OnLeaf>
inline void traverse_all(const Layout& layout, RayContext& r, OnLeaf&& on_leaf) {
#if defined(__AVX2__) && defined(__FMA__)
    if (layout.has_wide && r.ray.tmin >= 0.0f) {
        traverse_wide(layout.wide, r.ray, on_leaf);
        return;
    }
#endif
    if (layout.nodes.empty()) return;
    uint32_t stack[kStackSize];
    int top = 0;
    stack[top++] = 0;
    const double tmin = r.ray.tmin, tmax = r.ray.tmax;
    const SlabRay slabs(r.ray);
    while (top > 0) {
        const QueryNode& node = layout.nodes[stack[--top]];
        double near[2];
        const unsigned mask = enter_children(node, slabs, tmin, tmax, near);
        // Inner children first, fetched ahead while the leaves are tested (the walk of an incoherent
        // ray waits on memory more than on arithmetic).
        unsigned leaves = 0;
        for (int slot = 0; slot < 2; ++slot) {
            if (!((mask >> slot) & 1)) continue;
            if (node.count[slot] == 0) {
                __builtin_prefetch(&layout.nodes[node.child[slot]]);
                stack[top++] = node.child[slot];
            } else {
                __builtin_prefetch(&layout.packs[node.child[slot]]);
                leaves |= 1u << slot;
            }
        }
        while (leaves) {
            const int slot = __builtin_ctz(leaves);
            leaves &= leaves - 1;
            if (on_leaf(layout.packs.data(), node.child[slot], node.count[slot])) return;
        }
    }
}

bool valid_ray(const Ray& ray) {
    return is_finite(ray.org) && is_finite(ray.dir) && !(ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) &&
           !std::isnan(ray.tmin) && !std::isnan(ray.tmax);
}

void check_ray(const Ray& ray) {
    if (!valid_ray(ray))
        throw Error("queries: a ray needs a finite origin, a finite nonzero direction and tmin, tmax that are not NaN");
}

// Collects the crossings (deduplicated: spatial splits put a triangle in several leaves), sorted.
void collect_hits(const Layout& layout, const Ray& ray, std::vector<QueryHit>& out, size_t max_hits) {
    out.clear();
    if (max_hits == 0) return;
    RayContext r(ray);
    const double tmax = ray.tmax;
    traverse_all(layout, r, [&](const trace::TrianglePack* packs, uint32_t first, uint32_t count) {
        return visit_leaf(packs, r, first, count, [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
            double t;
            if (crossing_in_range(ray, v0, v1, v2, tmax, t)) out.push_back(make_hit(ray, v0, v1, v2, id, t));
            return false;
        });
    });
    std::sort(out.begin(), out.end(), [](const QueryHit& a, const QueryHit& b) {
        return a.t < b.t || (a.t == b.t && a.primitive < b.primitive);
    });
    out.erase(std::unique(out.begin(), out.end(),
                          [](const QueryHit& a, const QueryHit& b) { return a.primitive == b.primitive; }),
              out.end());
    if (out.size() > max_hits) out.resize(max_hits);
}

uint32_t count_crossings(const Layout& layout, const Ray& ray, std::vector<uint32_t>& scratch) {
    scratch.clear();
    RayContext r(ray);
    const double tmax = ray.tmax;
    traverse_all(layout, r, [&](const trace::TrianglePack* packs, uint32_t first, uint32_t count) {
        return visit_leaf(packs, r, first, count, [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
            double t;
            if (crossing_in_range(ray, v0, v1, v2, tmax, t)) scratch.push_back(id);
            return false;
        });
    });
    if (scratch.size() > 1) {
        std::sort(scratch.begin(), scratch.end());
        scratch.erase(std::unique(scratch.begin(), scratch.end()), scratch.end());
    }
    return uint32_t(scratch.size());
}

// The nearest crossing found so far. Before the first, the bound is the ray's own tmax (decided
// exactly); after it, the best t (compared in double: the t of every crossing is computed alike).
struct Nearest {
    const Ray& ray;
    double t;
    bool found = false;
    uint32_t id = kInvalidIndex;
    Vec3 vertex[3];

    explicit Nearest(const Ray& r) : ray(r), t(r.tmax) {}
    // Returns true when the triangle's crossing is the new nearest.
    bool offer(uint32_t candidate, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
        double candidate_t;
        if (!crossing_in_range(ray, v0, v1, v2, found ? t : double(ray.tmax), candidate_t)) return false;
        if (found && (candidate_t > t || (candidate_t == t && candidate >= id))) return false;
        found = true;
        t = candidate_t;
        id = candidate;
        vertex[0] = v0, vertex[1] = v1, vertex[2] = v2;
        return true;
    }
    std::optional<QueryHit> hit() const {
        if (!found) return std::nullopt;
        return make_hit(ray, vertex[0], vertex[1], vertex[2], id, t);
    }
};

// Finds the nearest crossing into `nearest` (its id stays kInvalidIndex when there is none).
void find_nearest(const Layout& layout, const Ray& ray, Nearest& nearest) {
    if (layout.nodes.empty()) return;
    RayContext r(ray);
#if defined(__AVX2__) && defined(__FMA__)
    if (layout.has_wide && ray.tmin >= 0.0f) {
        float box_tmax = ray.tmax;
        traverse_wide_nearest_first(
            layout.wide, ray, box_tmax, [&](const trace::TrianglePack* packs, uint32_t first, uint32_t count) {
                visit_leaf(packs, r, first, count, [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
                    if (nearest.offer(id, v0, v1, v2)) box_tmax = std::nextafter(float(nearest.t), kInfinity);
                    return false;
                });
            });
        return;
    }
#endif
    struct Entry {
        uint32_t node;
        double near;
    };
    Entry stack[kStackSize];
    const SlabRay slabs(ray);
    int top = 0;
    stack[top++] = {0, -std::numeric_limits<double>::infinity()};
    while (top > 0) {
        const Entry entry = stack[--top];
        if (entry.near > nearest.t) continue;
        const QueryNode& node = layout.nodes[entry.node];
        double near[2];
        const unsigned mask = enter_children(node, slabs, ray.tmin, nearest.t, near);
        if (!mask) continue;
        // Nearer child last on the stack (visited first); leaves are tested at once.
        int order[2] = {0, 1};
        if (mask == 3 && near[1] < near[0]) std::swap(order[0], order[1]);
        for (int k = 1; k >= 0; --k) {
            const int slot = order[k];
            if (!((mask >> slot) & 1) || node.count[slot] != 0) continue;
            __builtin_prefetch(&layout.nodes[node.child[slot]]);
            stack[top++] = {node.child[slot], near[slot]};
        }
        for (int k = 0; k < 2; ++k) {
            const int slot = order[k];
            if (!((mask >> slot) & 1) || node.count[slot] == 0) continue;
            visit_leaf(layout.packs.data(), r, node.child[slot], node.count[slot],
                       [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
                           nearest.offer(id, v0, v1, v2);
                           return false;
                       });
        }
    }
}

std::optional<QueryHit> nearest_crossing(const Layout& layout, const Ray& ray) {
    Nearest nearest(ray);
    find_nearest(layout, ray, nearest);
    return nearest.hit();
}

uint32_t nearest_crossing_id(const Layout& layout, const Ray& ray) {
    Nearest nearest(ray);
    find_nearest(layout, ray, nearest);
    return nearest.id;
}

bool any_crossing(const Layout& layout, const Ray& ray) {
    RayContext r(ray);
    bool found = false;
    const double tmax = ray.tmax;
    traverse_all(layout, r, [&](const trace::TrianglePack* packs, uint32_t first, uint32_t count) {
        return visit_leaf(packs, r, first, count, [&](uint32_t, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
            double t;
            found = crossing_in_range(ray, v0, v1, v2, tmax, t);
            return found;
        });
    });
    return found;
}

Ray containment_ray(Vec3 point) {
    if (!is_finite(point)) throw Error("queries: contains() needs a finite point");
    return Ray{point, kContainmentDirection, 0.0f, kInfinity};
}

// A fixed grain: the work split does not depend on the thread count (and answers are per ray anyway).
constexpr size_t kGrain = 256;

template <class Body>
void for_chunks(size_t n, Body&& body) {
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, n, kGrain),
        [&](const tbb::blocked_range<size_t>& range) { body(range.begin(), range.end()); }, tbb::simple_partitioner());
}

// The order containment rays are walked in: their points bucketed on a grid over the mesh's box
// (clamped to it), cells in Morton order, the input order within a cell (a stable counting sort).
// Containment rays share one direction, so rays from points close together walk nearly the same
// nodes and leaves, and walking them one after another finds those in cache: an incoherent batch is
// bound by memory latency, not arithmetic. Each answer belongs to its own point, so the order changes
// no answer, and it depends on the points only (not on the thread count). Rays of other directions
// gain less than the ordering costs (measured for first, any and all hits), so only containment
// is ordered.
template <class RayAt>
std::vector<uint32_t> coherent_order(const AABB& bounds, size_t n, const RayAt& ray_at) {
    // 2^4 cells per axis: 4096 counters, which stay in the first-level cache while counting.
    constexpr int kBits = 4;
    constexpr uint32_t kCells = 1u << kBits, kKeys = 1u << (3 * kBits);
    static_assert(3 * kBits <= 16, "keys are 16 bits");
    float scale[3], low[3];
    for (int a = 0; a < 3; ++a) {
        const float extent = bounds.hi[a] - bounds.lo[a];
        low[a] = bounds.lo[a];
        scale[a] = extent > 0.0f ? float(kCells) / extent : 0.0f;
    }
    std::vector<uint16_t> key(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1 << 14), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i < range.end(); ++i) {
            const Vec3 org = ray_at(i).org;
            uint32_t code = 0;
            for (int a = 0; a < 3; ++a) {
                const float x = (org[a] - low[a]) * scale[a];  // NaN only for an empty box: cell 0
                const uint32_t cell = !(x > 0.0f) ? 0u : x >= float(kCells - 1) ? kCells - 1 : uint32_t(x);
                for (int bit = 0; bit < kBits; ++bit) code |= ((cell >> bit) & 1u) << (3 * bit + a);
            }
            key[i] = uint16_t(code);
        }
    });
    std::vector<uint32_t> start(kKeys + 1, 0), order(n);
    for (size_t i = 0; i < n; ++i) ++start[key[i] + 1u];
    for (uint32_t k = 0; k < kKeys; ++k) start[k + 1] += start[k];
    for (size_t i = 0; i < n; ++i) order[start[key[i]]++] = uint32_t(i);
    return order;
}

// Containment batches smaller than this are walked in input order (ordering would cost more than it
// saves).
constexpr size_t kOrderedBatch = 4096;

void check_sizes(size_t a, size_t b, const char* what) {
    if (a != b)
        throw Error(std::string("queries: ") + what + ": " + std::to_string(a) + " inputs but room for " +
                    std::to_string(b) + " answers");
}

}  // namespace

std::optional<QueryHit> intersect_triangle_perturbed(const Ray& ray, const Triangle& triangle, uint32_t id) {
    check_ray(ray);
    if (triangle.is_degenerate()) return std::nullopt;
    if (!crosses_perturbed(ray, triangle.v0, triangle.v1, triangle.v2)) return std::nullopt;
    double t;
    if (!crossing_in_range(ray, triangle.v0, triangle.v1, triangle.v2, ray.tmax, t)) return std::nullopt;
    return make_hit(ray, triangle.v0, triangle.v1, triangle.v2, id, t);
}

RayQueries::RayQueries(std::span<const Triangle> triangles, const Bvh& bvh) : layout_(std::make_unique<Layout>()) {
    layout_->triangle_count = triangles.size();
    for (size_t i = 0; i < triangles.size(); ++i) {
        if (!is_finite(triangles[i].v0) || !is_finite(triangles[i].v1) || !is_finite(triangles[i].v2))
            throw Error("queries: triangle " + std::to_string(i) + " has a vertex that is not finite");
        layout_->bounds.extend(triangles[i].bounds());
    }
    if (bvh.empty() || triangles.empty()) return;
    const BvhNode& root = bvh.root();
    if (root.is_leaf()) {
        layout_->nodes.emplace_back();
        const auto [first, lanes] = add_leaf(*layout_, triangles, bvh, root);
        set_slot(layout_->nodes[0], 0, root.bounds, first, lanes);
        set_slot(layout_->nodes[0], 1, AABB{}, 0, kEmptySlot);
    } else {
        add_node(*layout_, triangles, bvh, 0, 0);
    }
#if defined(__AVX2__) && defined(__FMA__)
    layout_->wide = trace::collapse_to_wide<8>(triangles, bvh, WideCollapse::sah_optimal);
    layout_->has_wide = !layout_->wide.nodes.empty();
#endif
}

RayQueries::~RayQueries() = default;
RayQueries::RayQueries(RayQueries&&) noexcept = default;
RayQueries& RayQueries::operator=(RayQueries&&) noexcept = default;

size_t RayQueries::triangle_count() const { return layout_->triangle_count; }

std::optional<QueryHit> RayQueries::first_hit(const Ray& ray) const {
    check_ray(ray);
    return nearest_crossing(*layout_, ray);
}

bool RayQueries::any_hit(const Ray& ray) const {
    check_ray(ray);
    return any_crossing(*layout_, ray);
}

void RayQueries::all_hits(const Ray& ray, std::vector<QueryHit>& out, size_t max_hits) const {
    check_ray(ray);
    collect_hits(*layout_, ray, out, max_hits);
}

uint32_t RayQueries::count_hits(const Ray& ray) const {
    check_ray(ray);
    std::vector<uint32_t> scratch;
    return count_crossings(*layout_, ray, scratch);
}

bool RayQueries::contains(Vec3 point) const {
    std::vector<uint32_t> scratch;
    return count_crossings(*layout_, containment_ray(point), scratch) % 2 == 1;
}

void RayQueries::first_hits(std::span<const Ray> rays, std::span<QueryHit> out) const {
    check_sizes(rays.size(), out.size(), "first_hits");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) out[i] = nearest_crossing(*layout_, rays[i]).value_or(QueryHit{});
    });
}

void RayQueries::first_hit_ids(std::span<const Ray> rays, std::span<uint32_t> out) const {
    check_sizes(rays.size(), out.size(), "first_hit_ids");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) out[i] = nearest_crossing_id(*layout_, rays[i]);
    });
}

void RayQueries::any_hits(std::span<const Ray> rays, std::span<uint8_t> out) const {
    check_sizes(rays.size(), out.size(), "any_hits");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) out[i] = any_crossing(*layout_, rays[i]) ? 1 : 0;
    });
}

HitLists RayQueries::all_hits(std::span<const Ray> rays, size_t max_hits) const {
    for (const Ray& ray : rays) check_ray(ray);
    const size_t chunks = (rays.size() + kGrain - 1) / kGrain;
    std::vector<std::vector<QueryHit>> chunk_hits(chunks);
    HitLists lists;
    lists.offsets.assign(rays.size() + 1, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1), [&](const tbb::blocked_range<size_t>& range) {
        std::vector<QueryHit> scratch;
        for (size_t c = range.begin(); c != range.end(); ++c) {
            std::vector<QueryHit>& hits = chunk_hits[c];
            const size_t end = std::min(rays.size(), (c + 1) * kGrain);
            for (size_t i = c * kGrain; i < end; ++i) {
                collect_hits(*layout_, rays[i], scratch, max_hits);
                lists.offsets[i + 1] = scratch.size();
                hits.insert(hits.end(), scratch.begin(), scratch.end());
            }
        }
    });
    for (size_t i = 0; i < rays.size(); ++i) lists.offsets[i + 1] += lists.offsets[i];
    lists.hits.resize(lists.offsets.back());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t c = range.begin(); c != range.end(); ++c)
            std::copy(chunk_hits[c].begin(), chunk_hits[c].end(),
                      lists.hits.begin() + ptrdiff_t(lists.offsets[c * kGrain]));
    });
    return lists;
}

void RayQueries::count_hits(std::span<const Ray> rays, std::span<uint32_t> out) const {
    check_sizes(rays.size(), out.size(), "count_hits");
    for (const Ray& ray : rays) check_ray(ray);
    for_chunks(rays.size(), [&](size_t begin, size_t end) {
        std::vector<uint32_t> scratch;
        for (size_t i = begin; i < end; ++i) out[i] = count_crossings(*layout_, rays[i], scratch);
    });
}

void RayQueries::contains(std::span<const Vec3> points, std::span<uint8_t> out) const {
    check_sizes(points.size(), out.size(), "contains");
    for (const Vec3& p : points) containment_ray(p);
    const size_t n = points.size();
    if (n < kOrderedBatch || n > std::numeric_limits<uint32_t>::max() || layout_->nodes.empty()) {
        for_chunks(n, [&](size_t begin, size_t end) {
            std::vector<uint32_t> scratch;
            for (size_t i = begin; i < end; ++i)
                out[i] = count_crossings(*layout_, containment_ray(points[i]), scratch) % 2;
        });
        return;
    }
    // In coherent_order, the rays gathered first: read in place, each would be a cache miss the walk
    // waits on.
    const std::vector<uint32_t> order =
        coherent_order(layout_->bounds, n, [&](size_t i) { return containment_ray(points[i]); });
    std::vector<Ray> ordered(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1 << 14), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t k = range.begin(); k < range.end(); ++k) ordered[k] = containment_ray(points[order[k]]);
    });
    for_chunks(n, [&](size_t begin, size_t end) {
        std::vector<uint32_t> scratch;
        for (size_t k = begin; k < end; ++k) out[order[k]] = count_crossings(*layout_, ordered[k], scratch) % 2;
    });
}

}  // namespace spacebvh
