// SPDX-License-Identifier: MIT
// Embree's binary trees imported into our Bvh (see embree_builder.hpp).
#include "spacebvh/tools/embree_builder.hpp"
#include "spacebvh/memory_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include <embree3/rtcore_builder.h>

#include "spacebvh/clip.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::tools {

namespace {

// The temporary tree Embree builds through our callbacks, allocated with rtcThreadLocalAlloc (it
// lives in the RTCBVH and goes with it). Both node kinds start with `kind`, so a void* child can be
// told apart by reading the first member.
enum class TempKind : uint32_t { inner = 0, leaf = 1 };
constexpr unsigned kBinary = 2;

struct TempInner {
    TempKind kind = TempKind::inner;
    uint32_t child_count = 0;  // as Embree announced it; only the first kBinary are stored
    const void* children[kBinary] = {nullptr, nullptr};
    AABB child_bounds[kBinary];
};

struct TempLeaf {
    TempKind kind = TempKind::leaf;
    uint32_t count = 0;
    AABB bounds;  // union of the references' bounds
    // followed by `count` uint32_t triangle ids
    uint32_t* ids() { return reinterpret_cast<uint32_t*>(this + 1); }
    const uint32_t* ids() const { return reinterpret_cast<const uint32_t*>(this + 1); }
};

TempKind kind_of(const void* node) { return *static_cast<const TempKind*>(node); }

// Shared by the callbacks (userPtr). Callbacks run on Embree's worker threads; they must not throw
// through Embree's C API, so failures are recorded here and reported after rtcBuildBVH returns.
struct BuildContext {
    const Scene* scene = nullptr;
    const BuildConfig* options = nullptr;
    std::mutex failure_mutex;
    std::string failure;                  // a callback that could not do its job
    std::exception_ptr progress_failure;  // an exception thrown by options.hooks.progress

    void fail(std::string message) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (failure.empty()) failure = std::move(message);
    }
};

AABB to_aabb(const RTCBounds& b) { return {{b.lower_x, b.lower_y, b.lower_z}, {b.upper_x, b.upper_y, b.upper_z}}; }
AABB to_aabb(const RTCBuildPrimitive& p) {
    return {{p.lower_x, p.lower_y, p.lower_z}, {p.upper_x, p.upper_y, p.upper_z}};
}

// Writes the box into an RTCBounds; the padding words keep the primitive's ids, as Embree's own
// tutorial splitter does (Embree overwrites them with the ids itself anyway).
void store(const AABB& box, const RTCBuildPrimitive& prim, RTCBounds& out) {
    out.lower_x = box.lo.x;
    out.lower_y = box.lo.y;
    out.lower_z = box.lo.z;
    out.upper_x = box.hi.x;
    out.upper_y = box.hi.y;
    out.upper_z = box.hi.z;
    unsigned geom = prim.geomID, id = prim.primID;
    static_assert(sizeof(out.align0) == sizeof(unsigned) && sizeof(out.align1) == sizeof(unsigned));
    std::memcpy(&out.align0, &geom, sizeof(unsigned));
    std::memcpy(&out.align1, &id, sizeof(unsigned));
}

void* create_node(RTCThreadLocalAllocator allocator, unsigned child_count, void* user) {
    void* memory = rtcThreadLocalAlloc(allocator, sizeof(TempInner), alignof(TempInner));
    if (!memory) return nullptr;  // Embree has recorded the error
    TempInner* node = new (memory) TempInner();
    node->child_count = child_count;
    if (child_count > kBinary || child_count == 0)
        static_cast<BuildContext*>(user)->fail("Embree created an inner node with " + std::to_string(child_count) +
                                               " children (a binary tree was requested)");
    return node;
}

void set_node_children(void* node_ptr, void** children, unsigned child_count, void*) {
    TempInner* node = static_cast<TempInner*>(node_ptr);
    for (unsigned i = 0; i < std::min(child_count, kBinary); ++i) node->children[i] = children[i];
}

