// SPDX-License-Identifier: MIT
// The `spacebvh` command-line tool (apps/spacebvh), run as a separate process in a temporary
// directory: help, every subcommand on a builtin scene, the files it writes (JSON, ray and hit files,
// PNG), and clean failures (exit code 1 or 2 with a message naming the problem, never a crash).
#include <gtest/gtest.h>

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>

#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/verify.hpp"
#include "cli_support.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
namespace fs = std::filesystem;
using spacebvh::testing_support::Cli;
using spacebvh::testing_support::CliResult;
using spacebvh::testing_support::has_png_signature;

namespace {

const char* kSubcommands[] = {"info", "build", "rays", "trace", "render", "compare", "optimum"};

// Width and height from the IHDR chunk (big-endian, right after the signature and chunk header).
std::pair<uint32_t, uint32_t> png_size(const std::string& bytes) {
    auto be32 = [&](size_t at) {
        const auto* p = reinterpret_cast<const unsigned char*>(bytes.data()) + at;
        return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]);
    };
    if (bytes.size() < 24 || bytes.compare(12, 4, "IHDR") != 0) return {0, 0};
    return {be32(16), be32(20)};
}

}  // namespace

// --help and every subcommand's --help succeed and describe the tool.
TEST_F(Cli, HelpForTheToolAndEverySubcommand) {
    const CliResult top = run("--help");
    EXPECT_EQ(top.exit_code, 0) << top.output;
    for (const char* sub : kSubcommands) EXPECT_NE(top.output.find(sub), std::string::npos) << sub;
    for (const char* sub : kSubcommands) {
        const CliResult r = run(std::string(sub) + " --help");
        EXPECT_EQ(r.exit_code, 0) << sub << ":\n" << r.output;
        EXPECT_NE(r.output.find("Usage"), std::string::npos) << sub << ":\n" << r.output;
    }
    // The build help lists every builder.
    const CliResult build_help = run("build --help");
    for (const std::string& name : builder_names()) EXPECT_NE(build_help.output.find(name), std::string::npos) << name;
}

