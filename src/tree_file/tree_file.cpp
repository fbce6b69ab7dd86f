// SPDX-License-Identifier: MIT
// Tree files (docs/tree-format.md): writing, and loading with every check made before the tree is
// handed out.
#include "spacebvh/tree_file.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sstream>
#include <type_traits>

#include "tree_file/file_bytes.hpp"
#include "tree_file/tree_file_checksum.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {
namespace {

using namespace tree_file_detail;

// ---------------------------------------------------------------------------------------------------
// The 64-bit hash behind the checksum and the geometry hash. Four lanes take the input's 64-bit words
// in turn; a lane absorbs a word by h = rotl((h ^ w) * K, 29), a bijection of h for a given w, and
// the lanes are folded by bijective mixes, so a file that differs from the written one in any single
// 64-bit word (any flipped byte) always fails the checksum; more scattered damage escapes it with
// probability about 2^-64.

constexpr uint64_t kLaneMultiplier = 0x9E3779B97F4A7C15ull;  // odd: 2^64 / golden ratio
constexpr uint64_t kMixMultiplier = 0xC2B2AE3D27D4EB4Full;   // odd
constexpr uint64_t kChecksumSeed = 0x7472656566696C65ull;    // "treefile"
constexpr uint64_t kGeometrySeed = 0x67656F6D65747279ull;    // "geometry"

constexpr uint64_t rotl(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }
constexpr uint64_t absorb(uint64_t h, uint64_t word) { return rotl((h ^ word) * kLaneMultiplier, 29); }
constexpr uint64_t mix(uint64_t x) {
    x ^= x >> 31;
    x *= kMixMultiplier;
    x ^= x >> 29;
    x *= kLaneMultiplier;
    x ^= x >> 32;
    return x;
}

uint64_t hash_bytes(const std::byte* data, size_t size, uint64_t seed) {
    uint64_t lane[4] = {seed, seed ^ kMixMultiplier, rotl(seed, 17) ^ kLaneMultiplier, ~seed};
    size_t at = 0;
    for (; at + 32 <= size; at += 32)
        for (int i = 0; i < 4; ++i) lane[i] = absorb(lane[i], load_le<uint64_t>(data + at + 8 * i));
    for (int i = 0; at + 8 <= size; at += 8, ++i) lane[i] = absorb(lane[i], load_le<uint64_t>(data + at));
    if (at < size) {  // the last 1..7 bytes, zero-filled; the length below tells them from zeros
        uint64_t tail = 0;
        for (size_t i = 0; at + i < size; ++i) tail |= uint64_t(std::to_integer<uint8_t>(data[at + i])) << (8 * i);
        lane[3] = absorb(lane[3], tail);
    }
    uint64_t h = mix(seed ^ uint64_t(size));
    for (const uint64_t l : lane) h = mix(h ^ l);
    return h;
}

// ---------------------------------------------------------------------------------------------------
// The layout (docs/tree-format.md).

constexpr char kMagic[8] = {'S', 'B', 'V', 'H', 'T', 'R', 'E', 'E'};
constexpr uint32_t kEndianMarker = 0x0A0B0C0Du;  // bytes 0D 0C 0B 0A in a little-endian file
constexpr uint64_t kHeaderSize = 96;
constexpr uint32_t kNodeRecordSize = 32;
constexpr uint32_t kPrimitiveRecordSize = 4;
constexpr uint64_t kMaxBuilderLength = 4096;
constexpr uint64_t kMaxSettingsLength = 1u << 20;
constexpr uint64_t kMaxCount = 0xFFFFFFFFull;  // node and primitive indices are 32-bit

// Header field offsets.
enum : size_t {
    kAtMagic = 0,
    kAtVersion = 8,
    kAtEndian = 12,
    kAtHeaderSize = 16,
    kAtNodeRecordSize = 20,
    kAtPrimitiveRecordSize = 24,
    kAtFlags = 28,
    kAtFileSize = 32,
    kAtTriangleCount = 40,
    kAtGeometryHash = 48,
    kAtNodeCount = 56,
    kAtPrimitiveCount = 64,
    kAtTraversalCost = 72,
    kAtIntersectionCost = 76,
    kAtOverlapPenalty = 80,
    kAtLeafBlock = 84,
    kAtBuilderLength = 88,
    kAtSettingsLength = 92,
};

// Where each section starts; every count is below 2^32, so no sum overflows.
struct Layout {
    uint64_t text, nodes, primitives, checksum, size;
};
Layout layout_of(uint64_t builder_length, uint64_t settings_length, uint64_t node_count, uint64_t primitive_count) {
    Layout layout;
    layout.text = kHeaderSize;
    layout.nodes = layout.text + pad8(builder_length + settings_length);
    layout.primitives = layout.nodes + node_count * kNodeRecordSize;
    layout.checksum = layout.primitives + pad8(primitive_count * kPrimitiveRecordSize);
    layout.size = layout.checksum + 8;
    return layout;
}

static_assert(sizeof(BvhNode) == kNodeRecordSize && std::is_trivially_copyable_v<BvhNode>);
static_assert(offsetof(BvhNode, bounds) == 0 && offsetof(BvhNode, first) == 24 &&
              offsetof(BvhNode, reference_count) == 28);
static_assert(sizeof(Triangle) == 36 && std::is_trivially_copyable_v<Triangle>);

void store_node(std::byte* p, const BvhNode& node) {
    const float box[6] = {node.bounds.lo.x, node.bounds.lo.y, node.bounds.lo.z,
                          node.bounds.hi.x, node.bounds.hi.y, node.bounds.hi.z};
    for (int i = 0; i < 6; ++i) store_f32(p + 4 * i, box[i]);
    store_le(p + 24, node.first);
    store_le(p + 28, node.reference_count);
}
BvhNode load_node(const std::byte* p) {
    BvhNode node;
    node.bounds.lo = {load_f32(p), load_f32(p + 4), load_f32(p + 8)};
    node.bounds.hi = {load_f32(p + 12), load_f32(p + 16), load_f32(p + 20)};
    node.first = load_le<uint32_t>(p + 24);
    node.reference_count = load_le<uint32_t>(p + 28);
    return node;
}

bool box_is_valid(const AABB& box) {
    return is_finite(box.lo) && is_finite(box.hi) && box.lo.x <= box.hi.x && box.lo.y <= box.hi.y &&
           box.lo.z <= box.hi.z;
}

bool boxes_meet(const AABB& a, const AABB& b) { return !intersect(a, b).is_empty(); }

// Does a leaf list a triangle twice? Leaves are small; large ones are checked on a sorted copy.
bool lists_twice(std::span<const uint32_t> ids) {
    if (ids.size() <= 16) {
        for (size_t i = 1; i < ids.size(); ++i)
            for (size_t j = 0; j < i; ++j)
                if (ids[i] == ids[j]) return true;
        return false;
    }
    std::vector<uint32_t> sorted(ids.begin(), ids.end());
    std::sort(sorted.begin(), sorted.end());
    return std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end();
}

// "" when the tree is safe to traverse and faithful to the triangles, else the first problem: every
// box finite and not inverted, child indices in range, every node reached exactly once from the root
// (no shared subtree, no cycle), depth within kTreeFileMaxDepth, parents containing their children,
// leaf ranges inside the primitive array, ids below the triangle count and not repeated in a leaf,
// each leaf box meeting the boxes of its triangles, and each vertex of a triangle that can be hit
// (not degenerate) lying in the box of a leaf that lists it.
std::string tree_problem(const Bvh& bvh, std::span<const Triangle> triangles) {
    const std::vector<BvhNode>& nodes = bvh.nodes;
    const uint64_t node_count = nodes.size(), primitive_count = bvh.primitives.size();
    for (size_t i = 0; i < nodes.size(); ++i)
        if (!box_is_valid(nodes[i].bounds)) return "node " + std::to_string(i) + " has a non-finite or inverted box";
    std::vector<uint8_t> reached(nodes.size(), 0);
    std::vector<uint8_t> vertices_covered(triangles.size(), 0);  // bit v: vertex v in a listing leaf's box
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};  // node, depth
    reached[0] = 1;
    while (!stack.empty()) {
        const auto [index, depth] = stack.back();
        stack.pop_back();
        if (depth > kTreeFileMaxDepth)
            return "the tree is deeper than " + std::to_string(kTreeFileMaxDepth) + " levels (node " +
                   std::to_string(index) + ")";
        const BvhNode& node = nodes[index];
        if (node.is_leaf()) {
            if (uint64_t(node.first) + node.reference_count > primitive_count)
                return "leaf " + std::to_string(index) + " lists primitives [" + std::to_string(node.first) + ", " +
                       std::to_string(uint64_t(node.first) + node.reference_count) + ") of only " +
                       std::to_string(primitive_count);
            const std::span<const uint32_t> ids(bvh.primitives.data() + node.first, node.reference_count);
            for (const uint32_t id : ids) {
                if (id >= triangles.size())
                    return "leaf " + std::to_string(index) + " names triangle " + std::to_string(id) + " of only " +
                           std::to_string(triangles.size());
                const Triangle& triangle = triangles[id];
                if (triangle.is_degenerate()) continue;  // never hit: its place cannot change an answer
                if (!boxes_meet(node.bounds, triangle.bounds()))
                    return "leaf " + std::to_string(index) + "'s box misses its triangle " + std::to_string(id);
                for (int v = 0; v < 3; ++v)
                    if (node.bounds.contains(triangle.vertex(v))) vertices_covered[id] |= uint8_t(1u << v);
            }
            if (lists_twice(ids)) return "leaf " + std::to_string(index) + " lists a triangle twice";
            continue;
        }
        if (uint64_t(node.first) + 1 >= node_count)
            return "node " + std::to_string(index) + " has children at " + std::to_string(node.first) + " of only " +
                   std::to_string(node_count) + " nodes";
        for (const uint32_t child : {node.first + 1, node.first}) {  // left on top: visited first
            if (reached[child]++)
                return "node " + std::to_string(child) +
                       " is reached twice from the root (a shared subtree or a cycle)";
            if (!node.bounds.contains(nodes[child].bounds))
                return "node " + std::to_string(index) + "'s box does not contain its child " + std::to_string(child);
            stack.push_back({child, depth + 1});
        }
    }
    const auto unreached = std::find(reached.begin(), reached.end(), 0);
    if (unreached != reached.end())
        return "node " + std::to_string(unreached - reached.begin()) + " is not reached from the root";
    for (size_t id = 0; id < triangles.size(); ++id) {
        if (vertices_covered[id] == 7 || triangles[id].is_degenerate()) continue;
        const int v = std::countr_one(unsigned(vertices_covered[id]));
        return "triangle " + std::to_string(id) + " is not covered: its vertex " + std::to_string(v) +
               " lies in no leaf box that lists it";
    }
    return "";
}

}  // namespace

