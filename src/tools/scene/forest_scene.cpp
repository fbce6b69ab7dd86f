// SPDX-License-Identifier: MIT
// builtin:forest:N: N placements of four generated meshes (a conifer, a broadleaf tree, a rock and a
// fern, 2.9k to 27k triangles each, about 14.1k per placement on average, so 10^6 placements are
// 1.41 x 10^10 instanced triangles) on a jittered grid over gentle hills. Each placement turns about
// the vertical, tilts a few degrees, scales non-uniformly, and one in four is mirrored. Deterministic:
// placement i depends on i and on the grid's side only (splitmix64, no std distributions, no clocks).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>

#include "spacebvh/tools/rays.hpp"
#include "tools/scene/instanced_internal.hpp"

namespace spacebvh::tools::scene_detail {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kSpacing = 3.0;  // grid cell side, world units

// Doubles from splitmix64 (tools::SplitMix64, docs/rays.md): 53 bits, [0, 1).
struct Random {
    SplitMix64 bits;
    double uniform() { return double(bits.next() >> 11) * 0x1.0p-53; }
    double between(double lo, double hi) { return lo + (hi - lo) * uniform(); }
};

// A closed surface of revolution about +y: `rings` rings of `segments` vertices at heights
// height(r) and radii radius(r, s), closed by a fan to the axis at both ends. Each vertex is a
// function of its integer (ring, segment) only (segment taken modulo `segments`), so shared edges
// have bit-identical ends and the mesh is watertight.
template <typename Height, typename Radius>
void revolve(std::vector<Triangle>& out, int rings, int segments, const Height& height, const Radius& radius) {
    auto vertex = [&](int r, int s) {
        s %= segments;
        const double angle = 2.0 * kPi * s / segments;
        const double rr = radius(r, s);
        return Vec3(float(rr * std::cos(angle)), float(height(r)), float(rr * std::sin(angle)));
    };
    const Vec3 bottom(0.0f, float(height(0)), 0.0f), top(0.0f, float(height(rings - 1)), 0.0f);
    for (int s = 0; s < segments; ++s) {
        out.push_back({bottom, vertex(0, s + 1), vertex(0, s)});
        for (int r = 0; r + 1 < rings; ++r) {
            const Vec3 a = vertex(r, s), b = vertex(r, s + 1), c = vertex(r + 1, s + 1), d = vertex(r + 1, s);
            out.push_back({a, c, b});
            out.push_back({a, d, c});
        }
        out.push_back({top, vertex(rings - 1, s), vertex(rings - 1, s + 1)});
    }
}

double wobble(int r, int s, double amount) {
    return amount * std::sin(0.7 * r + 1.3 * s) * std::cos(0.31 * r - 0.9 * s);
}

void trunk(std::vector<Triangle>& out, double radius, double height) {
    revolve(
        out, 12, 24, [&](int r) { return height * r / 11.0; },
        [&](int r, int s) { return radius * (1.0 - 0.3 * r / 11.0) * (1.0 + wobble(r, s, 0.05)); });
}

// A trunk under a crown of five drooping tiers: 15,936 triangles.
std::vector<Triangle> conifer() {
    std::vector<Triangle> t;
    trunk(t, 0.12, 1.0);
    constexpr int rings = 120, segments = 64;
    revolve(
        t, rings, segments, [](int r) { return 0.6 + 3.4 * r / (rings - 1.0); },
        [](int r, int s) {
            const double along = double(r) / (rings - 1);
            const double tier = std::fmod(along * 5.0, 1.0);  // each tier widens downwards
            return (1.0 - along) * (0.35 + 0.65 * tier) * 1.1 * (1.0 + wobble(r, s, 0.08));
        });
    return t;
}

// A trunk under a lumpy, roughly spherical crown: 26,976 triangles.
std::vector<Triangle> broadleaf() {
    std::vector<Triangle> t;
    trunk(t, 0.18, 1.8);
    constexpr int rings = 110, segments = 120;
    revolve(
        t, rings, segments, [](int r) { return 1.5 + 2.6 * (1.0 - std::cos(kPi * r / (rings - 1.0))) / 2.0; },
        [](int r, int s) {
            const double polar = kPi * r / (rings - 1.0);
            const double lumps = 1.0 + 0.12 * std::sin(5.0 * polar) * std::cos(7.0 * 2.0 * kPi * s / segments);
            return 1.6 * std::sin(polar) * lumps * (1.0 + wobble(r, s, 0.03));
        });
    return t;
}

// A flattened, irregular boulder: 6,144 triangles.
std::vector<Triangle> rock() {
    std::vector<Triangle> t;
    constexpr int rings = 48, segments = 64;
    revolve(
        t, rings, segments, [](int r) { return 0.5 * (1.0 - std::cos(kPi * r / (rings - 1.0))) / 2.0 * 1.2; },
        [](int r, int s) {
            const double polar = kPi * r / (rings - 1.0);
            const double angle = 2.0 * kPi * s / segments;
            return 0.9 * std::sin(polar) * (1.0 + 0.25 * std::sin(3.0 * angle + 1.0) * std::sin(2.0 * polar)) *
                   (1.0 + wobble(r, s, 0.06));
        });
    return t;
}

// Blades: thin bent strips fanned around the axis, open (two-sided) triangles: 2,880 triangles.
std::vector<Triangle> fern() {
    std::vector<Triangle> t;
    constexpr int blades = 40, pieces = 36;
    for (int b = 0; b < blades; ++b) {
        const double angle = 2.0 * kPi * b / blades + 0.3 * std::sin(b * 1.7);
        const double lean = 0.35 + 0.25 * std::sin(b * 2.3), length = 0.9 + 0.4 * std::cos(b * 0.9);
        const double c = std::cos(angle), s = std::sin(angle);
        auto point = [&](int i, double side) {
            const double along = length * i / pieces, width = 0.06 * std::sin(kPi * i / pieces);
            const double out = along * lean + 0.25 * along * along, up = along * (1.0 - 0.5 * along);
            return Vec3(float(out * c - side * width * s), float(up), float(out * s + side * width * c));
        };
        for (int i = 0; i < pieces; ++i) {
            const Vec3 a = point(i, -1), b2 = point(i, 1), c2 = point(i + 1, 1), d = point(i + 1, -1);
            t.push_back({a, b2, c2});
            t.push_back({a, c2, d});
        }
    }
    return t;
}

struct Kind {
    const char* name;
    std::vector<Triangle> (*make)();
    double share;  // of the placements
    double size_lo, size_hi;
};
constexpr Kind kKinds[] = {
    {"forest-conifer", conifer, 0.35, 0.6, 1.6},
    {"forest-broadleaf", broadleaf, 0.25, 0.6, 1.4},
    {"forest-rock", rock, 0.20, 0.4, 1.5},
    {"forest-fern", fern, 0.20, 0.5, 1.2},
};

double ground_height(double x, double z) { return 2.0 * std::sin(x * 0.05) * std::cos(z * 0.04); }

// T(position) * Ry(yaw) * Rx(tilt x) * Rz(tilt z) * S(sx, sy, sz), composed in double.
Affine64 placement_transform(Random& random, double x, double z, const Kind& kind) {
    const double yaw = random.between(0.0, 2.0 * kPi);
    const double tilt_x = random.between(-0.14, 0.14), tilt_z = random.between(-0.14, 0.14);
    const double size = random.between(kind.size_lo, kind.size_hi);
    double sx = size * random.between(0.8, 1.25), sy = size * random.between(0.8, 1.25);
    const double sz = size * random.between(0.8, 1.25);
    if (random.uniform() < 0.25) sx = -sx;  // mirrored
    if (kind.make == rock) sy *= 0.7;
    Affine64 yaw_m, tilt_xm, tilt_zm, scale, move;
    yaw_m.m = {std::cos(yaw), 0, std::sin(yaw), 0, 0, 1, 0, 0, -std::sin(yaw), 0, std::cos(yaw), 0};
    tilt_xm.m = {1, 0, 0, 0, 0, std::cos(tilt_x), -std::sin(tilt_x), 0, 0, std::sin(tilt_x), std::cos(tilt_x), 0};
    tilt_zm.m = {std::cos(tilt_z), -std::sin(tilt_z), 0, 0, std::sin(tilt_z), std::cos(tilt_z), 0, 0, 0, 0, 1, 0};
    scale.m = {sx, 0, 0, 0, 0, sy, 0, 0, 0, 0, sz, 0};
    move.m = {1, 0, 0, x, 0, 1, 0, ground_height(x, z) - 0.1 * size, 0, 0, 1, z};
    return move * yaw_m * tilt_xm * tilt_zm * scale;
}

}  // namespace

