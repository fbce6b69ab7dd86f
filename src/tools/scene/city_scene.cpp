// SPDX-License-Identifier: MIT
// builtin:city:N, a procedural city of about N triangles for building at scale: a grid of blocks of
// four lots each, holding plain boxes, stepped towers and buildings whose walls are grids of small
// facade cells, over a ground and streets made of a few huge triangles (whose boxes span the city, so
// spatial splits matter). Deterministic: each building's shape comes from a splitmix64 stream seeded
// by its index, and N fixes the block grid and the facade detail. Linear work: one planning pass
// (about 32 bytes per building, hundreds of triangles each), one exact allocation of the triangles,
// then the buildings written in parallel, each into its own range.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <charconv>
#include <cmath>

#include "spacebvh/tools/rays.hpp"
#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools::scene_detail {
namespace {

constexpr float kBlockSide = 100.0f;  // a block: 2 x 2 lots of 50 x 50
constexpr float kStreetWidth = 20.0f;
constexpr float kPitch = kBlockSide + kStreetWidth;
constexpr float kLotSide = 0.5f * kBlockSide;
constexpr uint64_t kTrianglesPerBuilding = 400;  // sets the block grid from N
constexpr uint64_t kSeed = 0xC17F5EEDull;

enum class Kind : uint8_t { box, tower, facade };

struct BuildingPlan {
    float x0, z0, x1, z1, height;
    Kind kind;
    uint8_t tiers;     // tower: stacked boxes, each narrower than the one below
    uint32_t columns;  // facade: cells per wall across
    uint32_t rows;     // facade: cells per wall up
    uint64_t triangles() const {
        switch (kind) {
            case Kind::box:
                return 10;  // four walls and a roof (no floor)
            case Kind::tower:
                return 10 * uint64_t(tiers);
            case Kind::facade:
                return 2 + 8 * uint64_t(columns) * rows;
        }
        return 0;
    }
};

class TriangleWriter {
public:
    explicit TriangleWriter(Triangle* out) : out_(out) {}
    void triangle(Vec3 a, Vec3 b, Vec3 c) { *out_++ = {a, b, c}; }
    void quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
        triangle(a, b, c);
        triangle(a, c, d);
    }
    // origin + s*u + t*v on an nu x nv grid. Shared corners come from the same expression, so
    // neighbouring cells meet without cracks.
    void grid(Vec3 origin, Vec3 u, Vec3 v, uint32_t nu, uint32_t nv) {
        auto at = [&](uint32_t i, uint32_t j) {
            return origin + u * (float(i) / float(nu)) + v * (float(j) / float(nv));
        };
        for (uint32_t j = 0; j < nv; ++j)
            for (uint32_t i = 0; i < nu; ++i) quad(at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
    }
    // The four walls of [x0,x1] x [y0,y1] x [z0,z1], each an nu x nv grid, counter-clockwise seen from outside.
    void walls(float x0, float z0, float x1, float z1, float y0, float y1, uint32_t nu, uint32_t nv) {
        const Vec3 corners[4] = {{x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1}};
        const Vec3 up{0.0f, y1 - y0, 0.0f};
        for (int k = 0; k < 4; ++k) grid(corners[k], corners[(k + 1) % 4] - corners[k], up, nu, nv);
    }
    void roof(float x0, float z0, float x1, float z1, float y) {
        quad({x0, y, z0}, {x0, y, z1}, {x1, y, z1}, {x1, y, z0});
    }
    Triangle* position() const { return out_; }

private:
    Triangle* out_;
};

// The city's extent along x and z: G blocks and G + 1 streets.
float city_side(uint32_t blocks) { return float(blocks) * kPitch + kStreetWidth; }

// The corner of the city at the lowest x and z: the city is centred on the origin.
float city_origin(uint32_t blocks) { return -std::floor(0.5f * city_side(blocks)); }

// Shape of building `index` on its lot (facade detail is set later, from the triangle budget).
BuildingPlan plan_building(uint64_t index, uint32_t blocks) {
    const float origin = city_origin(blocks);
    SplitMix64 random(kSeed ^ (index * 0x9E3779B97F4A7C15ull));
    const uint64_t block = index / 4, lot = index % 4;
    const float lot_x = origin + kStreetWidth + float(block % blocks) * kPitch + float(lot % 2) * kLotSide;
    const float lot_z = origin + kStreetWidth + float(block / blocks) * kPitch + float(lot / 2) * kLotSide;
    BuildingPlan plan{};
    const float width = 25.0f + 20.0f * random.uniform(), depth = 25.0f + 20.0f * random.uniform();
    plan.x0 = lot_x + (kLotSide - width) * random.uniform();
    plan.z0 = lot_z + (kLotSide - depth) * random.uniform();
    plan.x1 = plan.x0 + width;
    plan.z1 = plan.z0 + depth;
    const float pick = random.uniform(), tall = random.uniform();
    if (pick < 0.5f) {
        plan.kind = Kind::box;
        plan.height = 6.0f + 30.0f * tall;
    } else if (pick < 0.75f) {
        plan.kind = Kind::tower;
        plan.tiers = uint8_t(2 + random.next() % 3);
        plan.height = 40.0f + 200.0f * tall * tall * tall;  // a few skyscrapers
    } else {
        plan.kind = Kind::facade;
        plan.height = 15.0f + 100.0f * tall * tall;
    }
    return plan;
}

// Shares `budget` facade triangles among the facade buildings by wall area, cells about as wide as
// a storey is high. The rounding error is carried to the next building, so the total misses the
// budget by at most about one building's rounding.
void plan_facades(std::vector<BuildingPlan>& plans, double budget) {
    double total_area = 0;
    for (const BuildingPlan& plan : plans)
        if (plan.kind == Kind::facade)
            total_area += double(plan.height) * double((plan.x1 - plan.x0) + (plan.z1 - plan.z0));
    double carry = 0;
    for (BuildingPlan& plan : plans) {
        if (plan.kind != Kind::facade) continue;
        const double perimeter_half = double((plan.x1 - plan.x0) + (plan.z1 - plan.z0));
        const double share = budget * double(plan.height) * perimeter_half / total_area + carry;
        const double cells = std::max(1.0, (share - 2.0) / 8.0);  // per wall
        const double mean_wall = 0.5 * perimeter_half;
        plan.rows = uint32_t(std::clamp(std::round(std::sqrt(cells * double(plan.height) / mean_wall)), 1.0, 1e5));
        plan.columns = uint32_t(std::clamp(std::round(cells / plan.rows), 1.0, 1e5));
        carry = share - double(plan.triangles());
    }
}

void write_building(const BuildingPlan& plan, TriangleWriter& out) {
    switch (plan.kind) {
        case Kind::box:
            out.walls(plan.x0, plan.z0, plan.x1, plan.z1, 0.0f, plan.height, 1, 1);
            out.roof(plan.x0, plan.z0, plan.x1, plan.z1, plan.height);
            break;
        case Kind::tower: {
            float x0 = plan.x0, z0 = plan.z0, x1 = plan.x1, z1 = plan.z1, y0 = 0.0f;
            float tier_height = plan.height / float(plan.tiers);
            for (uint8_t tier = 0; tier < plan.tiers; ++tier) {
                const float y1 = tier + 1 == plan.tiers ? plan.height : y0 + tier_height;
                out.walls(x0, z0, x1, z1, y0, y1, 1, 1);
                out.roof(x0, z0, x1, z1, y1);
                // Setback: each tier 15% narrower on every side.
                const float inset_x = 0.15f * (x1 - x0), inset_z = 0.15f * (z1 - z0);
                x0 += inset_x, x1 -= inset_x, z0 += inset_z, z1 -= inset_z;
                y0 = y1;
            }
            break;
        }
        case Kind::facade:
            out.walls(plan.x0, plan.z0, plan.x1, plan.z1, 0.0f, plan.height, plan.columns, plan.rows);
            out.roof(plan.x0, plan.z0, plan.x1, plan.z1, plan.height);
            break;
    }
}

// Blocks per side: about kTrianglesPerBuilding triangles per building, four buildings per block.
uint32_t block_count(uint64_t target_triangles) {
    return uint32_t(std::max(1.0, std::round(std::sqrt(double(target_triangles) / (4.0 * kTrianglesPerBuilding)))));
}

}  // namespace

