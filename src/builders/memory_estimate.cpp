// SPDX-License-Identifier: MIT
// The peak memory of build(), from the triangle count and the configuration. The build's arrays, per
// reference of capacity C (the reference budget times the triangle count when references may be
// split or pre-split, the triangle count otherwise), all allocated and written before the first split:
//   references      28 bytes, three copies when a search space reads centroid orders (object sweep)
//   node slots      2 x 36 bytes (2C - 1 slots, top_down_builder.cpp)
// and then, at different times, the partition's copies of the two children at the top nodes (2 x 28
// bytes) or the output tree (a 32-byte node per reference or less, leaves holding two or more, and a
// 4-byte id): 56 bytes; with recursive cost evaluation 56 more. Plus kFixedBytes for thread stacks and the small
// per-node buffers. An indexed mesh adds its 36-byte triangle copy; the reinsertion optimiser runs once the slots and
// references are freed and needs less. On builtin:city:N from 10^6 triangles the measured peak RSS is 0.90 to 1.00 of
// the scene's bytes plus this (bench/scale.sh prints both).
#include "builders/memory_estimate.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "builders/preset_table.hpp"
#include "builders/driver/reference.hpp"
#include "builders/search_spaces/search_spaces.hpp"
#include "builders/driver/top_down_builder.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {
namespace {

constexpr uint64_t kFixedBytes = uint64_t(16) << 20;
constexpr uint64_t kChildrenOrTreeBytes = 2 * sizeof(builders::Reference);
static_assert(kChildrenOrTreeBytes >= sizeof(BvhNode) + sizeof(uint32_t));

}  // namespace

MemoryEstimate estimate_build_memory(uint64_t triangle_count, const BuildConfig& config, bool indexed_mesh) {
    const builders::BuilderPreset& preset = builders::preset_of(config.preset);
    const uint32_t spaces = builders::effective_search_spaces(preset, config);
    const bool grows = builders::splits_references(spaces, config) || preset.presplit != builders::Presplit::none;
    const uint64_t capacity =
        grows ? std::max<uint64_t>(triangle_count,
                                   uint64_t(double(config.limits.reference_budget) * double(triangle_count)))
              : triangle_count;
    const bool keeps_orders = spaces & uint32_t(SearchSpace::object_sweep);
    const uint64_t reference_bytes = (keeps_orders ? 3 : 1) * sizeof(builders::Reference);
    // Leaves of one reference: two nodes per reference.
    const uint64_t tree_bytes =
        config.limits.max_leaf_size == 1 ? 2 * sizeof(BvhNode) + sizeof(uint32_t) : kChildrenOrTreeBytes;
    // Recursive cost evaluation prices each candidate on a copy of the node's references, nested
    // along the subtree it builds: about two copies of the root's.
    const bool looks_ahead = config.lookahead.depth > 0 || config.lookahead.top_share > 0;
    const uint64_t lookahead_bytes = looks_ahead ? 2 * sizeof(builders::Reference) : 0;
    const uint64_t per_reference =
        reference_bytes + 2 * builders::kSlotBytes + std::max(kChildrenOrTreeBytes, tree_bytes) + lookahead_bytes;
    MemoryEstimate estimate;
    estimate.references = capacity;
    estimate.bytes = kFixedBytes + capacity * per_reference + (indexed_mesh ? triangle_count * sizeof(Triangle) : 0);
    return estimate;
}

uint64_t available_memory_bytes() {
    std::ifstream meminfo("/proc/meminfo");
    std::string line;
    while (std::getline(meminfo, line)) {
        if (line.rfind("MemAvailable:", 0) != 0) continue;
        std::istringstream fields(line.substr(13));
        uint64_t kib = 0;
        if (fields >> kib) return kib * 1024;
    }
    return 0;
}

std::string format_bytes(uint64_t bytes) {
    char text[64];
    if (bytes < 1024)
        std::snprintf(text, sizeof text, "%llu bytes", static_cast<unsigned long long>(bytes));
    else if (bytes < (uint64_t(1) << 20))
        std::snprintf(text, sizeof text, "%.1f KiB", double(bytes) / 1024.0);
    else if (bytes < (uint64_t(1) << 30))
        std::snprintf(text, sizeof text, "%.1f MiB", double(bytes) / double(1 << 20));
    else
        std::snprintf(text, sizeof text, "%.2f GiB", double(bytes) / double(uint64_t(1) << 30));
    return text;
}

void check_memory_estimate(const std::string& what, uint64_t estimate_bytes, uint64_t memory_limit_bytes) {
    const uint64_t limit = memory_limit_bytes ? memory_limit_bytes : available_memory_bytes();
    if (limit == 0 || estimate_bytes <= limit) return;
    throw Error(what + ": the build needs about " + format_bytes(estimate_bytes) + " (estimate), more than " +
                (memory_limit_bytes ? "the memory limit of " + format_bytes(limit)
                                    : "the " + format_bytes(limit) + " available (MemAvailable)") +
                "; nothing was built");
}

namespace builders {

void check_build_memory(uint64_t triangle_count, bool indexed_mesh, const std::string& mesh_name,
                        const BuildConfig& config) {
    const MemoryEstimate estimate = estimate_build_memory(triangle_count, config, indexed_mesh);
    const std::string what = "mesh '" + mesh_name + "' (" + std::to_string(triangle_count) + " triangles, builder " +
                             to_string(config.preset) + ")";
    if (estimate.references > kMaxReferenceCapacity)
        throw Error(what + ": the build may hold " + std::to_string(estimate.references) +
                    " references (reference budget " + std::to_string(config.limits.reference_budget) +
                    "), more than the 2^31 - 1 its 32-bit node numbers allow");
    check_memory_estimate(what, estimate.bytes, config.limits.memory_limit_bytes);
}

}  // namespace builders
}  // namespace spacebvh