uint64_t tree_file_detail::checksum(std::span<const std::byte> covered) {
    return hash_bytes(covered.data(), covered.size(), kChecksumSeed);
}

uint64_t geometry_hash(std::span<const Triangle> triangles) {
    const uint64_t seed = kGeometrySeed ^ mix(uint64_t(triangles.size()));
    if constexpr (kLittleHost)
        return hash_bytes(reinterpret_cast<const std::byte*>(triangles.data()), triangles.size_bytes(), seed);
    std::vector<std::byte> bytes(triangles.size_bytes());
    for (size_t t = 0; t < triangles.size(); ++t)
        for (int v = 0; v < 3; ++v)
            for (int axis = 0; axis < 3; ++axis)
                store_f32(bytes.data() + 36 * t + 12 * v + 4 * axis, triangles[t].vertex(v)[axis]);
    return hash_bytes(bytes.data(), bytes.size(), seed);
}

std::vector<std::byte> serialize_bvh(const Bvh& bvh, std::span<const Triangle> triangles, std::string_view settings) {
    if (bvh.nodes.empty()) throw Error("tree file: cannot save an empty tree");
    if (bvh.nodes.size() > kMaxCount || bvh.primitives.size() > kMaxCount || triangles.size() > kMaxCount)
        throw Error("tree file: " + std::to_string(bvh.nodes.size()) + " nodes, " +
                    std::to_string(bvh.primitives.size()) + " primitive ids or " + std::to_string(triangles.size()) +
                    " triangles exceed the format's 2^32 - 1");
    if (bvh.builder.size() > kMaxBuilderLength)
        throw Error("tree file: the builder label exceeds " + std::to_string(kMaxBuilderLength) + " bytes");
    if (settings.size() > kMaxSettingsLength)
        throw Error("tree file: the settings text exceeds " + std::to_string(kMaxSettingsLength) + " bytes");
    const Layout layout = layout_of(bvh.builder.size(), settings.size(), bvh.nodes.size(), bvh.primitives.size());
    std::vector<std::byte> bytes(layout.size);  // zero: the padding
    std::byte* out = bytes.data();
    std::memcpy(out + kAtMagic, kMagic, sizeof kMagic);
    store_le(out + kAtVersion, kTreeFileVersion);
    store_le(out + kAtEndian, kEndianMarker);
    store_le(out + kAtHeaderSize, uint32_t(kHeaderSize));
    store_le(out + kAtNodeRecordSize, kNodeRecordSize);
    store_le(out + kAtPrimitiveRecordSize, kPrimitiveRecordSize);
    store_le(out + kAtFlags, uint32_t(0));
    store_le(out + kAtFileSize, layout.size);
    store_le(out + kAtTriangleCount, uint64_t(triangles.size()));
    store_le(out + kAtGeometryHash, geometry_hash(triangles));
    store_le(out + kAtNodeCount, uint64_t(bvh.nodes.size()));
    store_le(out + kAtPrimitiveCount, uint64_t(bvh.primitives.size()));
    store_f32(out + kAtTraversalCost, bvh.cost.traversal_cost);
    store_f32(out + kAtIntersectionCost, bvh.cost.intersection_cost);
    store_f32(out + kAtOverlapPenalty, bvh.cost.overlap_penalty);
    store_le(out + kAtLeafBlock, bvh.cost.leaf_block);
    store_le(out + kAtBuilderLength, uint32_t(bvh.builder.size()));
    store_le(out + kAtSettingsLength, uint32_t(settings.size()));
    copy_bytes(out + layout.text, bvh.builder.data(), bvh.builder.size());
    copy_bytes(out + layout.text + bvh.builder.size(), settings.data(), settings.size());
    if constexpr (kLittleHost) {
        copy_bytes(out + layout.nodes, bvh.nodes.data(), bvh.nodes.size() * kNodeRecordSize);
        copy_bytes(out + layout.primitives, bvh.primitives.data(), bvh.primitives.size() * kPrimitiveRecordSize);
    } else {
        for (size_t i = 0; i < bvh.nodes.size(); ++i)
            store_node(out + layout.nodes + kNodeRecordSize * i, bvh.nodes[i]);
        for (size_t i = 0; i < bvh.primitives.size(); ++i)
            store_le(out + layout.primitives + kPrimitiveRecordSize * i, bvh.primitives[i]);
    }
    store_le(out + layout.checksum, hash_bytes(out, layout.checksum, kChecksumSeed));
    return bytes;
}

