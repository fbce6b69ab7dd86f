// SPDX-License-Identifier: MIT
// What the library's own callers reach inside a Tracer (not installed): RenderScene refits its meshes'
// layouts over triangles it has checked already.
#pragma once

#include <span>

#include "spacebvh/trace.hpp"

namespace spacebvh {

struct TracerAccess {
    // Tracer::refit without its checks: `triangles` (the ones `mesh` shows) are finite and `bvh` names
    // none past them, which the caller has made sure of.
    static bool refit_checked(Tracer& tracer, const MeshView& mesh, std::span<const Triangle> triangles,
                              const Bvh& bvh);
};

}  // namespace spacebvh
