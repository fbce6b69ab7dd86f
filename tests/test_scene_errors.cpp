// SPDX-License-Identifier: MIT
// RenderScene's bad input: singular, non-finite and badly conditioned transforms, unknown and detached
// ids, scenes changed while instanced, uncommitted and stale scenes, packet kernels, wrong batch sizes;
// each a clear Error, and the scene unchanged after it. Degenerate triangles are legal and never hit.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"
#include "scene_test_support.hpp"
#include "spacebvh/scene.hpp"

using namespace spacebvh;

namespace {

using scene_testing::expect_error;

const std::vector<Triangle>& square() {
    static const std::vector<Triangle> t = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}, {{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
    return t;
}

std::shared_ptr<RenderScene> committed_square(const std::string& name = "square") {
    auto s = std::make_shared<RenderScene>(SceneConfig{}, name);
    s->attach_mesh(MeshView(square()));
    s->commit();
    return s;
}

Affine scaled(float x, float y, float z) {
    Affine a;
    a.m[0] = x;
    a.m[5] = y;
    a.m[10] = z;
    return a;
}

TEST(SceneErrors, BadTransformsAreRefusedAndLeaveTheSceneAsItWas) {
    const auto child = committed_square();
    RenderScene top(SceneConfig{}, "top");
    top.attach_instance(child, Affine::identity());
    top.commit();
    expect_error([&] { top.attach_instance(child, scaled(1, 0, 1)); }, "singular");
    Affine nan = Affine::identity();
    nan.m[7] = std::numeric_limits<float>::quiet_NaN();
    expect_error([&] { top.attach_instance(child, nan); }, "entry (1, 3) is not finite");
    Affine inf = Affine::identity();
    inf.m[2] = std::numeric_limits<float>::infinity();
    expect_error([&] { top.attach_instance(child, inf); }, "entry (0, 2) is not finite");
    expect_error([&] { top.attach_instance(child, scaled(1, 1e-6f, 1)); }, "nearly singular");
    Affine flat = Affine::identity();  // the second row is twice the first
    flat.m = {1, 2, 3, 0, 2, 4, 6, 0, 0, 0, 1, 0};
    expect_error([&] { top.attach_instance(child, flat); }, "singular (determinant 0)");
    const float bad_row[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1};
    expect_error([&] { (void)Affine::from_4x4(std::span<const float, 16>(bad_row)); }, "last row");
    // Nothing half-built: still one geometry, still committed, still traceable.
    EXPECT_EQ(top.geometry_count(), 1u);
    EXPECT_TRUE(top.committed());
    EXPECT_TRUE(top.intersect(Ray{{0.5f, 0.25f, 1}, {0, 0, -1}}).is_hit());
}

TEST(SceneErrors, InstancesNeedACommittedOtherSceneWithinTheNestingLimit) {
    RenderScene top(SceneConfig{}, "top");
    expect_error([&] { top.attach_instance(nullptr, Affine::identity()); }, "no scene given");
    auto open = std::make_shared<RenderScene>(SceneConfig{}, "open");
    open->attach_mesh(MeshView(square()));
    expect_error([&] { top.attach_instance(open, Affine::identity()); }, "scene 'open' is not committed");
    auto self = committed_square("self");
    expect_error([&] { self->attach_instance(self, Affine::identity()); }, "cannot instance itself");
    std::shared_ptr<RenderScene> chain = committed_square("level0");
    for (uint32_t level = 1; level <= kMaxInstanceLevels; ++level) {
        auto next = std::make_shared<RenderScene>(SceneConfig{}, "level" + std::to_string(level));
        next->attach_instance(chain, Affine::identity());
        next->commit();
        EXPECT_EQ(next->depth(), level);
        chain = next;
    }
    EXPECT_TRUE(chain->intersect(Ray{{0.5f, 0.25f, 1}, {0, 0, -1}}).instance[kMaxInstanceLevels - 1] != kInvalidIndex);
    expect_error([&] { top.attach_instance(chain, Affine::identity()); }, "at most 4 levels");
}

TEST(SceneErrors, UnknownDetachedAndSharedIds) {
    auto child = std::make_shared<RenderScene>(SceneConfig{}, "child");
    const uint32_t a = child->attach_mesh(MeshView(square()));
    const uint32_t b = child->attach_mesh(MeshView(square()), 0x2);
    child->commit();
    expect_error([&] { child->detach(99); }, "scene 'child': no geometry with id 99");
    expect_error([&] { child->set_mask(7, 1); }, "no geometry with id 7");
    RenderScene top(SceneConfig{}, "top");
    const uint32_t inst = top.attach_instance(child, Affine::identity());
    top.commit();
    // A mesh cannot leave a scene that is instanced: the instance's box and ids would go stale.
    expect_error([&] { child->detach(a); }, "cannot detach geometry 0 while 1 instance(s)");
    expect_error([&] { child->attach_mesh(MeshView(square())); }, "cannot attach a mesh while");
    expect_error([&] { child->commit(); }, "cannot commit while");
    top.detach(inst);
    expect_error([&] { top.detach(inst); }, "no geometry with id 0 (detached)");
    expect_error([&] { top.intersect(Ray{}); }, "not committed");
    child->detach(b);  // no instance left: allowed
    expect_error([&] { child->refit(b); }, "(detached)");
    child->commit();
    EXPECT_EQ(child->geometry_count(), 1u);
    expect_error(
        [&] {
            RenderScene empty(SceneConfig{}, "empty");
            empty.commit();
        },
        "nothing to commit");
}

TEST(SceneErrors, RefitOfAnInstancedSceneMakesItsParentsRefit) {
    std::vector<float> xyz = {0, 0, 0, 1, 0, 0, 1, 1, 0};
    const std::vector<uint32_t> index = {0, 1, 2};
    auto child = std::make_shared<RenderScene>(SceneConfig{}, "child");
    const uint32_t mesh = child->attach_mesh(MeshView(std::span<const float>(xyz), std::span<const uint32_t>(index)));
    child->commit();
    RenderScene top(SceneConfig{}, "top");
    const uint32_t inst = top.attach_instance(child, Affine::identity());
    top.commit();
    const Ray ray{{0.9f, 0.95f, 1}, {0, 0, -1}};
    EXPECT_FALSE(top.intersect(ray).is_hit());
    for (size_t v = 0; v < 3; ++v) xyz[3 * v + 1] += 0.5f;  // the triangle moves under the ray
    child->refit(mesh);
    expect_error([&] { top.intersect(ray); }, "instances scene 'child', which was refitted since");
    expect_error([&] { top.refit(inst); }, "is an instance");
    top.refit();
    const SceneHit hit = top.intersect(ray);
    EXPECT_TRUE(hit.is_hit());
    EXPECT_EQ(hit.instance[0], inst);
    EXPECT_EQ(hit.geometry, mesh);
    xyz[0] = std::numeric_limits<float>::quiet_NaN();
    expect_error([&] { child->refit(mesh); }, "mesh 0");
}

TEST(SceneErrors, KernelsBatchesAndMeshes) {
    SceneConfig packets;
    packets.tracer.kernel = Kernel::packet8;
    expect_error([&] { RenderScene s(packets, "p"); }, "kernel 'packet8' cannot trace scenes");
    auto s = committed_square();
    std::vector<Ray> rays(3);
    std::vector<SceneHit> hits(2);
    expect_error([&] { s->intersect(rays, hits); }, "3 rays but 2 answers");
    std::vector<uint8_t> blocked(3);
    std::vector<uint32_t> masks(2);
    expect_error([&] { s->occluded(rays, blocked, {}, masks); }, "3 rays but 2 masks");
    const std::vector<float> xyz = {0, 0, 0, 1, 0, 0, 1, std::numeric_limits<float>::infinity(), 0};
    const std::vector<uint32_t> index = {0, 1, 2};
    RenderScene bad(SceneConfig{}, "bad");
    expect_error(
        [&] { bad.attach_mesh(MeshView(std::span<const float>(xyz), std::span<const uint32_t>(index)).named("wing")); },
        "wing");
    const std::vector<uint32_t> out_of_range = {0, 1, 5};
    expect_error(
        [&] { bad.attach_mesh(MeshView(std::span<const float>(xyz), std::span<const uint32_t>(out_of_range))); },
        "mesh 0");
    expect_error([&] { bad.attach_mesh(MeshView(std::vector<Triangle>{})); }, "no triangles");
    EXPECT_EQ(bad.geometry_count(), 0u);
}

TEST(SceneErrors, DegenerateTrianglesAreLegalAndNeverHit) {
    const std::vector<Triangle> tris = {{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}},   // a segment
                                        {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}},   // a point
                                        {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}}};  // a real one, above
    auto child = std::make_shared<RenderScene>(SceneConfig{}, "child");
    child->attach_mesh(MeshView(tris));
    child->commit();
    RenderScene top(SceneConfig{}, "top");
    top.attach_instance(child, scaled(2, -1, 1));
    top.commit();
    // Straight down through the segment's and the point's world positions: nothing below z = 1.
    EXPECT_FALSE(top.intersect(Ray{{1, 0, 0.5f}, {0, 0, -1}}).is_hit());
    EXPECT_FALSE(top.occluded(Ray{{0, 0, 0.5f}, {0, 0, -1}}));
    const SceneHit hit = top.intersect(Ray{{0.2f, -0.2f, 3}, {0, 0, -1}});
    EXPECT_EQ(hit.primitive, 2u);
    EXPECT_FLOAT_EQ(hit.t, 2.0f);
}

}  // namespace
