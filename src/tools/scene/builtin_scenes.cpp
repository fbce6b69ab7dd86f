// SPDX-License-Identifier: MIT
// Procedural scenes, generated without files and deterministic (no std distributions, no clocks):
//   interior          an architectural hall: floor, walls and gabled roof split into long thin strips,
//                     columns, arches and slanted roof beams (the case where object partitioning does badly)
//   interior-rotated  the same rotated x:45,y:45,z:45 (the "rotated Sponza" stress case)
//   organic           a closed, displaced cube-sphere (dense, smooth, uniform triangles)
//   soup              large overlapping random triangles
//   city:N            about N triangles of city blocks over huge ground triangles (city_scene.cpp)
//   forest:N          builtin:forest:N's placements flattened into one mesh (an instanced scene first,
//                     forest_scene.cpp and tools::load_instanced_scene)
#include <numbers>

#include "spacebvh/tools/instanced_scene.hpp"

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
const SceneTransform kInteriorRotation{Vec3(45.0f, 45.0f, 45.0f), 1.0f, Vec3(0.0f)};
constexpr std::string_view kCityPrefix = "city:";

// splitmix64 (Steele, Lea & Flood 2014), as in docs/rays.md.
struct SplitMix64 {
    uint64_t state;
    uint64_t next() {
        uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    float uniform() { return static_cast<float>(next() >> 40) * 0x1.0p-24f; }  // [0,1), exact
};

class MeshBuilder {
public:
    std::vector<Triangle> triangles;

