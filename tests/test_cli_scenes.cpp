// SPDX-License-Identifier: MIT
// The command line on instanced scenes (builtin:forest:N): info, build, trace, render and compare
// take them; trace's answers match the instanced scene's exact arbiter (each placement's triangles
// for the ray taken into its space) and compare finds no wrong answer against Embree's two-level
// scene; bad specs and options fail cleanly.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_support.hpp"
#include "instanced_shim.hpp"  // TEMPORARY
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene_arbiter.hpp"
#include "spacebvh/tools/verify.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

using spacebvh::testing_support::Cli;
using spacebvh::testing_support::CliResult;
using spacebvh::testing_support::has_png_signature;

namespace {

constexpr const char* kForest = "builtin:forest:12";

// Every placement of the description: instance k of the top scene places its mesh as geometry 0.
std::vector<MeshPlacement> forest_placements(const InstancedScene& scene) {
    std::vector<MeshPlacement> out;
    for (size_t k = 0; k < scene.instances.size(); ++k) {
        MeshPlacement p;
        p.mesh = scene.instances[k].mesh;
        p.transforms = {scene.instances[k].transform};
        p.path[0] = uint32_t(k);
        out.push_back(p);
    }
    return out;
}

// The forest's exact arbiter, made from the scene description the tests load themselves.
struct ForestReference {
    InstancedScene scene = load_instanced_scene(kForest);
    SceneArbiter arbiter{scene.meshes, forest_placements(scene)};
};

}  // namespace