// `info` prints the scene's triangle count, and its JSON says the same.
TEST_F(Cli, InfoOnABuiltinScene) {
    const CliResult r = run("info builtin:soup --json info.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("30000"), std::string::npos) << r.output;
    const nlohmann::json json = read_json("info.json");
    EXPECT_EQ(json["triangles"], 30000);
    EXPECT_EQ(json["scene"], "soup");
    EXPECT_GT(json["diagonal"].get<double>(), 0.0);
}

// A scene file's camera comes from the manifest the caller names (--manifest, else SPACEBVH_SCENE_MANIFEST), never
// from a file found beside the scene; a named manifest that cannot be read is an error.
TEST_F(Cli, CameraFromTheNamedManifestOnly) {
    fs::create_directories(path("scenes/thing"));
    write("scenes/thing/thing.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write("scenes/MANIFEST.md", "| scene | camera |\n|---|---|\n| thing | `0,0,5,0,0,0,0,1,0,50` |\n");
    const std::string listed = "camera      0,0,5,0,0,0,0,1,0,50";
    const CliResult unnamed = run("info scenes/thing/thing.obj");
    ASSERT_EQ(unnamed.exit_code, 0) << unnamed.output;
    EXPECT_EQ(unnamed.output.find(listed), std::string::npos) << unnamed.output;
    const CliResult named = run("info scenes/thing/thing.obj --manifest scenes/MANIFEST.md");
    ASSERT_EQ(named.exit_code, 0) << named.output;
    EXPECT_NE(named.output.find(listed), std::string::npos) << named.output;
    setenv("SPACEBVH_SCENE_MANIFEST", path("scenes/MANIFEST.md").c_str(), 1);
    const CliResult from_environment = run("info scenes/thing/thing.obj");
    unsetenv("SPACEBVH_SCENE_MANIFEST");
    ASSERT_EQ(from_environment.exit_code, 0) << from_environment.output;
    EXPECT_NE(from_environment.output.find(listed), std::string::npos) << from_environment.output;
    // rays takes the camera the same way: the same primary rays as with --camera.
    ASSERT_EQ(run("rays scenes/thing/thing.obj --kind primary --width 4 --height 3 -o named.rays "
                  "--manifest scenes/MANIFEST.md")
                  .exit_code,
              0);
    ASSERT_EQ(run("rays scenes/thing/thing.obj --kind primary --width 4 --height 3 -o given.rays "
                  "--camera 0,0,5,0,0,0,0,1,0,50")
                  .exit_code,
              0);
    EXPECT_EQ(read("named.rays"), read("given.rays"));
    const CliResult absent = run("info scenes/thing/thing.obj --manifest scenes/ABSENT.md");
    EXPECT_EQ(absent.exit_code, 1) << absent.output;
    EXPECT_NE(absent.output.find("ABSENT.md"), std::string::npos) << absent.output;
}

// `build --json` writes the tree's metrics, consistent with each other and with the scene.
TEST_F(Cli, BuildWritesConsistentJson) {
    const CliResult r = run("build builtin:soup --builder cbvh --json out.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json json = read_json("out.json");
    EXPECT_EQ(json["scene"], "soup");
    EXPECT_EQ(json["triangles"], 30000);
    EXPECT_EQ(json["builder"], "cbvh");
    const size_t nodes = json["nodes"], leaves = json["leaves"];
    EXPECT_EQ(nodes, 2 * leaves - 1);
    EXPECT_EQ(json["references"], 30000);  // cbvh partitions objects: one reference per triangle
    EXPECT_EQ(json["distinct_primitives"], 30000);
    EXPECT_GT(json["max_depth"].get<int>(), 5);
    EXPECT_GT(json["sah"].get<double>(), 0.0);
    EXPECT_GE(json["epo"].get<double>(), 0.0);
    EXPECT_GT(json["bytes"].get<double>(), 0.0);
    EXPECT_GT(json["layout_bytes"].get<double>(), 0.0);
    EXPECT_EQ(json["cost"]["C_T"], 1.0);
    EXPECT_EQ(json["cost"]["C_I"], 1.0);
    EXPECT_EQ(json["lookahead_depth"], 0);
    // Peak memory: at least the scene, below the machine's physical memory.
    const double physical_bytes = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
    EXPECT_GT(json["peak_rss_bytes"].get<double>(), 30000.0 * sizeof(Triangle));
    EXPECT_LT(json["peak_rss_bytes"].get<double>(), physical_bytes);
    EXPECT_NE(r.output.find("peak memory"), std::string::npos) << r.output;
    // The same tree built in-process gives the same node count.
    const Scene scene = load_scene("builtin:soup");
    EXPECT_EQ(nodes, spacebvh::build(scene, config_for("cbvh")).nodes.size());
}

// --quality picks the tree spacebvh::build(mesh, Quality) builds, and excludes --builder and --tree.
TEST_F(Cli, QualityLevelsAreTheLibrarys) {
    const Scene scene = load_scene("builtin:soup");
    for (const std::string& level : quality_names()) {
        const CliResult r = run("build builtin:soup --quality " + level + " --no-epo --json q.json");
        ASSERT_EQ(r.exit_code, 0) << r.output;
        const nlohmann::json json = read_json("q.json");
        const Bvh bvh = spacebvh::build(scene, parse_quality(level));
        EXPECT_EQ(json["builder"], bvh.builder) << level;
        EXPECT_EQ(json["nodes"].get<size_t>(), bvh.nodes.size()) << level;
        EXPECT_EQ(json["references"].get<size_t>(), bvh.primitives.size()) << level;
    }
    expect_clean_failure("build builtin:soup --quality best", {"--quality"});
    expect_clean_failure("build builtin:soup --quality fast --builder cbvh", {"--quality"});
}

// The overlap penalty is reported as a number (or "inf"), not as the whole cost description.
TEST_F(Cli, BuildJsonReportsTheOverlapPenaltyItself) {
    ASSERT_EQ(run("build builtin:soup --builder binned --no-epo --co 0.5 --json half.json").exit_code, 0);
    const nlohmann::json half = read_json("half.json");
    ASSERT_TRUE(half["cost"].contains("C_o"));
    EXPECT_TRUE(half["cost"]["C_o"].is_number()) << half["cost"]["C_o"];
    if (half["cost"]["C_o"].is_number()) {
        EXPECT_EQ(half["cost"]["C_o"].get<double>(), 0.5);
    }
    ASSERT_EQ(run("build builtin:soup --builder binned --no-epo --co inf --json inf.json").exit_code, 0);
    const nlohmann::json inf = read_json("inf.json");
    EXPECT_TRUE(inf["cost"]["C_o"] == "inf" || inf["cost"]["C_o"].is_null()) << inf["cost"]["C_o"];
}

// `rays` writes the spec's random rays; `trace` answers them (closest hit and occlusion) as the
// arbiter does, and as the library does in-process.
TEST_F(Cli, RaysThenTraceMatchTheArbiter) {
    CliResult r = run("rays builtin:soup --kind random --count 1000 -o r.bin");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const Scene scene = load_scene("builtin:soup");
    const std::vector<Ray> rays = read_ray_file(path("r.bin"));
    const std::vector<Ray> expected = generate_random_rays(scene.bounds(), 1000, 1);
    ASSERT_EQ(rays.size(), 1000u);
    EXPECT_EQ(std::memcmp(rays.data(), expected.data(), rays.size() * sizeof(Ray)), 0);

    r = run("trace builtin:soup --rays r.bin --hits h.bin");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = run("trace builtin:soup --rays r.bin --hits o.bin --occlusion --stats --json t.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::vector<HitRecord> hits = read_hit_file(path("h.bin"));
    const std::vector<HitRecord> occlusion = read_hit_file(path("o.bin"));
    ASSERT_EQ(hits.size(), rays.size());
    ASSERT_EQ(occlusion.size(), rays.size());

    const float diagonal = scene.diagonal();
    size_t wrong = 0, hit_count = 0;
    for (size_t i = 0; i < 200; ++i) {
        const HitRecord truth = arbiter_closest_hit(scene, rays[i]);
        hit_count += truth.is_hit();
        wrong += !hits_agree(hits[i], truth, rays[i], diagonal);
        wrong += !hits_agree(occlusion[i], arbiter_occlusion(scene, rays[i]), rays[i], diagonal);
        wrong += occlusion[i].is_hit() && occlusion[i].t != 0.0f;  // occluded: t = 0
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(hit_count, 20u);

    // All 1000 records equal the library's own answers with the default builder.
    const Tracer tracer(scene, spacebvh::build(scene, BuildConfig{}), Kernel::binary);
    size_t different = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const HitRecord mine = to_record(tracer.intersect(rays[i]));
        different += mine.t != hits[i].t || mine.primitive != hits[i].primitive;
        different += tracer.occluded(rays[i]) != occlusion[i].is_hit();
    }
    EXPECT_EQ(different, 0u);
    const nlohmann::json json = read_json("t.json");
    EXPECT_EQ(json["rays"], 1000);
    EXPECT_GT(json["nodes_per_ray"].get<double>(), 0.0);
}

// Primary and diffuse ray files have the expected counts.
TEST_F(Cli, PrimaryAndDiffuseRays) {
    ASSERT_EQ(run("rays builtin:interior --kind primary --width 32 --height 24 -o p.bin").exit_code, 0);
    const Scene scene = load_scene("builtin:interior");
    const std::vector<Ray> primary = read_ray_file(path("p.bin"));
    const std::vector<Ray> expected = generate_primary_rays(camera_for_scene(scene, "builtin:interior", {}), 32, 24);
    ASSERT_EQ(primary.size(), 768u);
    EXPECT_EQ(std::memcmp(primary.data(), expected.data(), primary.size() * sizeof(Ray)), 0);
    const CliResult r = run("rays builtin:interior --kind diffuse --width 32 --height 24 -o d.bin");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::vector<Ray> diffuse = read_ray_file(path("d.bin"));
    EXPECT_GT(diffuse.size(), 700u);  // inside the hall almost every primary ray hits
    EXPECT_LE(diffuse.size(), 768u);
}

// `render` writes PNG files of the requested size, shaded and as a heat map (with its legend below).
TEST_F(Cli, RenderWritesPngFiles) {
    CliResult r = run("render builtin:soup -o a.png --width 64 --height 48");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string shaded = read("a.png");
    ASSERT_TRUE(has_png_signature(shaded));
    EXPECT_EQ(png_size(shaded), std::make_pair(64u, 48u));

    r = run("render builtin:soup -o h.png --width 64 --height 48 --heatmap");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string heat = read("h.png");
    ASSERT_TRUE(has_png_signature(heat));
    const auto [width, height] = png_size(heat);
    EXPECT_EQ(width, 64u);
    EXPECT_GE(height, 48u);
    EXPECT_NE(shaded, heat);
}

// `compare` runs every row on a small ray set; our builders and Embree answer without a wrong ray.
TEST_F(Cli, CompareWritesRowsWithoutWrongAnswers) {
    // --no-epo: EPO costs seconds per builder on the soup (BuildWritesConsistentJson covers it).
    const CliResult r =
        run("compare builtin:soup --random 2000 --width 32 --height 32 --runs 1 --build-runs 1 --no-epo --json c.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json json = read_json("c.json");
    ASSERT_EQ(json["scenes"].size(), 1u);
    const nlohmann::json& scene = json["scenes"][0];
    EXPECT_EQ(scene["triangles"], 30000);
    EXPECT_EQ(scene["rays"]["random"], 2000);
    EXPECT_EQ(scene["rays"]["primary"], 1024);
    // Row names may carry details after the name ("cbvh (C_o=0.00)"): match by prefix.
    auto find_row = [&](const std::string& name) -> const nlohmann::json* {
        for (const nlohmann::json& row : scene["rows"]) {
            const std::string label = row["builder"];
            if (label == name || label.rfind(name + " ", 0) == 0 || label.rfind(name + "@", 0) == 0) return &row;
        }
        return nullptr;
    };
    for (const char* name : {"cbvh", "binned", "embree-low", "embree-medium", "embree-high"}) {
        const nlohmann::json* row = find_row(name);
        ASSERT_NE(row, nullptr) << "no row for " << name << " in " << scene["rows"].dump();
        for (const char* kind : {"random", "primary", "diffuse"}) {
            ASSERT_TRUE((*row)[kind].contains("wrong")) << name << " " << kind;
            if (std::string(name).rfind("embree-", 0) != 0) {
                EXPECT_EQ((*row)[kind]["wrong"], 0) << name << " " << kind;
                EXPECT_GT((*row)[kind]["nodes_per_ray"].get<double>(), 0.0) << name << " " << kind;
                EXPECT_GT((*row)[kind]["occlusion_nodes_per_ray"].get<double>(), 0.0) << name << " " << kind;
            }
            EXPECT_GT((*row)[kind]["closest_mrays"].get<double>(), 0.0) << name << " " << kind;
        }
        EXPECT_GT((*row)["peak_rss_bytes"].get<double>(), 0.0) << name;
    }
    EXPECT_GE(json["peak_rss_bytes"].get<double>(), scene["rows"][0]["peak_rss_bytes"].get<double>());
}

// `--runs 0` (the soak's answers-only pass): one timed pass per measurement, no work-per-ray pass, and
// every row's answers, Embree's tiled packets included, still checked ray for ray.
TEST_F(Cli, CompareAnswersOnlyChecksEveryRow) {
    const CliResult r =
        run("compare builtin:soup --builders cbvh --kernel bvh8,packet8 --embree high --embree-packets high "
            "--random 2000 --width 32 --height 32 --runs 0 --build-runs 1 --no-epo --json a.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json rows = read_json("a.json")["scenes"][0]["rows"];
    ASSERT_EQ(rows.size(), 4u) << rows.dump();
    for (const nlohmann::json& row : rows) {
        const std::string name = row["builder"];
        for (const char* kind : {"random", "primary", "diffuse"}) {
            const nlohmann::json& k = row[kind];
            EXPECT_EQ(k["closest_ms_runs"].size(), 1u) << name << " " << kind;
            EXPECT_EQ(k["occlusion_ms_runs"].size(), 1u) << name << " " << kind;
            EXPECT_GT(k["closest_mrays"].get<double>(), 0.0) << name << " " << kind;
            EXPECT_FALSE(k.contains("nodes_per_ray") || k.contains("occlusion_nodes_per_ray")) << name << " " << kind;
            ASSERT_TRUE(k.contains("wrong")) << name << " " << kind;
            if (name.rfind("embree-", 0) != 0) {
                EXPECT_EQ(k["wrong"], 0) << name << " " << kind;
            }
        }
    }
    expect_clean_failure("compare builtin:soup --runs -1", {"--runs"});
}

// SPACEBVH_EMBREE_CONFIG reaches Embree's device: "verbose=3" makes Embree print the statistics of
// the BVH it builds for the Embree row (its SAH line); without it, Embree stays silent.
TEST_F(Cli, EmbreeConfigFromEnvironment) {
    const std::string args =
        "compare builtin:soup --builders cbvh --kernel bvh8 --embree high --embree-packets none "
        "--random 500 --width 16 --height 16 --runs 1 --build-runs 1 --no-epo --no-verify -q";
    // The child inherits the test's environment.
    setenv("SPACEBVH_EMBREE_CONFIG", "verbose=3", 1);
    const CliResult verbose = run(args);
    unsetenv("SPACEBVH_EMBREE_CONFIG");
    ASSERT_EQ(verbose.exit_code, 0) << verbose.output;
    EXPECT_NE(verbose.output.find("sah ="), std::string::npos) << verbose.output;
    const CliResult quiet = run(args);
    ASSERT_EQ(quiet.exit_code, 0) << quiet.output;
    EXPECT_EQ(quiet.output.find("sah ="), std::string::npos) << quiet.output;
}

// `--lookahead` and `NAME@lookahead=D` build by recursive cost evaluation; the trees answer correctly.
TEST_F(Cli, LookaheadInBuildAndCompare) {
    const CliResult build = run("build builtin:soup --builder cbvh --lookahead 1 --no-epo --json l.json");
    ASSERT_EQ(build.exit_code, 0) << build.output;
    EXPECT_EQ(read_json("l.json")["lookahead_depth"], 1);
    EXPECT_NE(build.output.find("lookahead 1"), std::string::npos) << build.output;
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(
        compare_rows("builtin:soup --builders 'cbvh,cbvh@lookahead=1;candidates=1' --embree medium "
                     "--embree-packets none --random 2000 --width 32 --height 32 --runs 1 --build-runs 1 --no-epo",
                     3, rows));
    EXPECT_EQ(rows[1]["builder"].get<std::string>().rfind("cbvh@lookahead=1;candidates=1", 0), 0u) << rows[1];
    for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(rows[1][kind]["wrong"], 0) << kind;
    expect_clean_failure("build builtin:soup --lookahead 99 --no-epo", {"lookahead"});
    expect_clean_failure("build builtin:soup --lookahead 1 --lookahead-candidates 0 --no-epo", {"candidates"});
    expect_clean_failure("build builtin:soup --builder embree-high --lookahead 1 --no-epo", {"lookahead"});
    expect_clean_failure("compare builtin:soup --builders 'cbvh@lookahead=-1'", {"lookahead"});
}

// `--lookahead-top S` and `NAME@top=S`: nodes with at least that share of the references look ahead
// to the leaves; the setting is reported, the trees answer correctly, absurd shares are refused.
TEST_F(Cli, LookaheadTopInBuildAndCompare) {
    const CliResult build = run("build builtin:soup --builder spatial --lookahead-top 0.5 --no-epo --json t.json");
    ASSERT_EQ(build.exit_code, 0) << build.output;
    EXPECT_FLOAT_EQ(read_json("t.json")["lookahead_top_share"].get<float>(), 0.5f);
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(
        compare_rows("builtin:soup --builders 'spatial,spatial@top=0.5' --embree medium "
                     "--embree-packets none --random 2000 --width 32 --height 32 --runs 1 --build-runs 1 --no-epo",
                     3, rows));
    EXPECT_EQ(rows[1]["builder"].get<std::string>().rfind("spatial@top=0.5", 0), 0u) << rows[1];
    EXPECT_LE(rows[1]["sah"].get<double>(), rows[0]["sah"].get<double>() * (1 + 1e-6));
    for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(rows[1][kind]["wrong"], 0) << kind;
    expect_clean_failure("build builtin:soup --builder spatial --lookahead-top 2 --no-epo",
                         {"lookahead top share", "got 2"});
    expect_clean_failure("build builtin:soup --builder embree-high --lookahead-top 0.5 --no-epo", {"lookahead"});
    expect_clean_failure("compare builtin:soup --builders 'spatial@top=0.001'", {"lookahead top share"});
}

// A compare row's own settings mean what the build flags of the same name mean: `bins=` is `--bins`
// (the binned object search space), `spatialbins=` is `--spatial-bins`. Each row's tree has the
// SAH that `build` gives with the flag, and differs from the default tree.
TEST_F(Cli, CompareRowBinsAreTheBuildFlags) {
    auto built_sah = [&](const std::string& flags) {
        const CliResult r = run("build builtin:interior " + flags + " --no-epo --json b.json");
        EXPECT_EQ(r.exit_code, 0) << r.output;
        return read_json("b.json")["sah"].get<double>();
    };
    const double binned = built_sah("--builder binned"), binned4 = built_sah("--builder binned --bins 4");
    const double kdbvh = built_sah("--builder kdbvh"), kdbvh4 = built_sah("--builder kdbvh --spatial-bins 4");
    ASSERT_NE(binned, binned4);
    ASSERT_NE(kdbvh, kdbvh4);
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(
        compare_rows("builtin:interior --builders 'binned@bins=4,kdbvh@spatialbins=4,binned@spatialbins=4' "
                     "--embree none --embree-packets none --random 1000 --width 16 --height 16 --runs 1 "
                     "--build-runs 1 --no-epo",
                     3, rows));
    EXPECT_DOUBLE_EQ(rows[0]["sah"].get<double>(), binned4) << rows[0];
    EXPECT_DOUBLE_EQ(rows[1]["sah"].get<double>(), kdbvh4) << rows[1];
    EXPECT_DOUBLE_EQ(rows[2]["sah"].get<double>(), binned) << rows[2];  // binned has no spatial search space
    expect_clean_failure("compare builtin:soup --builders 'binned@bins=1'", {"bins"});
    expect_clean_failure("compare builtin:soup --builders 'binned@objbins=8'", {"objbins", "spatialbins"});
}

// `--optimize`, `--optimize-iterations`, `NAME+opt` and `NAME@optimize=N`: the reinsertion optimiser
// after the build; the tree's name and the compare rows say "+opt", the SAH is lower, answers stay right.
TEST_F(Cli, OptimizeInBuildAndCompare) {
    ASSERT_EQ(run("build builtin:soup --builder binned --no-epo --json plain.json").exit_code, 0);
    const CliResult build = run("build builtin:soup --builder binned --optimize --no-epo --json o.json");
    ASSERT_EQ(build.exit_code, 0) << build.output;
    const nlohmann::json plain = read_json("plain.json"), optimized = read_json("o.json");
    EXPECT_EQ(optimized["builder"], "binned+opt");
    EXPECT_EQ(optimized["reinsertion_iterations"], kDefaultReinsertionIterations);
    EXPECT_EQ(plain["reinsertion_iterations"], 0);
    EXPECT_LT(optimized["sah"].get<double>(), plain["sah"].get<double>());
    EXPECT_EQ(optimized["nodes"], plain["nodes"]);
    ASSERT_EQ(
        run("build builtin:soup --builder binned+opt --optimize-iterations 3 --no-epo --json three.json").exit_code, 0);
    EXPECT_EQ(read_json("three.json")["reinsertion_iterations"], 3);
    EXPECT_EQ(read_json("three.json")["builder"], "binned+opt");

    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(
        compare_rows("builtin:soup --builders 'binned,binned+opt,cbvh@optimize=2' --embree medium "
                     "--embree-packets none --random 2000 --width 32 --height 32 --runs 1 --build-runs 1 --no-epo",
                     4, rows));
    EXPECT_EQ(rows[0]["builder"].get<std::string>().rfind("binned (", 0), 0u) << rows[0];
    EXPECT_EQ(rows[1]["builder"].get<std::string>().rfind("binned+opt (", 0), 0u) << rows[1];
    EXPECT_EQ(rows[2]["builder"].get<std::string>().rfind("cbvh+opt@optimize=2 (", 0), 0u) << rows[2];
    for (size_t row = 1; row < 3; ++row)
        for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(rows[row][kind]["wrong"], 0) << row << kind;

    expect_clean_failure("build builtin:soup --optimize-iterations 5000 --no-epo", {"reinsertion iterations", "5000"});
    // 0 iterations: no optimisation, as `optimize=0` in a row and in Python.
    ASSERT_EQ(run("build builtin:soup --builder binned --optimize-iterations 0 --no-epo --json zero.json").exit_code,
              0);
    EXPECT_EQ(read_json("zero.json")["builder"], "binned");
    expect_clean_failure("build builtin:soup --optimize-iterations x --no-epo", {"--optimize-iterations"});
    expect_clean_failure("compare builtin:soup --builders 'binned@optimize=x'", {"optimize"});
}

// Ctrl-C during a long build stops it cleanly: exit code 130 and a one-line message, no crash, no
// hang. (--progress: progress lines on the pipe tell when the build is under way.)
TEST_F(Cli, InterruptStopsALongBuildWithExitCode130) {
    const CliResult r = run_and_interrupt(
        {"build", "builtin:interior", "--builder", "spatial", "--lookahead", "2", "--no-epo", "--progress"}, "building",
        120);
    EXPECT_EQ(r.exit_code, 130) << r.output;
    EXPECT_NE(r.output.find("stopped"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("SAH"), std::string::npos) << "the build finished instead:\n" << r.output;
    EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
}

// Bad input fails cleanly with a message naming the problem.
TEST_F(Cli, BadInputFailsCleanly) {
    expect_clean_failure("info does_not_exist.obj", {"does_not_exist.obj"});
    expect_clean_failure("info builtin:nope", {"nope"});
    expect_clean_failure("build builtin:soup --builder nope --no-epo", {"nope"});
    expect_clean_failure("build builtin:soup --co -1 --no-epo", {"C_o"});
    expect_clean_failure("build builtin:soup --co abc --no-epo", {"abc"});
    expect_clean_failure("build builtin:soup --bins 1 --no-epo", {"bins"});
    expect_clean_failure("build builtin:soup --max-leaf 0 --no-epo", {"leaf"});
    expect_clean_failure("build builtin:soup --max-depth 5000 --no-epo", {"depth"});
    expect_clean_failure("info builtin:soup --rotate x:abc", {"x:abc"});
    expect_clean_failure("info builtin:soup --rotate q:45", {"q"});
    expect_clean_failure("render builtin:soup -o x.png --width 0 --height 10", {"width"});
    expect_clean_failure("rays builtin:soup --kind sideways -o r.bin", {"sideways"});

    // A ray file cut off inside a record.
    ASSERT_EQ(run("rays builtin:soup --count 10 -o r.bin").exit_code, 0);
    write("truncated.bin", read("r.bin").substr(0, 100));
    expect_clean_failure("trace builtin:soup --rays truncated.bin --hits h.bin", {"truncated.bin"});
    expect_clean_failure("trace builtin:soup --rays missing.bin --hits h.bin", {"missing.bin"});
    // An OBJ file with a NaN coordinate, and one with a face index out of range.
    write("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
    expect_clean_failure("info nan.obj", {"nan.obj", "2"});
    expect_clean_failure("build nan.obj --no-epo", {"nan.obj"});
    write("bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    expect_clean_failure("info bad_index.obj", {"bad_index.obj"});
    // An unwritable output path.
    expect_clean_failure("rays builtin:soup --count 10 -o no_such_dir/r.bin", {"no_such_dir"});
}

// Usage errors (unknown option, missing argument, unconvertible number) also exit with 1 or 2.
TEST_F(Cli, UsageErrorsExitWithOneOrTwo) {
    expect_clean_failure("build builtin:soup --bogus", {"--bogus"});
    expect_clean_failure("build", {"scene"});
    expect_clean_failure("", {"subcommand"});
    expect_clean_failure("build builtin:soup --max-leaf -1", {"max-leaf"});
    expect_clean_failure("frobnicate", {"frobnicate"});
}

// --threads 0 means all cores; explicit thread counts work too.
TEST_F(Cli, ThreadOptions) {
    for (const char* threads : {"0", "1", "2"}) {
        const CliResult r = run(std::string("build builtin:soup --no-epo --threads ") + threads);
        EXPECT_EQ(r.exit_code, 0) << threads << ":\n" << r.output;
        EXPECT_NE(r.output.find("nodes"), std::string::npos) << r.output;
    }
}

// `optimum` compares every search space with the exhaustive optimum; no object-partitioning search
// space is ever below it (their "below" column is 0). --search builds any union; bad names fail cleanly.
TEST_F(Cli, OptimumReportAndSearchSpaceUnions) {
    const CliResult r = run("optimum --nodes 12 --min-refs 6 --max-refs 10 --co inf --json optimum.json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("object (cbvh sweep)"), std::string::npos) << r.output;
    const nlohmann::json json = read_json("optimum.json");
    for (const char* space : {"object (cbvh sweep)", "binned", "grid, no splitting"}) {
        EXPECT_EQ(json["random"]["search_spaces"][space]["below_optimum"], 0) << space;
        EXPECT_GE(json["random"]["search_spaces"][space]["mean_ratio"].get<double>(), 1.0) << space;
    }
    // With C_o = inf a node whose every partition overlaps has no feasible optimum and is left out.
    EXPECT_GE(json["random"]["nodes"].get<int>(), 6);
    EXPECT_LE(json["random"]["nodes"].get<int>(), 12);
    const CliResult union_build =
        run("build builtin:soup --builder cbvh --search object,grid --co 0.5 --no-epo --quiet");
    EXPECT_EQ(union_build.exit_code, 0) << union_build.output;
    expect_clean_failure("build builtin:soup --search object,kd --no-epo", {"kd"});
    expect_clean_failure("build builtin:soup --grid-max 40 --no-epo", {"grid max"});
}