    void triangle(Vec3 a, Vec3 b, Vec3 c) { triangles.push_back({a, b, c}); }
    void quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
        triangle(a, b, c);
        triangle(a, c, d);
    }
    // The parallelogram origin + s*along + t*across split into `count` strips of full `along` length:
    // long thin triangles when |along| >> |across| / count.
    void strips(Vec3 origin, Vec3 along, Vec3 across, int count) {
        for (int i = 0; i < count; ++i) {
            Vec3 a = origin + across * (static_cast<float>(i) / count);
            Vec3 d = origin + across * (static_cast<float>(i + 1) / count);
            quad(a, a + along, d + along, d);
        }
    }
    // A grid of small squares (the opposite of strips).
    void grid(Vec3 origin, Vec3 u, Vec3 v, int nu, int nv) {
        for (int i = 0; i < nu; ++i)
            for (int j = 0; j < nv; ++j) {
                Vec3 a = origin + u * (static_cast<float>(i) / nu) + v * (static_cast<float>(j) / nv);
                Vec3 b = origin + u * (static_cast<float>(i + 1) / nu) + v * (static_cast<float>(j) / nv);
                Vec3 c = origin + u * (static_cast<float>(i + 1) / nu) + v * (static_cast<float>(j + 1) / nv);
                Vec3 d = origin + u * (static_cast<float>(i) / nu) + v * (static_cast<float>(j + 1) / nv);
                quad(a, b, c, d);
            }
    }
    // Box with corners c[0..7] (bit 0 = x, bit 1 = y, bit 2 = z side): 12 triangles.
    void box(const std::array<Vec3, 8>& c) {
        quad(c[0], c[2], c[3], c[1]);  // z-
        quad(c[4], c[5], c[7], c[6]);  // z+
        quad(c[0], c[1], c[5], c[4]);  // y-
        quad(c[2], c[6], c[7], c[3]);  // y+
        quad(c[0], c[4], c[6], c[2]);  // x-
        quad(c[1], c[3], c[7], c[5]);  // x+
    }
    void axis_box(Vec3 lo, Vec3 hi) {
        std::array<Vec3, 8> c;
        for (int i = 0; i < 8; ++i) c[i] = {(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z};
        box(c);
    }
    // A square beam of side `width` from `from` to `to`, in any direction.
    void beam(Vec3 from, Vec3 to, float width) {
        Vec3 axis = normalize(to - from);
        Vec3 helper = std::fabs(axis.y) < 0.9f ? Vec3(0, 1, 0) : Vec3(1, 0, 0);
        Vec3 side = normalize(cross(axis, helper)) * (0.5f * width);
        Vec3 up = normalize(cross(side, axis)) * (0.5f * width);
        std::array<Vec3, 8> c;
        for (int i = 0; i < 8; ++i)
            c[i] = ((i & 4) ? to : from) + side * ((i & 1) ? 1.0f : -1.0f) + up * ((i & 2) ? 1.0f : -1.0f);
        box(c);
    }
    // Open vertical cylinder (standing on the floor, its top hidden by an arch or capital).
    void cylinder(Vec3 base, float radius, float height, int segments, int rings) {
        for (int r = 0; r < rings; ++r) {
            float y0 = base.y + height * static_cast<float>(r) / rings;
            float y1 = base.y + height * static_cast<float>(r + 1) / rings;
            for (int s = 0; s < segments; ++s) {
                float a0 = 2 * kPi * static_cast<float>(s) / segments;
                float a1 = 2 * kPi * static_cast<float>(s + 1) / segments;
                Vec3 p0{base.x + radius * std::cos(a0), y0, base.z + radius * std::sin(a0)};
                Vec3 p1{base.x + radius * std::cos(a1), y0, base.z + radius * std::sin(a1)};
                quad(p0, p1, {p1.x, y1, p1.z}, {p0.x, y1, p0.z});
            }
        }
    }
    // Semicircular arch in the x-y plane (centre `center`, springing at center.y), rectangular section.
    void arch(Vec3 center, float radius, float thickness, float depth, int segments) {
        auto point = [&](int s, float r, float dz) {
            float angle = kPi * static_cast<float>(s) / segments;
            return Vec3{center.x - r * std::cos(angle), center.y + r * std::sin(angle), center.z + dz};
        };
        const float ri = radius - 0.5f * thickness, ro = radius + 0.5f * thickness, h = 0.5f * depth;
        for (int s = 0; s < segments; ++s) {
            quad(point(s, ri, -h), point(s + 1, ri, -h), point(s + 1, ri, h), point(s, ri, h));    // intrados
            quad(point(s, ro, -h), point(s, ro, h), point(s + 1, ro, h), point(s + 1, ro, -h));    // extrados
            quad(point(s, ri, -h), point(s, ro, -h), point(s + 1, ro, -h), point(s + 1, ri, -h));  // front
            quad(point(s, ri, h), point(s + 1, ri, h), point(s + 1, ro, h), point(s, ro, h));      // back
        }
    }
};

// Hall 40 x 16, walls 10 high, gabled roof to 14; two rows of 13 columns carrying arches; trusses.
std::vector<Triangle> make_interior() {
    MeshBuilder mesh;
    const float x0 = -20, x1 = 20, z0 = -8, z1 = 8, wall = 10, ridge = 14;
    // Floor, long walls and the two roof slopes: strips spanning the whole 40-unit length.
    mesh.strips({x0, 0, z0}, {x1 - x0, 0, 0}, {0, 0, z1 - z0}, 160);
    mesh.strips({x0, 0, z0}, {x1 - x0, 0, 0}, {0, wall, 0}, 100);
    mesh.strips({x0, 0, z1}, {x1 - x0, 0, 0}, {0, wall, 0}, 100);
    mesh.strips({x0, wall, z0}, {x1 - x0, 0, 0}, {0, ridge - wall, -z0}, 160);  // slanted
    mesh.strips({x0, wall, z1}, {x1 - x0, 0, 0}, {0, ridge - wall, -z1}, 160);  // slanted
    // End walls (strips along z) with their gables.
    for (float x : {x0, x1}) {
        mesh.strips({x, 0, z0}, {0, 0, z1 - z0}, {0, wall, 0}, 100);
        mesh.triangle({x, wall, z0}, {x, wall, z1}, {x, ridge, 0});
    }
    // Two arcades: columns every 3 units, semicircular arches between them.
    const int columns = 13;
    const float column_height = 7, spacing = 3, first = -18;
    for (float z : {-4.0f, 4.0f}) {
        for (int i = 0; i < columns; ++i) mesh.cylinder({first + spacing * i, 0, z}, 0.35f, column_height, 48, 30);
        for (int i = 0; i + 1 < columns; ++i)
            mesh.arch({first + spacing * (i + 0.5f), column_height, z}, 0.5f * spacing, 0.3f, 0.5f, 24);
    }
    // Roof trusses above each column pair, and slanted braces between them: long, thin, slanted triangles
    // whose bounding boxes are huge compared with their area.
    for (int i = 0; i < columns; ++i) {
        const float x = first + spacing * i;
        mesh.beam({x, wall, z0}, {x, ridge, 0}, 0.25f);
        mesh.beam({x, wall, z1}, {x, ridge, 0}, 0.25f);
        mesh.beam({x, wall, z0}, {x, wall, z1}, 0.25f);
        mesh.beam({x, wall, 0}, {x, ridge, 0}, 0.2f);
        if (i + 1 < columns) {
            const float xn = x + spacing;
            mesh.beam({x, wall, z0}, {xn, ridge, 0}, 0.12f);
            mesh.beam({x, ridge, 0}, {xn, wall, z1}, 0.12f);
            mesh.beam({x, wall, z1}, {xn, wall, 0}, 0.12f);
            mesh.beam({x, wall, 0}, {xn, wall, z0}, 0.12f);
        }
    }
    // Wind braces running the full length diagonally across each roof slope.
    mesh.beam({x0, wall, z0}, {x1, ridge, 0}, 0.15f);
    mesh.beam({x0, ridge, 0}, {x1, wall, z0}, 0.15f);
    mesh.beam({x0, wall, z1}, {x1, ridge, 0}, 0.15f);
    mesh.beam({x0, ridge, 0}, {x1, wall, z1}, 0.15f);
    // Pews (seat and backrest) in the nave and a finely tessellated carpet down the aisle.
    for (int i = 0; i < 14; ++i) {
        const float x = -14.0f + 2.0f * i;
        for (float side : {-1.0f, 1.0f}) {
            const float za = side * 0.6f, zb = side * 3.0f;
            mesh.axis_box({x, 0.45f, std::min(za, zb)}, {x + 0.5f, 0.55f, std::max(za, zb)});
            mesh.axis_box({x + 0.45f, 0.55f, std::min(za, zb)}, {x + 0.55f, 1.1f, std::max(za, zb)});
        }
    }
    mesh.grid({-16, 0.01f, -0.5f}, {32, 0, 0}, {0, 0, 1}, 64, 8);
    // Degenerate triangles are legal input and must be kept and counted: a repeated vertex, a single
    // point (both stay degenerate under any rotation) and three collinear points.
    mesh.triangle({1, 2, 3}, {4, 5, 6}, {4, 5, 6});
    mesh.triangle({-3, 1, 2}, {-3, 1, 2}, {-3, 1, 2});
    mesh.triangle({0, 5, 0}, {1, 5, 0}, {2, 5, 0});
    return std::move(mesh.triangles);
}

// Value noise on the integer lattice (hash per corner, smoothstep-weighted trilinear blend), summed
// over octaves (fractal Brownian motion). Deterministic: integer hashing only.
float lattice_value(int x, int y, int z) {
    SplitMix64 hash{static_cast<uint64_t>(static_cast<uint32_t>(x)) * 0x8DA6B343u ^
                    static_cast<uint64_t>(static_cast<uint32_t>(y)) * 0xD8163841u ^
                    static_cast<uint64_t>(static_cast<uint32_t>(z)) * 0xCB1AB31Fu};
    return 2.0f * hash.uniform() - 1.0f;
}

float value_noise(Vec3 p) {
    const float fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
    const int ix = static_cast<int>(fx), iy = static_cast<int>(fy), iz = static_cast<int>(fz);
    auto smooth = [](float t) { return t * t * (3.0f - 2.0f * t); };
    const float tx = smooth(p.x - fx), ty = smooth(p.y - fy), tz = smooth(p.z - fz);
    auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
    float layer[2];
    for (int dz = 0; dz < 2; ++dz) {
        float row0 = lerp(lattice_value(ix, iy, iz + dz), lattice_value(ix + 1, iy, iz + dz), tx);
        float row1 = lerp(lattice_value(ix, iy + 1, iz + dz), lattice_value(ix + 1, iy + 1, iz + dz), tx);
        layer[dz] = lerp(row0, row1, ty);
    }
    return lerp(layer[0], layer[1], tz);
}

float fractal_noise(Vec3 p) {
    float sum = 0, amplitude = 0.5f;
    for (int octave = 0; octave < 5; ++octave) {
        sum += amplitude * value_noise(p);
        p = p * 2.03f + Vec3(17.1f, -3.7f, 5.3f);
        amplitude *= 0.5f;
    }
    return sum;
}

// Cube-sphere: the six faces of an N x N lattice cube, projected onto the sphere (spherified cube
// mapping) and displaced along the normal. Each lattice point's position is a function of its integer
// coordinates only, so faces sharing an edge produce bit-identical vertices: the mesh is watertight.
std::vector<Triangle> make_organic() {
    constexpr int n = 90;  // 6 * 90 * 90 * 2 = 97,200 triangles
    auto position = [](int i, int j, int k) {
        const float x = 2.0f * static_cast<float>(i) / n - 1.0f;
        const float y = 2.0f * static_cast<float>(j) / n - 1.0f;
        const float z = 2.0f * static_cast<float>(k) / n - 1.0f;
        const float x2 = x * x, y2 = y * y, z2 = z * z;
        const Vec3 dir{x * std::sqrt(1 - y2 / 2 - z2 / 2 + y2 * z2 / 3),
                       y * std::sqrt(1 - z2 / 2 - x2 / 2 + z2 * x2 / 3),
                       z * std::sqrt(1 - x2 / 2 - y2 / 2 + x2 * y2 / 3)};
        const float radius =
            1.0f + 0.35f * fractal_noise(dir * 2.5f) + 0.05f * std::sin(9.0f * dir.x) * std::sin(7.0f * dir.y);
        return dir * (4.0f * radius);
    };
    MeshBuilder mesh;
    for (int axis = 0; axis < 3; ++axis) {
        for (int side : {0, n}) {
            auto lattice = [&](int u, int v) {
                int c[3];
                c[axis] = side;
                c[(axis + 1) % 3] = u;
                c[(axis + 2) % 3] = v;
                return position(c[0], c[1], c[2]);
            };
            for (int u = 0; u < n; ++u)
                for (int v = 0; v < n; ++v) {
                    Vec3 a = lattice(u, v), b = lattice(u + 1, v), c = lattice(u + 1, v + 1), d = lattice(u, v + 1);
                    if (side == n)
                        mesh.quad(a, b, c, d);  // counter-clockwise seen from outside
                    else
                        mesh.quad(a, d, c, b);
                }
        }
    }
    return std::move(mesh.triangles);
}

// 30,000 large random triangles overlapping in a 20^3 box: corners within +-4 of a random centre.
std::vector<Triangle> make_soup() {
    SplitMix64 random{0x5EED50u};
    std::vector<Triangle> triangles(30000);
    for (Triangle& t : triangles) {
        const Vec3 center{20 * random.uniform() - 10, 20 * random.uniform() - 10, 20 * random.uniform() - 10};
        for (int corner = 0; corner < 3; ++corner) {
            const Vec3 offset{8 * random.uniform() - 4, 8 * random.uniform() - 4, 8 * random.uniform() - 4};
            (corner == 0 ? t.v0 : corner == 1 ? t.v1 : t.v2) = center + offset;
        }
    }
    return triangles;
}

}  // namespace

