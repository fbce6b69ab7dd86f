// SPDX-License-Identifier: MIT
// What the library's own callers reach inside a Tracer (not installed): RenderScene calls its meshes'
// kernels directly and refits their layouts over triangles it has checked already.
#pragma once

#include <span>

#include "spacebvh/trace.hpp"
#include "trace/kernels/kernels.hpp"
#include "trace/layout/wide_layout.hpp"

namespace spacebvh {

struct TracerInternals {
    // The tracer's single-ray kernel entry (kernels.hpp, KernelEntry).
    static trace::KernelEntry entry(const Tracer& tracer);
    // Tracer::refit without its checks: `triangles` (the ones `mesh` shows) are finite and `bvh` names
    // none past them, which the caller has made sure of. `same_degenerate`: exactly the triangles that
    // were degenerate when the layout was last made or refitted are degenerate now (the caller compared
    // them), so the layout's check of that is skipped (refit_wide).
    static bool refit_checked(Tracer& tracer, const MeshView& mesh, std::span<const Triangle> triangles, const Bvh& bvh,
                              bool same_degenerate = false);
    // refit_boxes(bvh, triangles) and then refit_checked(..., same_degenerate = true), in one walk of the
    // tree where the layout allows (trace::refit_tree_and_wide). The same conditions on `triangles`.
    static void refit_tree_checked(Tracer& tracer, const MeshView& mesh, std::span<const Triangle> triangles, Bvh& bvh);
    // The same over `moved` (a soup the tree indexes) before it is checked: in one walk that checks every
    // coordinate it reads (trace::refit_tree_and_wide with restore = `current`, the triangles the tree
    // and layout hold now). unsupported and not_finite change nothing.
    static trace::TreeRefit refit_tree_unchecked(Tracer& tracer, std::span<const Triangle> moved,
                                                 std::span<const Triangle> current, Bvh& bvh);
};

}  // namespace spacebvh
