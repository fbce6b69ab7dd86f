// SPDX-License-Identifier: MIT
// The top level's 8-wide box test (scene::WideTopQuery, with the ray prepared once per walk as
// scene::WideRay) against the scalar padded test scene::meets, child by child: the same children
// entered at bit-identical entry distances, on random boxes and rays and on the hostile ones (axes
// the ray runs parallel to, +0 and -0 and too-small-to-invert direction components, negative
// directions, planes exactly at the grown origin, boxes far from the origin); and no box culled
// that holds a point of the ray within [tmin, tmax], checked in double arithmetic.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "trace/scene/top_level_wide.hpp"

using namespace spacebvh;
using namespace spacebvh::scene;

namespace {

struct Entered {
    unsigned slots = 0;
    float key[kTopWidth] = {};
};

// The children WideTopQuery::enter enters (node 0 of `nodes`, whose children are all leaves k).
Entered wide_enter(const std::vector<TopNode>& nodes, const BoxRay& ray, float bound) {
    const WideTopQuery query(nodes, ray);
    WideTopQuery::Entry node = query.root(), out[kTopWidth];
    const int n = query.enter(node, bound, out);
    Entered e;
    for (int k = 0; k < n; ++k) {
        const WideTopQuery::Entry& child = k == 0 ? node : out[k - 1];
        const uint32_t slot = child.ref & ~kItemBit;
        EXPECT_EQ(e.slots & (1u << slot), 0u) << "slot " << slot << " entered twice";
        e.slots |= 1u << slot;
        e.key[slot] = child.key;
    }
    return e;
}

AABB box_of(const TopNode& n, int slot) {
    AABB b;
    for (int i = 0; i < 3; ++i) b.lo[i] = n.lo[i][slot], b.hi[i] = n.hi[i][slot];
    return b;
}

void set_box(TopNode& n, int slot, const AABB& b) {
    for (int i = 0; i < 3; ++i) n.lo[i][slot] = b.lo[i], n.hi[i][slot] = b.hi[i];
    n.child[slot] = kItemBit | uint32_t(slot);
    n.valid |= 1u << slot;
}

// The wide test and meets agree on every valid child; returns the slots entered.
unsigned expect_same_as_meets(const std::vector<TopNode>& nodes, const BoxRay& ray, float bound, const char* what) {
    const Entered wide = wide_enter(nodes, ray, bound);
    for (int slot = 0; slot < kTopWidth; ++slot) {
        if (!(nodes[0].valid & (1u << slot))) {
            EXPECT_EQ(wide.slots & (1u << slot), 0u) << what << ": unused slot " << slot << " entered";
            continue;
        }
        float entry = 0.0f;
        const bool met = meets(ray, box_of(nodes[0], slot), bound, entry);
        EXPECT_EQ(met, (wide.slots >> slot) & 1u) << what << ": slot " << slot;
        if (met && ((wide.slots >> slot) & 1u)) {
            EXPECT_EQ(std::signbit(entry), std::signbit(wide.key[slot])) << what << ": slot " << slot;
            EXPECT_EQ(entry, wide.key[slot]) << what << ": slot " << slot;
        }
    }
    return wide.slots;
}

float pick_direction(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    switch (rng() % 8) {
        case 0:
            return 0.0f;
        case 1:
            return -0.0f;
        case 2:
            return (rng() % 2 ? 1.0f : -1.0f) * 1e-39f;  // subnormal: its inverse overflows
        default:
            return u(rng);
    }
}

TEST(TopLevelWide, EntersWhatMeetsEntersWithTheSameKeys) {
    std::mt19937 rng(47);
    std::uniform_real_distribution<float> coord(-10.0f, 10.0f), size(0.0f, 4.0f), unit(0.0f, 1.0f);
    for (int trial = 0; trial < 20000; ++trial) {
        const float far = trial % 3 == 0 ? 1e6f : 1.0f;  // boxes and origins far from the origin too
        Ray ray;
        ray.org = Vec3(coord(rng), coord(rng), coord(rng)) * far;
        ray.dir = Vec3(pick_direction(rng), pick_direction(rng), pick_direction(rng));
        if (ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) ray.dir.z = 1.0f;
        ray.tmin = trial % 2 ? 0.0f : unit(rng);
        ray.tmax = kInfinity;
        const Padding padding{trial % 4 == 0 ? 0.0 : 1e-3 * unit(rng), trial % 5 == 0 ? 0.0 : 1e-6 * unit(rng)};
        const BoxRay box_ray(ray, padding, 20.0 * far);
        std::vector<TopNode> nodes(1);
        const int used = 1 + int(rng() % kTopWidth);
        for (int slot = 0; slot < used; ++slot) {
            AABB b;
            for (int i = 0; i < 3; ++i) {
                b.lo[i] = coord(rng) * far;
                b.hi[i] = b.lo[i] + size(rng) * far;
                // Planes exactly at the grown origin: the parallel test's boundary (0 * inf = NaN).
                if (rng() % 6 == 0) b.lo[i] = box_ray.lo_org[i];
                if (rng() % 6 == 0) b.hi[i] = box_ray.hi_org[i];
                if (b.lo[i] > b.hi[i]) std::swap(b.lo[i], b.hi[i]);
                if (!std::isfinite(b.lo[i]) || !std::isfinite(b.hi[i])) b.lo[i] = b.hi[i] = ray.org[i];
            }
            set_box(nodes[0], slot, b);
        }
        const float bound = trial % 2 ? kInfinity : 30.0f * far * unit(rng);
        expect_same_as_meets(nodes, box_ray, bound, "random");
        if (HasFailure()) return;
    }
}

// A box built around a point of the ray at t in [tmin, bound] (computed in double, then the box's
// float planes rounded outward past it) is entered, at an entry distance no larger than t.
TEST(TopLevelWide, NeverCullsABoxThatHoldsAPointOfTheRay) {
    std::mt19937 rng(4711);
    std::uniform_real_distribution<float> coord(-100.0f, 100.0f), unit(0.0f, 1.0f);
    int entered = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        Ray ray;
        ray.org = Vec3(coord(rng), coord(rng), coord(rng));
        ray.dir = Vec3(pick_direction(rng), pick_direction(rng), pick_direction(rng));
        if (ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) ray.dir.x = -1.0f;
        ray.tmin = 0.0f;
        const BoxRay box_ray(ray, Padding{}, 400.0);
        std::vector<TopNode> nodes(1);
        const float t = 50.0f * unit(rng);
        for (int slot = 0; slot < kTopWidth; ++slot) {
            AABB b;
            for (int i = 0; i < 3; ++i) {
                const double p = double(ray.org[i]) + double(t) * double(ray.dir[i]);
                const float extra = slot == 0 ? 0.0f : unit(rng) * float(slot);
                b.lo[i] = std::nextafter(float(p) - extra, -kInfinity);
                b.hi[i] = std::nextafter(float(p) + extra * unit(rng), kInfinity);
            }
            set_box(nodes[0], slot, b);
        }
        const float bound = std::nextafter(t, kInfinity) * (1.0f + unit(rng));
        const Entered wide = wide_enter(nodes, box_ray, bound);
        ASSERT_EQ(wide.slots, (1u << kTopWidth) - 1) << "trial " << trial << ": a box holding the ray's point culled";
        for (int slot = 0; slot < kTopWidth; ++slot) EXPECT_LE(wide.key[slot], t) << "trial " << trial;
        entered += __builtin_popcount(wide.slots);
    }
    EXPECT_EQ(entered, 20000 * kTopWidth);
}

