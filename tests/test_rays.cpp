// SPDX-License-Identifier: MIT
// Ray sets and files of docs/rays.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/verify.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

// An independent transcription of the spec's splitmix64, to check the library's against.
uint64_t reference_splitmix(uint64_t& state) {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

std::string temp_path(const std::string& name) {
    return (std::filesystem::path(testing::TempDir()) / ("spacebvh_rays_" + name)).string();
}

void write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::vector<unsigned char> read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A unit square in the plane y = 0, two triangles sharing the diagonal.
Scene floor_scene() {
    Scene scene;
    scene.name = "floor";
    scene.triangles = {{{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}}, {{-1, 0, -1}, {1, 0, 1}, {-1, 0, 1}}};
    return scene;
}

}  // namespace

TEST(SplitMix64, MatchesTheSpec) {
    SplitMix64 rng(0);
    EXPECT_EQ(rng.next(), 0xE220A8397B1DCDAFull);  // the published first output for seed 0
    for (uint64_t seed : {0ull, 1ull, 42ull, 0xFFFFFFFFFFFFFFFFull}) {
        SplitMix64 lib(seed);
        uint64_t state = seed;
        for (int i = 0; i < 100; ++i) ASSERT_EQ(lib.next(), reference_splitmix(state)) << "seed " << seed;
    }
}

TEST(SplitMix64, UniformIsTheTop24BitsInZeroOne) {
    SplitMix64 lib(7);
    uint64_t state = 7;
    for (int i = 0; i < 10000; ++i) {
        const float u = lib.uniform();
        ASSERT_GE(u, 0.0f);
        ASSERT_LT(u, 1.0f);
        ASSERT_EQ(u, float(reference_splitmix(state) >> 40) / 16777216.0f);
    }
}

TEST(SplitMix64, DiskSamplesInsideTheUnitDisk) {
    SplitMix64 rng(3);
    for (int i = 0; i < 10000; ++i) {
        float a, b, s;
        rng.disk(a, b, s);
        ASSERT_LT(s, 1.0f);
        ASSERT_GE(a, -1.0f);
        ASSERT_GE(b, -1.0f);
    }
}

TEST(RayKind, ParsesAndPrints) {
    for (RayKind kind : {RayKind::random, RayKind::primary, RayKind::diffuse})
        EXPECT_EQ(parse_ray_kind(to_string(kind)), kind);
    EXPECT_THROW(parse_ray_kind("shadow"), Error);
}

TEST(RandomRays, InsideTheBoxWithUnitDirections) {
    const AABB box{{-1, 2, -3}, {4, 5, 6}};
    const std::vector<Ray> rays = generate_random_rays(box, 5000, 11);
    ASSERT_EQ(rays.size(), 5000u);
    Vec3 mean_dir{0.0f};
    for (const Ray& ray : rays) {
        ASSERT_TRUE(box.contains(ray.org));
        ASSERT_NEAR(length(ray.dir), 1.0f, 1e-5f);
        ASSERT_EQ(ray.tmin, 0.0f);
        ASSERT_EQ(ray.tmax, kInfinity);
        mean_dir = mean_dir + ray.dir;
    }
    // Uniform on the sphere: the mean direction is close to zero (3 sigma ~ 0.025 per axis).
    mean_dir = mean_dir / 5000.0f;
    EXPECT_LT(length(mean_dir), 0.05f);

    // The first ray follows the spec's recipe (tolerance: this file may be compiled with FMA).
    uint64_t state = 11;
    auto uniform = [&] { return float(reference_splitmix(state) >> 40) / 16777216.0f; };
    const float u0 = uniform(), u1 = uniform(), u2 = uniform();
    EXPECT_NEAR(rays[0].org.x, -1.0 + u0 * 5.0, 1e-5);
    EXPECT_NEAR(rays[0].org.y, 2.0 + u1 * 3.0, 1e-5);
    EXPECT_NEAR(rays[0].org.z, -3.0 + u2 * 9.0, 1e-5);
    double a, b, s;
    do {
        a = 2.0 * uniform() - 1.0;
        b = 2.0 * uniform() - 1.0;
        s = a * a + b * b;
    } while (!(s < 1.0) || s == 0.0);
    EXPECT_NEAR(rays[0].dir.x, a * 2.0 * std::sqrt(1.0 - s), 1e-5);
    EXPECT_NEAR(rays[0].dir.y, b * 2.0 * std::sqrt(1.0 - s), 1e-5);
    EXPECT_NEAR(rays[0].dir.z, 1.0 - 2.0 * s, 1e-5);

    // Deterministic per seed.
    const std::vector<Ray> again = generate_random_rays(box, 5000, 11);
    const std::vector<Ray> other = generate_random_rays(box, 5000, 12);
    EXPECT_EQ(std::memcmp(rays.data(), again.data(), rays.size() * sizeof(Ray)), 0);
    EXPECT_NE(std::memcmp(rays.data(), other.data(), rays.size() * sizeof(Ray)), 0);
    EXPECT_THROW(generate_random_rays(AABB::empty(), 10, 1), Error);
}

