// SPDX-License-Identifier: MIT
// build()'s check before it allocates anything: the estimated peak (spacebvh/memory_estimate.hpp)
// against the memory limit, and the reference capacity against the driver's 32-bit slot numbers.
#pragma once

#include <cstdint>
#include <string>

#include "spacebvh/build.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/mesh.hpp"

namespace spacebvh::builders {

// The driver numbers node slots (2 * capacity - 1 of them) and references with 32 bits.
inline constexpr uint64_t kMaxReferenceCapacity = (uint64_t(1) << 31) - 1;

// Throws Error naming the mesh, the estimate and the limit when the build would not fit
// (check_memory_estimate), or when its reference capacity exceeds kMaxReferenceCapacity.
void check_build_memory(uint64_t triangle_count, bool indexed_mesh, const std::string& mesh_name,
                        const BuildConfig& config);
inline void check_build_memory(const MeshView& mesh, const BuildConfig& config) {
    check_build_memory(mesh.triangle_count(), !mesh.is_soup(), mesh.name(), config);
}

}  // namespace spacebvh::builders