void set_node_bounds(void* node_ptr, const RTCBounds** bounds, unsigned child_count, void*) {
    TempInner* node = static_cast<TempInner*>(node_ptr);
    for (unsigned i = 0; i < std::min(child_count, kBinary); ++i) node->child_bounds[i] = to_aabb(*bounds[i]);
}

void* create_leaf(RTCThreadLocalAllocator allocator, const RTCBuildPrimitive* primitives, size_t count, void* user) {
    void* memory = rtcThreadLocalAlloc(allocator, sizeof(TempLeaf) + count * sizeof(uint32_t), alignof(TempLeaf));
    if (!memory) return nullptr;
    TempLeaf* leaf = new (memory) TempLeaf();
    leaf->count = uint32_t(count);
    uint32_t* ids = leaf->ids();
    for (size_t i = 0; i < count; ++i) {
        ids[i] = primitives[i].primID;
        leaf->bounds.extend(to_aabb(primitives[i]));
    }
    if (count == 0) static_cast<BuildContext*>(user)->fail("Embree created an empty leaf");
    return leaf;
}

// Spatial split of one reference (a triangle restricted to prim's bounds) at x[dim] = pos, with
// exact clipping. Embree may call this with pos on or even outside the prim's bounds
// (RenderKit/embree#328), and it needs valid boxes inside the prim's bounds on both sides: pos is
// clamped into the bounds, and a side without any part of the triangle gets the flat box where the
// plane cuts the prim's bounds (a harmless extra reference, merged or never hit).
void split_primitive(const RTCBuildPrimitive* prim, unsigned dim, float pos, RTCBounds* left_out, RTCBounds* right_out,
                     void* user) {
    const BuildContext& context = *static_cast<const BuildContext*>(user);
    const AABB box = to_aabb(*prim);
    const int axis = int(std::min(dim, 2u));
    float position = pos;
    if (!(position >= box.lo[axis])) position = box.lo[axis];  // also catches NaN
    if (position > box.hi[axis]) position = box.hi[axis];

    AABB plane = box;
    plane.lo[axis] = position;
    plane.hi[axis] = position;

    SplitBounds pieces{AABB::empty(), AABB::empty()};
    if (prim->primID < context.scene->triangles.size())
        pieces = split_triangle_bounds(context.scene->triangles[prim->primID], box, axis, position);
    // The clipper keeps its results inside `box` and on their own side of the plane; intersecting
    // again only guards the contract Embree relies on.
    AABB left = pieces.left.is_empty() ? plane : intersect(pieces.left, box);
    AABB right = pieces.right.is_empty() ? plane : intersect(pieces.right, box);
    left.hi[axis] = std::min(left.hi[axis], position);
    right.lo[axis] = std::max(right.lo[axis], position);
    if (left.is_empty()) left = plane;
    if (right.is_empty()) right = plane;
    store(left, *prim, *left_out);
    store(right, *prim, *right_out);
}

bool build_progress(void* user, double fraction) {
    BuildContext& context = *static_cast<BuildContext*>(user);
    try {
        context.options->hooks.progress(std::clamp(fraction, 0.0, 1.0));
        return true;
    } catch (...) {
        std::lock_guard<std::mutex> lock(context.failure_mutex);
        if (!context.progress_failure) context.progress_failure = std::current_exception();
        return false;  // cancels the build
    }
}

// Owns the RTCBVH (and with it every temporary node).
struct BvhHandle {
    RTCBVH bvh = nullptr;
    ~BvhHandle() {
        if (bvh) rtcReleaseBVH(bvh);
    }
};

// Depth-first conversion, left first, siblings adjacent. Returns the node's box: a leaf's is the
// union of its references' bounds, an inner node's the union of its children's boxes as Embree
// reported them (setNodeBounds), extended by the boxes computed below so that containment holds
// even if the two ever differed by rounding.
class Converter {
public:
    Converter(Bvh& bvh, size_t triangle_count) : bvh_(bvh), triangle_count_(triangle_count) {}

