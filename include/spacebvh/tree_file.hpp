// SPDX-License-Identifier: MIT
// Tree files: a built binary tree saved to bytes or a file and loaded later without rebuilding.
//
// The format (docs/tree-format.md) is versioned little-endian binary: a fixed header (magic, format
// version, endianness marker, record sizes, counts, the builder label and cost model), a hash of the
// geometry the tree was built over, the nodes and primitive ids, and a checksum over everything
// before it. Loading validates all of it before the tree is used: a file that is truncated,
// corrupted, of another format version or built over other geometry throws Error naming the file and
// what is wrong; a tree that loads is one the tracers can traverse safely and that gives the answers
// the saved tree gave.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/cost_model.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh {

// The format version this library writes and the only one it reads.
inline constexpr uint32_t kTreeFileVersion = 1;
// Trees deeper than this are refused on load: the traversal stacks are sized for the depth limit the
// builders accept.
inline constexpr uint32_t kTreeFileMaxDepth = 1024;

// What a tree file says about itself besides the tree.
struct TreeFileInfo {
    uint32_t format_version = 0;
    uint64_t triangle_count = 0;  // of the geometry the tree was built over
    uint64_t geometry_hash = 0;   // geometry_hash() of that geometry
    uint64_t node_count = 0, primitive_count = 0;
    std::string builder;   // Bvh::builder
    CostModel cost;        // Bvh::cost
    std::string settings;  // free text the saver attached (the CLI: the build flags); may be empty
};

// A 64-bit hash of the triangles' coordinate bit patterns (in order) and their count: another
// triangle count, order or any changed coordinate bit gives another hash (up to collisions).
uint64_t geometry_hash(std::span<const Triangle> triangles);

// The tree file of `bvh` built over `triangles`. `settings` is stored as given (at most 1 MiB).
// Throws Error for an empty tree or one whose counts do not fit the format.
std::vector<std::byte> serialize_bvh(const Bvh& bvh, std::span<const Triangle> triangles,
                                     std::string_view settings = {});

// The tree in `bytes`, validated against `triangles` (see above); `source_name` (the file name)
// starts every error message. Fills `info` when given.
Bvh deserialize_bvh(std::span<const std::byte> bytes, std::span<const Triangle> triangles,
                    const std::string& source_name, TreeFileInfo* info = nullptr);

// serialize_bvh to a file (replaced if present). Throws Error naming the path when it cannot be written.
void save_bvh(const std::string& path, const Bvh& bvh, std::span<const Triangle> triangles,
              std::string_view settings = {});

// The file read in one read, then deserialize_bvh with the path as the source name.
Bvh load_bvh(const std::string& path, std::span<const Triangle> triangles, TreeFileInfo* info = nullptr);

}  // namespace spacebvh
