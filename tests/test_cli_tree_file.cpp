// SPDX-License-Identifier: MIT
// Tree files on the command line: `build --save FILE`, then `--tree FILE` on trace, render and compare
// in place of building (scene files for instanced scenes); a saved tree gives the hit files of the
// built one, and a damaged file, one of another scene or of the other kind fails cleanly, naming the file.
#include <gtest/gtest.h>

#include <string>

#include "cli_support.hpp"
#include "spacebvh/tools/instanced_scene.hpp"
#include "spacebvh/tools/rays.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using spacebvh::testing_support::Cli;
using spacebvh::testing_support::CliResult;
using spacebvh::testing_support::has_png_signature;

namespace {

class TreeFileCli : public Cli {};

}  // namespace

// A saved tree traced with --tree gives hit files identical to those of the same builder building
// anew, for closest hits and occlusion; trace reports the load.
TEST_F(TreeFileCli, SavedTreeTracesLikeTheBuiltOne) {
    ASSERT_EQ(run("rays builtin:organic --kind random --count 3000 -o r.bin").exit_code, 0);
    CliResult r = run("build builtin:organic --builder spatial --no-epo --save t.sbvh --json b.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("saved            t.sbvh"), std::string::npos) << r.output;
    EXPECT_EQ(read_json("b.json")["saved"], "t.sbvh");
    for (const std::string occlusion : {"", " --occlusion"}) {
        r = run("trace builtin:organic --rays r.bin --hits built.bin --builder spatial" + occlusion);
        ASSERT_EQ(r.exit_code, 0) << r.output;
        r = run("trace builtin:organic --rays r.bin --hits loaded.bin --tree t.sbvh --json t.json" + occlusion);
        ASSERT_EQ(r.exit_code, 0) << r.output;
        EXPECT_NE(r.output.find("builder spatial"), std::string::npos) << r.output;
        EXPECT_NE(r.output.find("tree loaded from t.sbvh"), std::string::npos) << r.output;
        EXPECT_TRUE(read_json("t.json").contains("tree_load_ms"));
        EXPECT_EQ(read_hit_file(path("built.bin")).size(), 3000u);
        EXPECT_EQ(read("built.bin"), read("loaded.bin")) << occlusion;
    }
}

// render --tree writes the picture; compare --tree measures the saved tree against Embree (its rows
// replace the builder rows unless --builders is given) without a wrong answer.
TEST_F(TreeFileCli, RenderAndCompareWithASavedTree) {
    ASSERT_EQ(run("build builtin:organic --builder binned --no-epo --save t.sbvh").exit_code, 0);
    CliResult r = run("render builtin:organic --tree t.sbvh -o a.png --width 32 --height 24");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(has_png_signature(read("a.png")));

    const std::string common =
        "builtin:organic --tree t.sbvh --random 2000 --width 16 --height 16 --runs 1 "
        "--build-runs 1 --no-epo --embree medium --embree-packets none";
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(compare_rows(common, 2, rows));
    EXPECT_EQ(rows[0]["builder"], "t.sbvh: binned (C_o=0.00)");
    EXPECT_EQ(rows[1]["builder"], "embree-medium");
    for (const auto& row : rows)
        for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(row[kind]["wrong"], 0) << row.dump();
    ASSERT_NO_FATAL_FAILURE(compare_rows(common + " --builders cbvh", 3, rows));
    EXPECT_EQ(rows[0]["builder"], "t.sbvh: binned (C_o=0.00)");
    EXPECT_EQ(rows[1]["builder"].get<std::string>().rfind("cbvh", 0), 0u) << rows.dump();
}

// Another scene (or transform), a damaged, truncated or missing file, --tree with --builder, and
// compare --tree over several scenes: clean failures naming the problem.
TEST_F(TreeFileCli, BadTreeFilesFailCleanly) {
    ASSERT_EQ(run("build builtin:organic --no-epo --save t.sbvh").exit_code, 0);
    ASSERT_EQ(run("rays builtin:organic --count 100 -o r.bin").exit_code, 0);
    const std::string trace = "trace builtin:organic --rays r.bin --hits h.bin ";
    expect_clean_failure("trace builtin:soup --rays r.bin --hits h.bin --tree t.sbvh", {"t.sbvh", "other geometry"});
    expect_clean_failure(trace + "--tree t.sbvh --scale 2", {"t.sbvh", "other geometry"});
    std::string bytes = read("t.sbvh");
    bytes[bytes.size() / 2] ^= 0x10;
    write("bad.sbvh", bytes);
    expect_clean_failure(trace + "--tree bad.sbvh", {"bad.sbvh", "corrupt"});
    write("short.sbvh", read("t.sbvh").substr(0, 500));
    expect_clean_failure(trace + "--tree short.sbvh", {"short.sbvh", "truncated"});
    expect_clean_failure(trace + "--tree missing.sbvh", {"missing.sbvh"});
    expect_clean_failure("render builtin:organic -o a.png --tree r.bin", {"r.bin", "not a spacebvh tree file"});
    expect_clean_failure(trace + "--tree t.sbvh --builder binned", {"--tree", "--builder"});
    expect_clean_failure("compare builtin:organic builtin:soup --tree t.sbvh", {"--tree", "one scene"});
}

// An instanced scene: build --save writes a scene file, and --tree loads it in place of building:
// trace gives the hit files of a fresh build byte for byte (two kernels, closest hits and occlusion),
// render and compare take it (compare finds no wrong answer against Embree), info prints what it holds.
TEST_F(TreeFileCli, SavedSceneTracesLikeTheBuiltOne) {
    const std::string forest = "builtin:forest:12";
    write_ray_file(path("r.bin"), generate_random_rays(load_instanced_scene(forest).bounds(), 2000, 5));
    CliResult r = run("build " + forest + " --builder spatial --save s.sbvh");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const std::string kernel : {"bvh8", "binary"})
        for (const std::string occlusion : {"", " --occlusion"}) {
            SCOPED_TRACE(kernel + occlusion);
            const std::string trace = "trace " + forest + " --rays r.bin --kernel " + kernel + occlusion;
            r = run(trace + " --hits built.bin --builder spatial");
            ASSERT_EQ(r.exit_code, 0) << r.output;
            r = run(trace + " --hits loaded.bin --tree s.sbvh --json t.json");
            ASSERT_EQ(r.exit_code, 0) << r.output;
            EXPECT_NE(r.output.find("scene loaded from s.sbvh"), std::string::npos) << r.output;
            EXPECT_TRUE(read_json("t.json").contains("tree_load_ms"));
            size_t hits = 0;
            for (const HitRecord& record : read_hit_file(path("built.bin"))) hits += record.is_hit();
            EXPECT_GT(hits, 100u);
            EXPECT_EQ(read("built.bin"), read("loaded.bin"));
        }
    r = run("render " + forest + " --tree s.sbvh -o a.png --width 32 --height 24");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(has_png_signature(read("a.png")));
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(compare_rows(forest + " --tree s.sbvh --random 1000 --width 16 --height 16 --runs 1 "
                                                  "--build-runs 1 --embree medium --embree-packets none",
                                         2, rows));
    EXPECT_EQ(rows[0]["builder"], "s.sbvh");
    for (const auto& row : rows)
        for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(row[kind]["wrong"], 0) << row.dump();
    r = run("info s.sbvh --json i.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(read_json("i.json")["instances"], 12);
    EXPECT_GT(read_json("i.json")["triangles"].get<uint64_t>(), 0u);
}

// A one-mesh tree file for an instanced scene and a scene file for one mesh, a scene file of another
// scene or transform, and a damaged one: clean failures naming the file.
TEST_F(TreeFileCli, SceneAndMeshTreeFilesAreNotInterchangeable) {
    ASSERT_EQ(run("build builtin:organic --no-epo --save t.sbvh").exit_code, 0);
    ASSERT_EQ(run("build builtin:forest:12 --save s.sbvh").exit_code, 0);
    ASSERT_EQ(run("rays builtin:organic --count 100 -o r.bin").exit_code, 0);
    const std::string forest = "trace builtin:forest:12 --rays r.bin --hits h.bin ";
    expect_clean_failure(forest + "--tree t.sbvh", {"t.sbvh", "not a scene file"});
    expect_clean_failure("render builtin:forest:12 -o a.png --tree t.sbvh", {"t.sbvh", "not a scene file"});
    expect_clean_failure("trace builtin:organic --rays r.bin --hits h.bin --tree s.sbvh", {"s.sbvh", "scene file"});
    expect_clean_failure("trace builtin:forest:13 --rays r.bin --hits h.bin --tree s.sbvh",
                         {"s.sbvh", "not a scene file of"});
    expect_clean_failure(forest + "--tree s.sbvh --translate 5 0 0", {"s.sbvh", "world box"});
    std::string bytes = read("s.sbvh");
    bytes[bytes.size() / 2] ^= 0x10;
    write("bad.sbvh", bytes);
    expect_clean_failure(forest + "--tree bad.sbvh", {"bad.sbvh", "corrupt"});
    expect_clean_failure("compare builtin:forest:12 --tree missing.sbvh --runs 1", {"missing.sbvh"});
}