Bvh deserialize_bvh(std::span<const std::byte> bytes, std::span<const Triangle> triangles,
                    const std::string& source_name, TreeFileInfo* info) {
    auto fail = [&](const std::string& what) -> Error { return Error(source_name + ": " + what); };
    const std::byte* in = bytes.data();
    const uint64_t size = bytes.size();

    // The header, field by field, before anything it describes is touched.
    if (size >= sizeof kMagic && std::memcmp(in, kMagic, sizeof kMagic) != 0)
        throw fail("not a spacebvh tree file (it does not start with \"SBVHTREE\")");
    if (size < kHeaderSize)
        throw fail("truncated: " + std::to_string(size) + " bytes, shorter than the " + std::to_string(kHeaderSize) +
                   "-byte header");
    const uint32_t marker = load_le<uint32_t>(in + kAtEndian);
    if (marker == byte_swap(kEndianMarker)) throw fail("written big-endian; tree files are little-endian");
    if (marker != kEndianMarker) throw fail("corrupt endianness marker 0x" + hex(marker).substr(8));
    const uint32_t version = load_le<uint32_t>(in + kAtVersion);
    if (version != kTreeFileVersion)
        throw fail("format version " + std::to_string(version) + ", this library reads " +
                   std::to_string(kTreeFileVersion));
    const uint32_t header_size = load_le<uint32_t>(in + kAtHeaderSize);
    const uint32_t node_record_size = load_le<uint32_t>(in + kAtNodeRecordSize);
    const uint32_t primitive_record_size = load_le<uint32_t>(in + kAtPrimitiveRecordSize);
    if (header_size != kHeaderSize || node_record_size != kNodeRecordSize ||
        primitive_record_size != kPrimitiveRecordSize)
        throw fail("record sizes " + std::to_string(header_size) + "/" + std::to_string(node_record_size) + "/" +
                   std::to_string(primitive_record_size) + " bytes (header/node/primitive id), version " +
                   std::to_string(kTreeFileVersion) + " has " + std::to_string(kHeaderSize) + "/" +
                   std::to_string(kNodeRecordSize) + "/" + std::to_string(kPrimitiveRecordSize));
    const uint32_t flags = load_le<uint32_t>(in + kAtFlags);
    if (flags != 0) throw fail("unknown flags 0x" + hex(flags).substr(8));
    const uint64_t builder_length = load_le<uint32_t>(in + kAtBuilderLength);
    const uint64_t settings_length = load_le<uint32_t>(in + kAtSettingsLength);
    if (builder_length > kMaxBuilderLength)
        throw fail("a builder label of " + std::to_string(builder_length) + " bytes (at most " +
                   std::to_string(kMaxBuilderLength) + ")");
    if (settings_length > kMaxSettingsLength)
        throw fail("a settings text of " + std::to_string(settings_length) + " bytes (at most " +
                   std::to_string(kMaxSettingsLength) + ")");
    const uint64_t triangle_count = load_le<uint64_t>(in + kAtTriangleCount);
    const uint64_t node_count = load_le<uint64_t>(in + kAtNodeCount);
    const uint64_t primitive_count = load_le<uint64_t>(in + kAtPrimitiveCount);
    if (node_count == 0) throw fail("the header says the tree has no nodes");
    if (node_count > kMaxCount || primitive_count > kMaxCount || triangle_count > kMaxCount)
        throw fail("the header's counts (" + std::to_string(node_count) + " nodes, " + std::to_string(primitive_count) +
                   " primitive ids, " + std::to_string(triangle_count) + " triangles) exceed the format's 2^32 - 1");
    const Layout layout = layout_of(builder_length, settings_length, node_count, primitive_count);
    if (size < layout.size) {
        const uint64_t room = size > layout.nodes + 8 ? (size - layout.nodes - 8) / kNodeRecordSize : 0;
        throw fail("truncated: the header says " + std::to_string(node_count) + " nodes and " +
                   std::to_string(primitive_count) + " primitive ids (" + std::to_string(layout.size) +
                   " bytes), the file has " + std::to_string(size) + " bytes (room for at most " +
                   std::to_string(room) + " nodes)");
    }
    if (size > layout.size)
        throw fail(std::to_string(size - layout.size) + " bytes past the end the header describes (" +
                   std::to_string(node_count) + " nodes and " + std::to_string(primitive_count) + " primitive ids, " +
                   std::to_string(layout.size) + " bytes)");
    const uint64_t file_size = load_le<uint64_t>(in + kAtFileSize);
    if (file_size != size)
        throw fail("the header says the file has " + std::to_string(file_size) + " bytes, it has " +
                   std::to_string(size));
    const uint64_t stored_checksum = load_le<uint64_t>(in + layout.checksum);
    const uint64_t checksum = hash_bytes(in, layout.checksum, kChecksumSeed);
    if (stored_checksum != checksum)
        throw fail("corrupt: checksum " + hex(checksum) + " does not match the stored " + hex(stored_checksum));
    // Past the checksum only a deliberately altered file can fail; it still gets a clear error.
    for (uint64_t at = layout.text + builder_length + settings_length; at < layout.nodes; ++at)
        if (in[at] != std::byte{0}) throw fail("nonzero padding after the settings text");
    for (uint64_t at = layout.primitives + primitive_count * kPrimitiveRecordSize; at < layout.checksum; ++at)
        if (in[at] != std::byte{0}) throw fail("nonzero padding after the primitive ids");

    Bvh bvh;
    bvh.builder.assign(reinterpret_cast<const char*>(in + layout.text), builder_length);
    bvh.cost.traversal_cost = load_f32(in + kAtTraversalCost);
    bvh.cost.intersection_cost = load_f32(in + kAtIntersectionCost);
    bvh.cost.overlap_penalty = load_f32(in + kAtOverlapPenalty);
    bvh.cost.leaf_block = load_le<uint32_t>(in + kAtLeafBlock);
    try {
        bvh.cost.validate();
    } catch (const Error& e) {
        throw fail(e.what());
    }

    // The geometry.
    if (triangle_count != triangles.size())
        throw fail("built over other geometry (" + std::to_string(triangle_count) + " triangles, this geometry has " +
                   std::to_string(triangles.size()) + ")");
    const uint64_t stored_hash = load_le<uint64_t>(in + kAtGeometryHash);
    const uint64_t hash = geometry_hash(triangles);
    if (stored_hash != hash)
        throw fail("built over other geometry (hash " + hex(stored_hash) + " vs " + hex(hash) +
                   " of this geometry: same triangle count, other coordinates or order)");

    // The tree.
    bvh.nodes.resize(node_count);
    bvh.primitives.resize(primitive_count);
    if constexpr (kLittleHost) {
        copy_bytes(bvh.nodes.data(), in + layout.nodes, node_count * kNodeRecordSize);
        copy_bytes(bvh.primitives.data(), in + layout.primitives, primitive_count * kPrimitiveRecordSize);
    } else {
        for (size_t i = 0; i < node_count; ++i) bvh.nodes[i] = load_node(in + layout.nodes + kNodeRecordSize * i);
        for (size_t i = 0; i < primitive_count; ++i)
            bvh.primitives[i] = load_le<uint32_t>(in + layout.primitives + kPrimitiveRecordSize * i);
    }
    if (const std::string problem = tree_problem(bvh, triangles); !problem.empty())
        throw fail("invalid tree: " + problem);

    if (info) {
        info->format_version = version;
        info->triangle_count = triangle_count;
        info->geometry_hash = stored_hash;
        info->node_count = node_count;
        info->primitive_count = primitive_count;
        info->builder = bvh.builder;
        info->cost = bvh.cost;
        info->settings.assign(reinterpret_cast<const char*>(in + layout.text + builder_length), settings_length);
    }
    return bvh;
}

void save_bvh(const std::string& path, const Bvh& bvh, std::span<const Triangle> triangles, std::string_view settings) {
    tree_file_detail::write_file(path, serialize_bvh(bvh, triangles, settings));
}

Bvh load_bvh(const std::string& path, std::span<const Triangle> triangles, TreeFileInfo* info) {
    const std::vector<std::byte> bytes = tree_file_detail::read_file(path, "tree file");
    return deserialize_bvh(bytes, triangles, path, info);
}

}  // namespace spacebvh
