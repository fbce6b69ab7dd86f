// SPDX-License-Identifier: MIT
// Building at scale: the procedural builtin:city:N scene (sizes, determinism, every builder's tree
// against the exact arbiter on a small city) and the memory estimate that refuses a build before it
// starts (include/spacebvh/memory_estimate.hpp).
#include <gtest/gtest.h>

#include <tbb/task_arena.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "builders/memory_estimate.hpp"
#include "cli_support.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "test_support.hpp"
#ifdef SPACEBVH_WITH_EMBREE
#include "spacebvh/tools/embree_builder.hpp"
#endif

using namespace spacebvh;
using namespace spacebvh::tools;
using namespace spacebvh::testing_support;

namespace {

bool same_bytes(const Scene& a, const Scene& b) {
    return a.triangles.size() == b.triangles.size() &&
           std::memcmp(a.triangles.data(), b.triangles.data(), a.triangles.size() * sizeof(Triangle)) == 0;
}

Scene city_in_arena(int threads, const std::string& size) {
    tbb::task_arena arena(threads);
    Scene scene;
    arena.execute([&] { scene = load_scene("builtin:city:" + size); });
    return scene;
}

}  // namespace

TEST(CityScene, CountsCloseToTheSizeAndTheSameBytesForTheSameSize) {
    for (uint64_t size : {100u, 1000u, 20000u, 250000u}) {
        SCOPED_TRACE(size);
        const Scene scene = load_scene("builtin:city:" + std::to_string(size));
        EXPECT_EQ(scene.name, "city:" + std::to_string(size));
        const double ratio = double(scene.triangles.size()) / double(size);
        // Small cities round to whole buildings; from 10^4 triangles the facade detail absorbs it.
        EXPECT_NEAR(ratio, 1.0, size >= 10000 ? 0.01 : 0.05);
        EXPECT_EQ(scene.degenerate_count, 0u);
        for (const Triangle& t : scene.triangles) ASSERT_TRUE(is_finite(t.v0) && is_finite(t.v1) && is_finite(t.v2));
        EXPECT_TRUE(same_bytes(scene, city_in_arena(1, std::to_string(size)))) << "1 thread";
        EXPECT_TRUE(same_bytes(scene, city_in_arena(2, std::to_string(size)))) << "2 threads";
        // Huge ground triangles: the first spans the whole scene in x and z.
        const AABB ground = scene.triangles.front().bounds(), all = scene.bounds();
        EXPECT_EQ(ground.lo.x, all.lo.x);
        EXPECT_EQ(ground.hi.z, all.hi.z);
        // Tall towers, and (from 10^4 triangles) most triangles small facade cells: a plain wall or a
        // tower storey has a box of area >= 100, a facade cell far less.
        float tallest = 0;
        size_t small = 0;
        for (const Triangle& t : scene.triangles) {
            tallest = std::max(tallest, t.bounds().hi.y);
            small += t.bounds().area() < 100.0f ? 1 : 0;
        }
        EXPECT_GT(tallest, 30.0f);
        if (size >= 10000) {
            EXPECT_GT(small, scene.triangles.size() / 2);
        }
    }
    EXPECT_TRUE(same_bytes(load_scene("builtin:city:1e4"), load_scene("builtin:city:10000")));
    EXPECT_FALSE(same_bytes(load_scene("builtin:city:10000"), load_scene("builtin:city:12000")));
}

TEST(CityScene, BadSizesAreRefusedNamingTheScene) {
    for (const char* bad : {"builtin:city:", "builtin:city:abc", "builtin:city:1.5", "builtin:city:99",
                            "builtin:city:-5", "builtin:city:3e9", "builtin:city:100x"}) {
        SCOPED_TRACE(bad);
        try {
            (void)load_scene(bad);
            ADD_FAILURE() << "no error";
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("builtin:city:"), std::string::npos) << error.what();
        }
    }
    try {
        (void)load_scene("builtin:town");
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("city:N"), std::string::npos) << error.what();
    }
}

// Every builder on a small city: a valid tree, the same byte for byte with 1 and 2 threads, and
// closest-hit and occlusion answers equal to the exact arbiter's on random rays, rays aimed at
// vertices and edges, and primary rays of its camera.
TEST(CityScene, EveryBuilderGivesAValidTreeThatAgreesWithTheArbiter) {
    const Scene scene = load_scene("builtin:city:3000");
    std::vector<Ray> rays = probing_rays(scene, 1500, 7);
    const std::vector<Ray> primary = generate_primary_rays(camera_for_scene(scene, "builtin:city:3000", {}), 48, 32);
    rays.insert(rays.end(), primary.begin(), primary.end());
    for (const std::string& builder : builder_names()) {
        SCOPED_TRACE(builder);
        const BuildConfig options = config_for(builder);
        const Bvh bvh = build_in_arena(2, scene, options);
        EXPECT_EQ(tree_violations(scene, bvh, options), "");
        EXPECT_EQ(first_difference(bvh, build_in_arena(1, scene, options)), "") << "1 vs 2 threads";
        EXPECT_EQ(wrong_against_arbiter(scene, Tracer(scene, bvh, Kernel::binary), rays), "");
    }
#ifdef SPACEBVH_WITH_EMBREE
    for (const std::string& builder : embree_tree_names()) {
        SCOPED_TRACE(builder);
        const BuildConfig options = config_for("spatial");  // the invariants of a tree with split references
        const Bvh bvh = build_embree_tree(scene, builder, options);
        EXPECT_EQ(tree_violations(scene, bvh, options), "");
        EXPECT_EQ(wrong_against_arbiter(scene, Tracer(scene, bvh, Kernel::binary), rays), "");
    }
#endif
}