// A test that can fail: boxes off the ray's line are culled (parallel axes included).
TEST(TopLevelWide, CullsBoxesOffTheRay) {
    Ray ray;
    ray.org = Vec3(0.0f, 0.0f, 0.0f);
    ray.dir = Vec3(1.0f, 0.0f, -0.0f);
    const BoxRay box_ray(ray, Padding{}, 10.0);
    std::vector<TopNode> nodes(1);
    set_box(nodes[0], 0, AABB{Vec3(2.0f, -1.0f, -1.0f), Vec3(3.0f, 1.0f, 1.0f)});    // ahead: entered at 2
    set_box(nodes[0], 1, AABB{Vec3(2.0f, 0.5f, -1.0f), Vec3(3.0f, 1.0f, 1.0f)});     // beside (y): culled
    set_box(nodes[0], 2, AABB{Vec3(2.0f, -1.0f, -3.0f), Vec3(3.0f, 1.0f, -0.5f)});   // beside (z, -0): culled
    set_box(nodes[0], 3, AABB{Vec3(-3.0f, -1.0f, -1.0f), Vec3(-2.0f, 1.0f, 1.0f)});  // behind: culled
    set_box(nodes[0], 4, AABB{Vec3(20.0f, -1.0f, -1.0f), Vec3(30.0f, 1.0f, 1.0f)});  // past the bound: culled
    const unsigned slots = expect_same_as_meets(nodes, box_ray, 10.0f, "off the ray");
    EXPECT_EQ(slots, 1u);
    const float key = wide_enter(nodes, box_ray, 10.0f).key[0];
    EXPECT_LE(key, 2.0f);
    EXPECT_GT(key, 1.999f);
}

}  // namespace
