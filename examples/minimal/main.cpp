// SPDX-License-Identifier: MIT
// The smallest use of spacebvh: two triangles, a tree, one ray.
#include <spacebvh/spacebvh.hpp>

#include <cstdio>

int main() {
    const float vertices[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};  // a unit square at z = 0
    const uint32_t indices[] = {0, 1, 2, 0, 2, 3};                  // as two triangles
    const spacebvh::MeshView mesh(vertices, indices);
    const spacebvh::Bvh bvh = spacebvh::build(mesh, spacebvh::Quality::balanced);
    const spacebvh::Tracer tracer(mesh, bvh);  // Kernel::automatic: the fastest on this CPU
    const spacebvh::Hit hit = tracer.intersect(spacebvh::Ray{{0.25f, 0.5f, -1}, {0, 0, 1}});
    std::printf("t = %g on triangle %u\n", hit.t, hit.primitive);
    return hit.is_hit() ? 0 : 1;
}