TEST_F(Cli, InfoOnAnInstancedScene) {
    const CliResult r = run(std::string("info ") + kForest + " --json i.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("instances   12"), std::string::npos) << r.output;
    const nlohmann::json json = read_json("i.json");
    const ForestReference reference;
    EXPECT_EQ(json["instances"], 12);
    EXPECT_EQ(json["meshes"], reference.scene.meshes.size());
    uint64_t instanced = 0;
    for (const MeshPlacement& p : reference.arbiter.placements())
        instanced += reference.scene.meshes[p.mesh].triangles.size();
    EXPECT_EQ(json["instanced_triangles"], instanced);
    EXPECT_GT(json["instanced_triangles"].get<uint64_t>(), json["triangles"].get<uint64_t>());
    EXPECT_GT(json["estimated_build_bytes"].get<uint64_t>(), 0u);
}

TEST_F(Cli, BuildAnInstancedScenePrintsTheEstimateFirst) {
    const CliResult r = run(std::string("build ") + kForest + " --builder spatial --json b.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const size_t estimate = r.output.find("memory estimate"), build = r.output.find("build    ");
    ASSERT_NE(estimate, std::string::npos) << r.output;
    ASSERT_NE(build, std::string::npos) << r.output;
    EXPECT_LT(estimate, build) << r.output;
    const nlohmann::json json = read_json("b.json");
    EXPECT_EQ(json["instances"], 12);
    EXPECT_GT(json["bytes"].get<uint64_t>(), 0u);
    EXPECT_GT(json["estimated_build_bytes"].get<uint64_t>(), 0u);
    // Over the limit: refused before the build, naming the scene and the limit.
    expect_clean_failure(std::string("build ") + kForest + " --memory-limit 1K", {"forest", "memory limit"});
    expect_clean_failure(std::string("build ") + kForest + " --save s.bvh", {"--save", "instanced"});
}

// Every single-ray kernel's hit file against the arbiter, closest hits and occlusion; packet
// kernels are refused.
TEST_F(Cli, TraceAnInstancedSceneMatchesTheArbiter) {
    const ForestReference reference;
    const AABB box = reference.arbiter.bounds();
    const std::vector<Ray> rays = generate_random_rays(box, 400, 3);
    write_ray_file(path("r.bin"), rays);
    const float diagonal = reference.arbiter.diagonal();
    for (const char* kernel : {"binary", "bvh4", "bvh8"}) {
        SCOPED_TRACE(kernel);
        CliResult r = run(std::string("trace ") + kForest + " --rays r.bin --hits h.bin --builder spatial --kernel " +
                          kernel + " --json t.json");
        ASSERT_EQ(r.exit_code, 0) << r.output;
        r = run(std::string("trace ") + kForest + " --rays r.bin --hits o.bin --occlusion --kernel " + kernel);
        ASSERT_EQ(r.exit_code, 0) << r.output;
        const std::vector<HitRecord> hits = read_hit_file(path("h.bin")), occluded = read_hit_file(path("o.bin"));
        ASSERT_EQ(hits.size(), rays.size());
        ASSERT_EQ(occluded.size(), rays.size());
        size_t wrong = 0, hit_count = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            const PlacedHit truth = reference.arbiter.closest_hit(rays[i]);
            hit_count += truth.hit.is_hit();
            wrong += !hits_agree(hits[i], truth.hit, rays[i], diagonal);
            wrong += occluded[i].is_hit() != reference.arbiter.occluded(rays[i]);
        }
        EXPECT_EQ(wrong, 0u);
        EXPECT_GT(hit_count, 20u);
        EXPECT_EQ(read_json("t.json")["rays"], 400);
    }
    expect_clean_failure(std::string("trace ") + kForest + " --rays r.bin --hits h.bin --kernel packet8",
                         {"packet8", "instanced"});
    expect_clean_failure(std::string("trace ") + kForest + " --rays r.bin --hits h.bin --stats", {"--stats"});
}

TEST_F(Cli, RenderAnInstancedScene) {
    const CliResult r = run(std::string("render ") + kForest + " -o f.png --width 48 --height 32");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(has_png_signature(read("f.png")));
    expect_clean_failure(std::string("render ") + kForest + " -o h.png --heatmap", {"--heatmap"});
}

// Our rows (two kernels) and Embree's two-level rows (single rays and 16-ray packets), every answer
// checked: none wrong, with the table's JSON keys.
TEST_F(Cli, CompareAnInstancedSceneAgainstEmbreesTwoLevelScene) {
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(compare_rows(std::string(kForest) +
                                             " --builders binned,spatial --kernel bvh8,binary --embree high "
                                             "--embree-packets high --random 3000 --width 40 --height 40 --runs 1 "
                                             "--build-runs 1 --no-epo",
                                         6, rows));
    const nlohmann::json json = read_json("c.json");
    EXPECT_EQ(json["scenes"][0]["instances"], 12);
    size_t embree_rows = 0;
    for (const nlohmann::json& row : rows) {
        const std::string name = row["builder"], kernel = row["kernel"];
        SCOPED_TRACE(name + " " + kernel);
        if (name.rfind("embree-", 0) == 0) {
            ++embree_rows;
            EXPECT_NE(kernel.find("two-level"), std::string::npos);
        }
        for (const char* kind : {"random", "primary", "diffuse"}) {
            EXPECT_EQ(row[kind]["wrong"], 0) << kind;
            EXPECT_GT(row[kind]["closest_mrays"].get<double>(), 0.0) << kind;
            EXPECT_GT(row[kind]["occlusion_mrays"].get<double>(), 0.0) << kind;
        }
    }
    EXPECT_EQ(embree_rows, 2u);
    EXPECT_GT(json["scenes"][0]["rays"]["diffuse"].get<int>(), 0);
    expect_clean_failure(std::string("compare ") + kForest + " --kernel packet16 --runs 1", {"packet16", "instanced"});
}

TEST_F(Cli, BadInstancedSpecsFailCleanly) {
    for (const char* spec : {"builtin:forest:0", "builtin:forest:abc", "builtin:forest:1e13", "builtin:forest:-5"})
        for (const char* command : {"info", "build"}) expect_clean_failure(std::string(command) + " " + spec, {"forest"});
    expect_clean_failure(std::string("info ") + kForest + " --rotate x:30", {"--rotate"});
    expect_clean_failure(std::string("compare ") + kForest + " --tree t.bvh", {"--tree"});
}