TEST(PrimaryRays, CountOrderAndDirections) {
    Camera camera;
    camera.eye = {0, 0, 0};
    camera.target = {0, 0, -1};
    camera.up = {0, 1, 0};
    camera.fovy_degrees = 90.0f;  // tanHalf = 1
    const std::vector<Ray> rays = generate_primary_rays(camera, 3, 3);
    ASSERT_EQ(rays.size(), 9u);
    for (const Ray& ray : rays) {
        EXPECT_EQ(ray.org, camera.eye);
        EXPECT_NEAR(length(ray.dir), 1.0f, 1e-6f);
    }
    // Centre pixel (1, 1) looks straight ahead.
    EXPECT_NEAR(rays[4].dir.x, 0.0f, 1e-7f);
    EXPECT_NEAR(rays[4].dir.y, 0.0f, 1e-7f);
    EXPECT_NEAR(rays[4].dir.z, -1.0f, 1e-7f);
    // Pixel (0, 0) is top left: sx = (2/6 - 1) = -2/3, sy = 1 - 2/6 = 2/3 -> normalize(-2/3, 2/3, -1).
    const float n = std::sqrt(4.0f / 9 + 4.0f / 9 + 1.0f);
    EXPECT_NEAR(rays[0].dir.x, -2.0f / 3 / n, 1e-6f);
    EXPECT_NEAR(rays[0].dir.y, 2.0f / 3 / n, 1e-6f);
    EXPECT_NEAR(rays[0].dir.z, -1.0f / n, 1e-6f);
    // Pixel (2, 0) (index 2) is top right.
    EXPECT_GT(rays[2].dir.x, 0.0f);
    EXPECT_GT(rays[2].dir.y, 0.0f);
}

TEST(PrimaryRays, CentrePixelLooksAtTheTargetForOddSizes) {
    Camera camera;
    camera.eye = {1, 2, 3};
    camera.target = {-0.5f, 0.25f, 0.0f};
    camera.up = {0, 1, 0};
    camera.fovy_degrees = 45.0f;
    const Vec3 forward = normalize(camera.target - camera.eye);
    for (auto [w, h] : {std::pair{5u, 3u}, std::pair{101u, 77u}, std::pair{1u, 1u}}) {
        const std::vector<Ray> rays = generate_primary_rays(camera, w, h);
        ASSERT_EQ(rays.size(), size_t(w) * h);
        const Ray& centre = rays[size_t(h / 2) * w + w / 2];
        EXPECT_NEAR(centre.dir.x, forward.x, 1e-6f);
        EXPECT_NEAR(centre.dir.y, forward.y, 1e-6f);
        EXPECT_NEAR(centre.dir.z, forward.z, 1e-6f);
    }
    EXPECT_THROW(generate_primary_rays(camera, 0, 4), Error);
    camera.target = camera.eye;
    EXPECT_THROW(generate_primary_rays(camera, 4, 4), Error);
}