    AABB emit(const void* node, uint32_t out_index) {
        if (!node) throw Error("Embree: rtcBuildBVH returned a tree with a missing node");
        if (kind_of(node) == TempKind::leaf) return emit_leaf(*static_cast<const TempLeaf*>(node), out_index);
        const TempInner& inner = *static_cast<const TempInner*>(node);
        if (inner.child_count == 1) return emit(inner.children[0], out_index);  // nothing to choose between
        const uint32_t first_child = uint32_t(bvh_.nodes.size());
        bvh_.nodes.resize(bvh_.nodes.size() + 2);
        bvh_.nodes[out_index].first = first_child;
        bvh_.nodes[out_index].reference_count = 0;
        AABB box = AABB::empty();
        for (unsigned i = 0; i < kBinary; ++i) {
            const AABB below = emit(inner.children[i], first_child + i);
            const AABB child = merge(below, inner.child_bounds[i].is_empty() ? below : inner.child_bounds[i]);
            bvh_.nodes[first_child + i].bounds = child;
            box.extend(child);
        }
        bvh_.nodes[out_index].bounds = box;
        return box;
    }

private:
    AABB emit_leaf(const TempLeaf& leaf, uint32_t out_index) {
        const size_t first = bvh_.primitives.size();
        const uint32_t* ids = leaf.ids();
        for (uint32_t i = 0; i < leaf.count; ++i) {
            if (ids[i] >= triangle_count_)
                throw Error("Embree: a leaf refers to primitive " + std::to_string(ids[i]) + " of " +
                            std::to_string(triangle_count_));
            bvh_.primitives.push_back(ids[i]);
        }
        // Pieces of one split triangle may meet in a leaf: list each triangle once.
        std::sort(bvh_.primitives.begin() + first, bvh_.primitives.end());
        bvh_.primitives.erase(std::unique(bvh_.primitives.begin() + first, bvh_.primitives.end()),
                              bvh_.primitives.end());
        BvhNode& out = bvh_.nodes[out_index];
        out.first = uint32_t(first);
        out.reference_count = uint32_t(bvh_.primitives.size() - first);
        out.bounds = leaf.bounds;
        return leaf.bounds;
    }

    Bvh& bvh_;
    size_t triangle_count_;
};

}  // namespace