uint64_t parse_forest_size(std::string_view text) {
    uint64_t n = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || n < 1 || n > kMaxForestInstances)
        throw Error("builtin:forest:N: N must be a whole number of instances from 1 to " +
                    std::to_string(kMaxForestInstances) + ", got '" + quote_token(text) + "'");
    return n;
}

InstancedScene make_forest(uint64_t instances) {
    if (instances < 1 || instances > kMaxForestInstances)
        throw Error("builtin:forest:N: N = " + std::to_string(instances) + " is not in [1, " +
                    std::to_string(kMaxForestInstances) + "]");
    InstancedScene scene;
    scene.name = "forest:" + std::to_string(instances);
    for (const Kind& kind : kKinds) {
        Scene mesh;
        mesh.name = kind.name;
        mesh.triangles = kind.make();
        mesh.degenerate_count = count_degenerate(mesh.triangles);
        scene.meshes.push_back(std::move(mesh));
    }
    const auto side = static_cast<uint64_t>(std::ceil(std::sqrt(double(instances))));
    scene.instances.resize(instances);
    for (uint64_t i = 0; i < instances; ++i) {
        Random random{SplitMix64(0x5EED'F0E5'7000'0000ull ^ (i * 0x9E3779B97F4A7C15ull))};
        double pick = random.uniform();
        uint32_t kind = 0;
        while (kind + 1 < std::size(kKinds) && pick >= kKinds[kind].share) pick -= kKinds[kind++].share;
        const double x = (double(i % side) + random.between(0.15, 0.85)) * kSpacing;
        const double z = (double(i / side) + random.between(0.15, 0.85)) * kSpacing;
        SceneInstance& instance = scene.instances[i];
        instance.mesh = kind;
        instance.transform = placement_transform(random, x, z, kKinds[kind]).rounded();
        instance.mask = 1u << kind;
    }
    return scene;
}

}  // namespace spacebvh::tools::scene_detail