TEST(DiffuseRays, LeaveTheSurfaceOnTheIncomingSide) {
    const Scene scene = floor_scene();
    Camera camera;
    camera.eye = {0.3f, 2.0f, 0.7f};
    camera.target = {0, 0, 0};
    camera.up = {0, 1, 0};
    camera.fovy_degrees = 60.0f;
    std::vector<Ray> primary = generate_primary_rays(camera, 16, 16);
    // Half of the rays come from below, to check the normal flip.
    for (size_t i = 0; i < primary.size(); i += 2) {
        primary[i].org.y = -primary[i].org.y;
        primary[i].dir.y = -primary[i].dir.y;
    }
    std::vector<Hit> hits(primary.size());
    size_t hit_count = 0;
    for (size_t i = 0; i < primary.size(); ++i) {
        const HitRecord r = arbiter_closest_hit(scene, primary[i]);
        if (r.is_hit()) {
            hits[i].t = r.t;
            hits[i].primitive = r.primitive;
            ++hit_count;
        }
    }
    ASSERT_GT(hit_count, 10u);
    ASSERT_LT(hit_count, primary.size());

    const std::vector<Ray> diffuse = generate_diffuse_rays(scene, primary, hits, 5);
    ASSERT_EQ(diffuse.size(), hit_count);
    const float epsilon = 1e-4f * scene.diagonal();
    size_t k = 0;
    for (size_t i = 0; i < primary.size(); ++i) {
        if (!hits[i].is_hit()) continue;
        const Ray& ray = diffuse[k++];
        const float side = primary[i].dir.y > 0 ? -1.0f : 1.0f;  // the side the primary ray came from
        EXPECT_NEAR(ray.org.y, side * epsilon, 1e-2f * epsilon);
        EXPECT_GT(ray.dir.y * side, 0.0f);
        EXPECT_NEAR(length(ray.dir), 1.0f, 1e-5f);
        EXPECT_EQ(ray.tmin, 0.0f);
        EXPECT_EQ(ray.tmax, kInfinity);
    }

    // An explicit epsilon is used as given; a mismatch of sizes or a bad primitive is an Error.
    const std::vector<Ray> far = generate_diffuse_rays(scene, primary, hits, 5, 0.5f);
    EXPECT_NEAR(std::abs(far[0].org.y), 0.5f, 1e-5f);
    EXPECT_THROW(generate_diffuse_rays(scene, primary, std::span<const Hit>(hits).first(3), 5), Error);
    hits[1].primitive = 99;
    hits[1].t = 1.0f;
    EXPECT_THROW(generate_diffuse_rays(scene, primary, hits, 5), Error);
}

TEST(DiffuseRays, CosineDistributedAroundTheNormal) {
    // Many bounces off one point: mean cos(theta) of a cosine lobe is 2/3.
    const Scene scene = floor_scene();
    Ray down;
    down.org = {0.1f, 1.0f, 0.2f};
    down.dir = {0, -1, 0};
    std::vector<Ray> primary(20000, down);
    std::vector<Hit> hits(primary.size());
    for (Hit& h : hits) {
        h.t = 1.0f;
        h.primitive = 0;
    }
    const std::vector<Ray> diffuse = generate_diffuse_rays(scene, primary, hits, 9);
    double mean_cos = 0, mean_x = 0, mean_z = 0;
    for (const Ray& r : diffuse) {
        mean_cos += r.dir.y;
        mean_x += r.dir.x;
        mean_z += r.dir.z;
    }
    EXPECT_NEAR(mean_cos / diffuse.size(), 2.0 / 3.0, 0.01);
    EXPECT_NEAR(mean_x / diffuse.size(), 0.0, 0.02);
    EXPECT_NEAR(mean_z / diffuse.size(), 0.0, 0.02);
}

TEST(Records, FromHitsAndOcclusion) {
    Hit miss;
    EXPECT_FALSE(to_record(miss).is_hit());
    EXPECT_EQ(to_record(miss).primitive, kInvalidIndex);
    Hit hit;
    hit.t = 2.5f;
    hit.primitive = 7;
    EXPECT_EQ(to_record(hit).t, 2.5f);
    EXPECT_EQ(to_record(hit).primitive, 7u);
    EXPECT_EQ(occlusion_record(true).t, 0.0f);
    EXPECT_TRUE(occlusion_record(true).is_hit());
    EXPECT_EQ(occlusion_record(false).t, kInfinity);
    EXPECT_EQ(occlusion_record(true).primitive, kInvalidIndex);
}