TEST(MemoryEstimate, GrowsWithTheReferencesTheBuildMayHold) {
    const uint64_t n = 1'000'000;
    const MemoryEstimate binned = estimate_build_memory(n, config_for("binned"));
    const MemoryEstimate cbvh = estimate_build_memory(n, config_for("cbvh"));
    const MemoryEstimate spatial = estimate_build_memory(n, config_for("spatial"));
    EXPECT_EQ(binned.references, n);
    EXPECT_EQ(cbvh.references, n);
    EXPECT_EQ(spatial.references, uint64_t(double(1.3f) * double(n)));  // as build() sizes its storage
    // Per reference at least the references and two 36-byte node slots; cbvh keeps three orders.
    EXPECT_GE(binned.bytes, n * (sizeof(builders::Reference) + 72));
    EXPECT_GE(cbvh.bytes, binned.bytes + 2 * n * sizeof(builders::Reference));
    EXPECT_GT(spatial.bytes, cbvh.bytes);
    BuildConfig more_budget = config_for("spatial");
    more_budget.limits.reference_budget = 2.0f;
    EXPECT_GT(estimate_build_memory(n, more_budget).bytes, spatial.bytes);
    EXPECT_EQ(estimate_build_memory(n, config_for("binned"), true).bytes, binned.bytes + n * sizeof(Triangle));
    const uint64_t fixed = estimate_build_memory(0, config_for("binned")).bytes;
    EXPECT_EQ(estimate_build_memory(10 * n, config_for("binned")).bytes - fixed, 10 * (binned.bytes - fixed));
    BuildConfig lookahead = config_for("spatial");
    lookahead.lookahead.depth = 2;
    EXPECT_GT(estimate_build_memory(n, lookahead).bytes, spatial.bytes);
}

TEST(MemoryEstimate, ABuildOverTheLimitIsRefusedBeforeItStarts) {
    const Scene scene = load_scene("builtin:city:2000");
    BuildConfig options = config_for("spatial");
    ProgressLog progress;
    options.hooks.progress = progress.callback();
    options.limits.memory_limit_bytes = 1000;
    const uint64_t estimate = estimate_build_memory(scene.triangles.size(), options).bytes;
    try {
        (void)spacebvh::build(scene, options);
        ADD_FAILURE() << "built over the limit";
    } catch (const Error& error) {
        const std::string text = error.what();
        EXPECT_NE(text.find("city:2000"), std::string::npos) << text;
        EXPECT_NE(text.find(format_bytes(estimate) + " (estimate)"), std::string::npos) << text;
        EXPECT_NE(text.find("memory limit of 1000 bytes"), std::string::npos) << text;
    }
    EXPECT_TRUE(progress.reports.empty()) << "the build started";
    options.limits.memory_limit_bytes = estimate;  // exactly the estimate fits
    EXPECT_FALSE(spacebvh::build(scene, options).empty());
#ifdef SPACEBVH_WITH_EMBREE
    BuildConfig embree_options = config_for("binned");
    embree_options.limits.memory_limit_bytes = 1000;
    EXPECT_THROW((void)build_embree_tree(scene, "embree-high", embree_options), Error);
#endif
}

TEST(MemoryEstimate, TheMemoryAvailableAndThe32BitNodeNumbersBoundTheBuild) {
    // 2e9 triangles never fit this machine: refused against MemAvailable, before any allocation.
    if (available_memory_bytes() > 0) {
        try {
            builders::check_build_memory(2'000'000'000, false, "huge", config_for("binned"));
            ADD_FAILURE() << "no error";
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("available (MemAvailable)"), std::string::npos) << error.what();
        }
    }
    // With a reference budget of 4, 2^30 triangles may grow to 2^32 references: more than the node
    // numbers hold, whatever the memory.
    BuildConfig options = config_for("spatial");
    options.limits.reference_budget = 4.0f;
    options.limits.memory_limit_bytes = UINT64_MAX;
    try {
        builders::check_build_memory(uint64_t(1) << 30, false, "wide", options);
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("2^31 - 1"), std::string::npos) << error.what();
    }
    EXPECT_NO_THROW(builders::check_build_memory(uint64_t(1) << 28, false, "fits", options));
}

TEST_F(Cli, BuildRefusesOverTheMemoryLimitAndReportsTheEstimate) {
    const CliResult refused = run("build builtin:city:2000 --builder spatial --memory-limit 2K");
    EXPECT_EQ(refused.exit_code, 1) << refused.output;
    EXPECT_NE(refused.output.find("memory limit of 2.0 KiB"), std::string::npos) << refused.output;
    expect_clean_failure("build builtin:city:2000 --memory-limit 2X", {"--memory-limit", "2X"});

    const CliResult built = run("build builtin:city:2000 --builder binned --no-epo --json out.json");
    ASSERT_EQ(built.exit_code, 0) << built.output;
    const nlohmann::json json = read_json("out.json");
    EXPECT_EQ(json["estimated_build_bytes"].get<uint64_t>(),
              estimate_build_memory(json["triangles"].get<uint64_t>(), config_for("binned")).bytes);
    EXPECT_GE(json["peak_rss_bytes"].get<uint64_t>(), json["build_peak_rss_bytes"].get<uint64_t>());
    EXPECT_EQ(json["scene_bytes"].get<uint64_t>(), json["triangles"].get<uint64_t>() * sizeof(Triangle));
}
