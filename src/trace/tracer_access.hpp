// SPDX-License-Identifier: MIT
// What the library's own callers reach inside a Tracer (not installed): RenderScene calls its meshes'
// kernels directly and refits their layouts over triangles it has checked already.
#pragma once

#include <span>

#include "spacebvh/trace.hpp"
#include "trace/kernels/kernels.hpp"

namespace spacebvh {

struct TracerInternals {
    // The tracer's single-ray kernel entry (kernels.hpp, KernelEntry).
    static trace::KernelEntry entry(const Tracer& tracer);
    // Tracer::refit without its checks: `triangles` (the ones `mesh` shows) are finite and `bvh` names
    // none past them, which the caller has made sure of.
    static bool refit_checked(Tracer& tracer, const MeshView& mesh, std::span<const Triangle> triangles,
                              const Bvh& bvh);
};

}  // namespace spacebvh