TEST(RayFiles, RoundTripBitExact) {
    std::vector<Ray> rays = generate_random_rays(AABB{{0, 0, 0}, {1, 2, 3}}, 70000, 1);  // > one I/O chunk
    rays[3].tmin = 0.25f;
    rays[3].tmax = 9.0f;
    rays[4].dir = {-0.0f, 1e-30f, 3.0f};
    const std::string path = temp_path("round_trip.rays");
    write_ray_file(path, rays);
    EXPECT_EQ(std::filesystem::file_size(path), 16u + 32u * rays.size());
    const std::vector<unsigned char> bytes = read_bytes(path);
    EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 8), "REFRAYS1");
    EXPECT_EQ(bytes[8], 70000 & 0xFF);  // little-endian count
    EXPECT_EQ(bytes[9], (70000 >> 8) & 0xFF);
    const std::vector<Ray> back = read_ray_file(path);
    ASSERT_EQ(back.size(), rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        ASSERT_EQ(std::memcmp(&back[i], &rays[i], sizeof(Ray)), 0) << "record " << i;
    }

    std::vector<HitRecord> hits = {{1.5f, 3}, {}, occlusion_record(true), {1e-38f, 0xFFFFFFFEu}};
    const std::string hit_path = temp_path("round_trip.hits");
    write_hit_file(hit_path, hits);
    EXPECT_EQ(std::filesystem::file_size(hit_path), 16u + 8u * hits.size());
    const std::vector<HitRecord> hits_back = read_hit_file(hit_path);
    ASSERT_EQ(hits_back.size(), hits.size());
    for (size_t i = 0; i < hits.size(); ++i) {
        EXPECT_TRUE(same_bits(hits_back[i].t, hits[i].t));
        EXPECT_EQ(hits_back[i].primitive, hits[i].primitive);
    }

    // Empty files are legal.
    write_ray_file(path, {});
    EXPECT_TRUE(read_ray_file(path).empty());
}

namespace {
// The error message of reading `path` as a ray file, or "" when it reads.
std::string ray_file_error(const std::string& path) {
    try {
        read_ray_file(path);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}
}  // namespace

TEST(RayFiles, ErrorsNameTheFileAndRecord) {
    const std::vector<Ray> rays = generate_random_rays(AABB{{0, 0, 0}, {1, 1, 1}}, 10, 1);
    const std::string good = temp_path("good.rays");
    write_ray_file(good, rays);
    const std::vector<unsigned char> bytes = read_bytes(good);

    // Bad magic.
    std::vector<unsigned char> bad = bytes;
    bad[7] = '2';
    const std::string bad_magic = temp_path("bad_magic.rays");
    write_bytes(bad_magic, bad);
    std::string message = ray_file_error(bad_magic);
    EXPECT_NE(message.find(bad_magic), std::string::npos) << message;
    EXPECT_NE(message.find("magic"), std::string::npos) << message;

    // A hit file is not a ray file.
    const std::string hits = temp_path("not_rays.hits");
    write_hit_file(hits, std::vector<HitRecord>(3));
    EXPECT_NE(ray_file_error(hits).find("magic"), std::string::npos);
    EXPECT_THROW(read_hit_file(good), Error);

    // Truncated inside record 9.
    const std::string truncated = temp_path("truncated.rays");
    write_bytes(truncated, std::vector<unsigned char>(bytes.begin(), bytes.end() - 5));
    message = ray_file_error(truncated);
    EXPECT_NE(message.find(truncated), std::string::npos) << message;
    EXPECT_NE(message.find("record 9"), std::string::npos) << message;

    // Truncated header, empty file.
    const std::string short_header = temp_path("short_header.rays");
    write_bytes(short_header, std::vector<unsigned char>(bytes.begin(), bytes.begin() + 12));
    EXPECT_NE(ray_file_error(short_header).find("truncated"), std::string::npos);
    const std::string empty = temp_path("empty.rays");
    write_bytes(empty, {});
    EXPECT_FALSE(ray_file_error(empty).empty());

    // A count far beyond the file size is refused before anything is allocated.
    std::vector<unsigned char> huge = bytes;
    huge[15] = 0x10;  // count ~ 2^60
    const std::string huge_path = temp_path("huge_count.rays");
    write_bytes(huge_path, huge);
    EXPECT_NE(ray_file_error(huge_path).find("truncated"), std::string::npos);

    // Trailing bytes after the last record.
    std::vector<unsigned char> trailing = bytes;
    trailing.push_back(0);
    const std::string trailing_path = temp_path("trailing.rays");
    write_bytes(trailing_path, trailing);
    EXPECT_FALSE(ray_file_error(trailing_path).empty());

    // A NaN direction in record 4.
    std::vector<unsigned char> nan_bytes = bytes;
    const float nan = std::nanf("");
    std::memcpy(&nan_bytes[16 + 32 * 4 + 12], &nan, 4);
    const std::string nan_path = temp_path("nan.rays");
    write_bytes(nan_path, nan_bytes);
    EXPECT_NE(ray_file_error(nan_path).find("record 4"), std::string::npos);

    // Missing file.
    EXPECT_NE(ray_file_error(temp_path("does_not_exist.rays")).find("cannot open"), std::string::npos);
    EXPECT_THROW(write_ray_file("/nonexistent_dir/x.rays", rays), Error);
}