std::vector<std::string> builtin_scene_names() { return {"interior", "interior-rotated", "organic", "soup"}; }

Scene make_builtin_scene(const std::string& name) {
    Scene scene;
    scene.name = name;
    if (name == "interior") {
        scene.triangles = make_interior();
    } else if (name == "interior-rotated") {
        scene.triangles = make_interior();
        const scene_detail::TransformMatrix rotation(kInteriorRotation);
        for (Triangle& t : scene.triangles) t = {rotation.apply(t.v0), rotation.apply(t.v1), rotation.apply(t.v2)};
    } else if (name == "organic") {
        scene.triangles = make_organic();
    } else if (name == "soup") {
        scene.triangles = make_soup();
    } else if (name.starts_with(kCityPrefix)) {
        scene.triangles = scene_detail::make_city(scene_detail::parse_city_size(name.substr(kCityPrefix.size())));
    } else if (name.starts_with("forest")) {
        // As one mesh: every placement's triangles in world space (within flatten_scene's cap).
        scene.triangles = flatten_scene(load_instanced_scene("builtin:" + name)).triangles;
    } else {
        std::string valid;
        for (const std::string& known : builtin_scene_names()) valid += (valid.empty() ? "" : ", ") + known;
        throw Error("unknown builtin scene '" + name + "' (valid: " + valid + ", city:N, forest:N)");
    }
    scene.degenerate_count = scene_detail::count_degenerate(scene.triangles);
    return scene;
}

namespace scene_detail {

// Standing at the west end of the nave, looking east along it, slightly up towards the trusses.
std::optional<Camera> builtin_camera(const std::string& name) {
    Camera interior;
    interior.eye = {-18.5f, 2.5f, 0.0f};
    interior.target = {10.0f, 4.5f, 0.0f};
    interior.up = {0.0f, 1.0f, 0.0f};
    interior.fovy_degrees = 60.0f;
    if (name == "interior") return interior;
    if (name.starts_with(kCityPrefix)) return city_camera(parse_city_size(name.substr(kCityPrefix.size())));
    if (name == "interior-rotated") {
        Camera rotated = interior;
        rotated.eye = kInteriorRotation.apply(interior.eye);
        rotated.target = kInteriorRotation.apply(interior.target);
        rotated.up = kInteriorRotation.apply(interior.up);
        return rotated;
    }
    return std::nullopt;
}

}  // namespace scene_detail
}  // namespace spacebvh::tools