Bvh build_bvh_with_embree(const Scene& scene, EmbreeQuality quality, const BuildConfig& options) {
    // Validate the shared options (the builder name is ours to set, so check with a known one).
    {
        BuildConfig check;
        check.cost = options.cost;
        check.limits = options.limits;
        check.validate();
    }
    if (quality == EmbreeQuality::low)
        throw Error(
            "Embree binary trees: quality 'low' (Morton, leaves of one triangle) is not offered; use "
            "medium or high");
    if (options.limits.max_leaf_size > RTC_BUILD_MAX_PRIMITIVES_PER_LEAF)
        throw Error("Embree binary trees: max leaf size must be at most " +
                    std::to_string(int(RTC_BUILD_MAX_PRIMITIVES_PER_LEAF)) + ", got " +
                    std::to_string(options.limits.max_leaf_size));
    const size_t triangle_count = scene.triangles.size();
    if (triangle_count == 0) throw Error("scene '" + scene.name + "' has no triangles to build a BVH over");
    if (triangle_count >= (size_t(1) << 31))
        throw Error("scene '" + scene.name + "' has too many triangles (at most 2^31 - 1)");

    const bool high = quality == EmbreeQuality::high;
    size_t capacity = triangle_count;
    if (high) {
        capacity = size_t(std::floor(double(options.limits.reference_budget) * double(triangle_count)));
        capacity = std::max(capacity, triangle_count);
    }

    std::vector<RTCBuildPrimitive> primitives(capacity);
    for (size_t i = 0; i < triangle_count; ++i) {
        const AABB b = scene.triangles[i].bounds();
        RTCBuildPrimitive& p = primitives[i];
        p.lower_x = b.lo.x;
        p.lower_y = b.lo.y;
        p.lower_z = b.lo.z;
        p.geomID = 0;
        p.upper_x = b.hi.x;
        p.upper_y = b.hi.y;
        p.upper_z = b.hi.z;
        p.primID = uint32_t(i);
    }

    BuildContext context;
    context.scene = &scene;
    context.options = &options;

    RTCDevice device = embree_device();
    rtcGetDeviceError(device);  // clear a stale error code of this thread
    BvhHandle handle;
    handle.bvh = rtcNewBVH(device);
    check_embree(device, "rtcNewBVH");
    if (!handle.bvh) throw Error("Embree: rtcNewBVH returned no BVH");

    RTCBuildArguments arguments = rtcDefaultBuildArguments();
    arguments.byteSize = sizeof(arguments);
    arguments.buildQuality = high ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
    arguments.buildFlags = RTC_BUILD_FLAG_NONE;
    arguments.maxBranchingFactor = kBinary;
    arguments.maxDepth = options.limits.max_depth;
    arguments.sahBlockSize = 1;
    arguments.minLeafSize = 1;
    arguments.maxLeafSize = options.limits.max_leaf_size;
    arguments.traversalCost = options.cost.traversal_cost;
    arguments.intersectionCost = options.cost.intersection_cost;
    arguments.bvh = handle.bvh;
    arguments.primitives = primitives.data();
    arguments.primitiveCount = triangle_count;
    arguments.primitiveArrayCapacity = capacity;
    arguments.createNode = create_node;
    arguments.setNodeChildren = set_node_children;
    arguments.setNodeBounds = set_node_bounds;
    arguments.createLeaf = create_leaf;
    arguments.splitPrimitive = high ? split_primitive : nullptr;
    arguments.buildProgress = options.hooks.progress ? build_progress : nullptr;
    arguments.userPtr = &context;

    const void* root = rtcBuildBVH(&arguments);
    if (context.progress_failure) std::rethrow_exception(context.progress_failure);
    check_embree(device, "rtcBuildBVH");
    if (!context.failure.empty()) throw Error("Embree: rtcBuildBVH: " + context.failure);
    if (!root) throw Error("Embree: rtcBuildBVH returned no tree");

    Bvh bvh;
    bvh.builder = high ? "embree-high" : "embree-medium";
    bvh.cost = options.cost;
    bvh.primitives.reserve(capacity);
    bvh.nodes.resize(1);
    Converter(bvh, triangle_count).emit(root, 0);
    if (options.hooks.progress) options.hooks.progress(1.0);
    return bvh;
}

uint64_t estimate_embree_tree_memory(uint64_t triangle_count, const std::string& builder, const BuildConfig& options) {
    const bool high = builder == "embree-high";
    const uint64_t capacity =
        high ? std::max<uint64_t>(triangle_count,
                                  uint64_t(double(options.limits.reference_budget) * double(triangle_count)))
             : triangle_count;
    // Per reference: the build primitive, Embree's temporary nodes and leaves (measured on
    // builtin:city:N, about kEmbreeTemporaryBytes), the converted tree (about one 32-byte node and a
    // 4-byte id) and the node array's growth by doubling; and thread stacks and Embree's own buffers.
    constexpr uint64_t kEmbreeTemporaryBytes = 48, kFixedBytes = uint64_t(16) << 20;
    return kFixedBytes +
           capacity * (sizeof(RTCBuildPrimitive) + kEmbreeTemporaryBytes + 2 * sizeof(BvhNode) + sizeof(uint32_t));
}

Bvh build_embree_tree(const Scene& scene, const std::string& builder, const BuildConfig& options) {
    if (!is_embree_tree(builder))
        throw Error("'" + builder + "' is not one of Embree's trees (embree-medium, embree-high)");
    check_memory_estimate("scene '" + scene.name + "' (" + std::to_string(scene.triangles.size()) +
                              " triangles, builder " + builder + ")",
                          estimate_embree_tree_memory(scene.triangles.size(), builder, options),
                          options.limits.memory_limit_bytes);
    Bvh bvh =
        build_bvh_with_embree(scene, builder == "embree-high" ? EmbreeQuality::high : EmbreeQuality::medium, options);
    optimize(bvh, options.reinsertion, options.limits.max_depth, options.hooks);
    return bvh;
}

}  // namespace spacebvh::tools