// An aerial view from above one corner, looking at the centre: every block in sight.
Camera city_camera(uint64_t target_triangles) {
    const float side = city_side(block_count(target_triangles));
    Camera camera;
    camera.eye = {-0.6f * side, 0.45f * side, -0.75f * side};
    camera.target = {0.0f, 0.0f, 0.0f};
    camera.up = {0.0f, 1.0f, 0.0f};
    camera.fovy_degrees = 60.0f;
    return camera;
}

uint64_t parse_city_size(const std::string& text) {
    const std::string what = "builtin:city:" + text;
    double value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || !(value == std::floor(value)))
        throw Error("'" + what + "': the size must be a whole number of triangles (e.g. city:100000 or city:1e7)");
    if (value < double(kMinCityTriangles) || value > double(kMaxCityTriangles))
        throw Error("'" + what + "': the size must be in [" + std::to_string(kMinCityTriangles) + ", " +
                    std::to_string(kMaxCityTriangles) + "]");
    return uint64_t(value);
}

std::vector<Triangle> make_city(uint64_t target_triangles) {
    const uint32_t blocks = block_count(target_triangles);
    const uint64_t building_count = 4 * uint64_t(blocks) * blocks;
    std::vector<BuildingPlan> plans(building_count);
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, building_count, 4096), [&](const auto& range) {
        for (uint64_t i = range.begin(); i != range.end(); ++i) plans[i] = plan_building(i, blocks);
    });
    const uint64_t ground_triangles = 2 + 4 * (uint64_t(blocks) + 1);
    uint64_t fixed = ground_triangles;
    for (BuildingPlan& plan : plans) {
        if (plan.kind == Kind::facade) plan.rows = plan.columns = 0;
        fixed += plan.kind == Kind::facade ? 2 : plan.triangles();
    }
    plan_facades(plans, std::max(0.0, double(target_triangles) - double(fixed)));
    std::vector<uint64_t> first(building_count + 1, ground_triangles);
    for (uint64_t i = 0; i < building_count; ++i) first[i + 1] = first[i] + plans[i].triangles();
    std::vector<Triangle> triangles(first.back());

    // Ground: one huge square twice the city's side; streets: one long strip per street and direction,
    // a little above the ground (x streets at 0.05, z streets at 0.1) so that no two are coplanar.
    TriangleWriter ground(triangles.data());
    const float lo = city_origin(blocks), hi = lo + city_side(blocks), margin = 0.5f * city_side(blocks);
    ground.quad({lo - margin, 0.0f, lo - margin}, {lo - margin, 0.0f, hi + margin}, {hi + margin, 0.0f, hi + margin},
                {hi + margin, 0.0f, lo - margin});
    for (uint32_t street = 0; street <= blocks; ++street) {
        const float near = lo + float(street) * kPitch, far = near + kStreetWidth;
        ground.quad({lo, 0.05f, near}, {lo, 0.05f, far}, {hi, 0.05f, far}, {hi, 0.05f, near});
        ground.quad({near, 0.1f, lo}, {near, 0.1f, hi}, {far, 0.1f, hi}, {far, 0.1f, lo});
    }
    if (ground.position() != triangles.data() + ground_triangles) throw Error("internal: city ground count");
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, building_count, 256), [&](const auto& range) {
        for (uint64_t i = range.begin(); i != range.end(); ++i) {
            TriangleWriter out(triangles.data() + first[i]);
            write_building(plans[i], out);
            if (out.position() != triangles.data() + first[i + 1]) throw Error("internal: city building count");
        }
    });
    return triangles;
}

}  // namespace spacebvh::tools::scene_detail
