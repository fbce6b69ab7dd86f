// SPDX-License-Identifier: MIT
// The command line on instanced scenes (builtin:forest:N): info, build, trace, render and compare
// take them; trace's answers match the instanced scene's exact arbiter (each placement's triangles
// for the ray taken into its space) and compare finds no wrong answer against Embree's two-level
// scene; bad specs and options fail cleanly.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "cli_support.hpp"
#include "spacebvh/scene_file.hpp"
#include "spacebvh/tools/instanced_scene.hpp"
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

// The forest's exact arbiter, made from the scene description the tests load themselves.
struct ForestReference {
    InstancedScene scene = load_instanced_scene(kForest);
    ScenePlacements placed = mesh_placements_of(scene);
    SceneArbiter arbiter{placed.meshes, placed.placements};
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
        instanced += reference.placed.meshes[p.mesh].triangles.size();
    EXPECT_EQ(json["instanced_triangles"], instanced);
    EXPECT_EQ(json["instanced_triangles"], reference.scene.instanced_triangle_count());
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
    // --save writes a scene file that loads as the same scene: its answers are the built scene's.
    const CliResult saved = run(std::string("build ") + kForest + " --builder spatial --save s.scene");
    ASSERT_EQ(saved.exit_code, 0) << saved.output;
    ASSERT_TRUE(is_scene_file(path("s.scene")));
    SceneFileInfo info;
    const std::shared_ptr<RenderScene> loaded = load_render_scene(path("s.scene"), {}, &info);
    const ForestReference reference;
    EXPECT_EQ(info.instance_count, 12u);
    const std::vector<Ray> rays = generate_random_rays(reference.arbiter.bounds(), 300, 4);
    size_t wrong = 0;
    for (const Ray& ray : rays) {
        const SceneHit hit = loaded->intersect(ray);
        wrong += !hits_agree({hit.t, hit.primitive}, reference.arbiter.closest_hit(ray).hit, ray,
                             reference.arbiter.diagonal());
    }
    EXPECT_EQ(wrong, 0u);
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
    // Every row's scene is kept: the estimate of all of them is checked before the first build.
    const CliResult r = run(std::string("compare ") + kForest +
                            " --builders binned,spatial --kernel bvh8,bvh4 "
                            "--memory-limit 60M --runs 1");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find("4 times, the rows' scenes"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("memory limit"), std::string::npos) << r.output;
}

TEST_F(Cli, BadInstancedSpecsFailCleanly) {
    for (const char* spec : {"builtin:forest:0", "builtin:forest:abc", "builtin:forest:1e13", "builtin:forest:-5"})
        for (const char* command : {"info", "build"})
            expect_clean_failure(std::string(command) + " " + spec, {"forest"});
    // The load-time transform moves every instance.
    CliResult r = run(std::string("info ") + kForest + " --translate 1000 0 0 --json moved.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = run(std::string("info ") + kForest + " --json here.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NEAR(read_json("moved.json")["bounds"][0][0].get<double>(),
                read_json("here.json")["bounds"][0][0].get<double>() + 1000.0, 1.0);
    expect_clean_failure(std::string("compare ") + kForest + " --tree t.bvh", {"t.bvh"});
}

namespace {

// A glTF (its JSON, then its NAME.bin) of one tetrahedron mesh placed by `nodes` translated nodes.
std::pair<std::string, std::string> gltf_files(const std::string& name, int nodes) {
    const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    std::string bin;
    for (const auto& face : faces)
        for (int k : face) bin.append(reinterpret_cast<const char*>(p[k]), sizeof p[k]);
    std::string node_list, node_ids;
    for (int n = 0; n < nodes; ++n) {
        node_list += std::string(n ? "," : "") + R"({"mesh":0,"translation":[)" + std::to_string(2 * n) + ",0.5," +
                     std::to_string(n % 2) + "]}";
        node_ids += std::string(n ? "," : "") + std::to_string(n);
    }
    return {R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[)" + node_ids + R"(]}],"nodes":[)" + node_list +
                R"(],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
                R"("accessors":[{"bufferView":0,"componentType":5126,"count":12,"type":"VEC3",)"
                R"("min":[0,0,0],"max":[1,1,1]}],"bufferViews":[{"buffer":0,"byteLength":144}],)"
                R"("buffers":[{"uri":")" +
                name + R"(.bin","byteLength":144}]})",
            bin};
}

}  // namespace

// A glTF whose nodes place its mesh three times is an instanced scene; one that places it once stays
// one mesh with today's output.
TEST_F(Cli, GltfNodeInstancingOnTheCommandLine) {
    for (const auto& [name, nodes] : {std::pair{"three", 3}, std::pair{"one", 1}}) {
        const auto [gltf, bin] = gltf_files(name, nodes);
        write(std::string(name) + ".gltf", gltf);
        write(std::string(name) + ".bin", bin);
    }
    CliResult r = run("info three.gltf --json three.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(read_json("three.json")["instances"], 3);
    EXPECT_EQ(read_json("three.json")["instanced_triangles"], 12);
    r = run("info one.gltf --json one.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_FALSE(read_json("one.json").contains("instances"));
    EXPECT_EQ(read_json("one.json")["triangles"], 4);
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(
        compare_rows("three.gltf --builders spatial --embree high --embree-packets none "
                     "--random 2000 --width 24 --height 24 --runs 1 --build-runs 1 --no-epo",
                     2, rows));
    for (const nlohmann::json& row : rows)
        for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(row[kind]["wrong"], 0) << kind;
}
