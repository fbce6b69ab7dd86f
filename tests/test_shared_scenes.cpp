// SPDX-License-Identifier: MIT
// Every builder on the real scenes of ../shared/scenes (MANIFEST.md), against Embree with the exact
// arbiter settling every disagreement (docs/rays.md): 20k random rays, 20k primary rays from
// the MANIFEST camera (160 x 125) and the diffuse rays from those primary hits. Skipped when the
// shared scenes are not present.
#include <gtest/gtest.h>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <ostream>
#include <string>
#include <tuple>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/verify.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

struct SharedScene {
    const char* key;     // test name
    const char* stem;    // scenes/<stem>/<stem>.obj
    const char* rotate;  // load-time rotation ("" = none)
};

const SharedScene kSharedScenes[] = {
    {"bunny", "bunny", ""},
    {"sibenik", "sibenik", ""},
    {"coffee_maker", "coffee_maker", ""},
    {"crytek_sponza", "crytek_sponza", ""},
    {"living_room_3", "living_room_3", ""},
    {"crytek_sponza_rotated", "crytek_sponza", "x:45,y:45,z:45"},  // the classic "rotated Sponza"
};

void PrintTo(const SharedScene& s, std::ostream* out) { *out << s.key; }

std::string scene_path(const SharedScene& s) {
    return std::string(SPACEBVH_SHARED_DIR) + "/scenes/" + s.stem + "/" + s.stem + ".obj";
}

SceneTransform transform_of(const SharedScene& s) {
    SceneTransform transform;
    if (*s.rotate) transform.rotate_degrees = SceneTransform::parse_rotation(s.rotate);
    return transform;
}

const char* kKindNames[3] = {"random", "primary", "diffuse"};

// A loaded shared scene with its three ray sets and Embree's (medium) answers.
struct Case {
    Scene scene;
    std::vector<Ray> rays[3];
    std::vector<HitRecord> embree_closest[3], embree_occlusion[3];
};

Case load_case(const SharedScene& s) {
    Case c;
    const std::string path = scene_path(s);
    const SceneTransform transform = transform_of(s);
    c.scene = load_scene(path, transform);
    const EmbreeScene embree(c.scene, EmbreeQuality::medium);
    c.rays[0] = generate_random_rays(c.scene.bounds(), 20000, 1);
    const std::string manifest = std::string(SPACEBVH_SHARED_DIR) + "/scenes/MANIFEST.md";
    c.rays[1] = generate_primary_rays(camera_for_scene(c.scene, path, transform, manifest), 160, 125);
    std::vector<Hit> primary_hits(c.rays[1].size());
    embree.intersect(c.rays[1], primary_hits);
    c.rays[2] = generate_diffuse_rays(c.scene, c.rays[1], primary_hits, 1);
    for (int k = 0; k < 3; ++k) {
        const size_t n = c.rays[k].size();
        std::vector<Hit> hits(n);
        std::vector<uint8_t> occluded(n);
        embree.intersect(c.rays[k], hits);
        embree.occluded(c.rays[k], occluded);
        c.embree_closest[k].resize(n);
        c.embree_occlusion[k].resize(n);
        for (size_t i = 0; i < n; ++i) {
            c.embree_closest[k][i] = to_record(hits[i]);
            c.embree_occlusion[k][i] = occlusion_record(occluded[i]);
        }
    }
    return c;
}

// Builders too slow for the largest scene within the time budget of the suite: kdbvh and spatial take
// 20-30 s each to build living_room_3 (786k triangles) on 2 cores, so they are not run there (every
// other builder is, cbvh included). They are checked on the other five scenes, rotated Sponza included.
// full (kdbvh's search plus the grid) runs on bunny, sibenik and rotated Sponza only (30-60 s per
// scene on the loaded 2-core machine elsewhere).
bool skipped(const SharedScene& s, const std::string& builder) {
    const std::string key = s.key;
    return builder == "full" && key != "bunny" && key != "sibenik" && key != "crytek_sponza_rotated";
}

std::string sanitize(std::string text) {
    for (char& c : text)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return text;
}

class SharedSceneWithBuilder : public ::testing::TestWithParam<std::tuple<SharedScene, std::string>> {};

std::string case_name(const ::testing::TestParamInfo<std::tuple<SharedScene, std::string>>& info) {
    return sanitize(std::string(std::get<0>(info.param).key) + "_" + std::get<1>(info.param));
}

class SharedSceneOnly : public ::testing::TestWithParam<SharedScene> {};

std::string scene_name(const ::testing::TestParamInfo<SharedScene>& info) { return info.param.key; }

}  // namespace

// Our closest hits and occlusion answers are never wrong, with any kernel; Embree's wrong answers are
// reported.
TEST_P(SharedSceneWithBuilder, AnswersAgreeWithEmbreeAndTheArbiter) {
    const auto& [shared, builder] = GetParam();
    if (!std::filesystem::exists(scene_path(shared))) GTEST_SKIP() << "shared scene not found: " << scene_path(shared);
    if (skipped(shared, builder)) GTEST_SKIP() << builder << " is not run on " << shared.key << " (build time)";
    const Case c = load_case(shared);
    const BuildConfig options = testing_support::options_for_tree(builder);
    const Bvh bvh = spacebvh::build(c.scene, options);
    // Every kernel family on the same tree: the binary reference, both wide layouts and packets.
    for (const char* kernel : {"binary", "bvh4", "bvh8", "packet8"}) {
        const std::unique_ptr<Tracer> tracer = make_tracer(kernel, c.scene, bvh);
        for (int k = 0; k < 3; ++k) {
            SCOPED_TRACE(tracer->name() + ", " + kKindNames[k] + " rays");
            const auto& rays = c.rays[k];
            EXPECT_GE(rays.size(), k == 2 ? 1000u : 20000u);
            const std::vector<HitRecord> closest = testing_support::closest_records(*tracer, rays);
            const std::vector<HitRecord> occlusion = testing_support::occlusion_records(*tracer, rays);
            const VerificationReport closest_report =
                verify_against_reference(c.scene, rays, closest, c.embree_closest[k], false);
            const VerificationReport occlusion_report =
                verify_against_reference(c.scene, rays, occlusion, c.embree_occlusion[k], true);
            EXPECT_EQ(closest_report.ours_wrong, 0u)
                << "closest hit; first wrong ray "
                << (closest_report.wrong_rays.empty() ? 0 : closest_report.wrong_rays[0]);
            EXPECT_EQ(occlusion_report.ours_wrong, 0u)
                << "occlusion; first wrong ray "
                << (occlusion_report.wrong_rays.empty() ? 0 : occlusion_report.wrong_rays[0]);
            if (std::string(kernel) != "binary") continue;
            RecordProperty(std::string("embree_wrong_") + kKindNames[k],
                           std::to_string(closest_report.reference_wrong + occlusion_report.reference_wrong));
            std::printf(
                "[ info ] %s, %s, %s rays: %zu rays, Embree medium wrong on %zu closest + %zu occlusion, ours %zu + "
                "%zu\n",
                shared.key, builder.c_str(), kKindNames[k], rays.size(), closest_report.reference_wrong,
                occlusion_report.reference_wrong, closest_report.ours_wrong, occlusion_report.ours_wrong);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Shared, SharedSceneWithBuilder,
                         ::testing::Combine(::testing::ValuesIn(kSharedScenes), ::testing::ValuesIn(builder_names())),
                         case_name);
// Trees reshaped by the reinsertion optimiser (deeper, other child pairs) through every kernel.
INSTANTIATE_TEST_SUITE_P(Optimized, SharedSceneWithBuilder,
                         ::testing::Combine(::testing::ValuesIn(kSharedScenes), ::testing::Values("binned+opt")),
                         case_name);

// The exact object sweep never gives a worse tree SAH than the binned approximation.
TEST_P(SharedSceneOnly, CbvhTreeSahIsAtMostBinned) {
    const SharedScene& shared = GetParam();
    if (!std::filesystem::exists(scene_path(shared))) GTEST_SKIP() << "shared scene not found: " << scene_path(shared);
    const Scene scene = load_scene(scene_path(shared), transform_of(shared));
    const BuildConfig sweep = config_for("cbvh"), binned = config_for("binned");
    const double sah_cbvh = tree_sah(spacebvh::build(scene, sweep), sweep.cost);
    const double sah_binned = tree_sah(spacebvh::build(scene, binned), binned.cost);
    RecordProperty("sah_cbvh", std::to_string(sah_cbvh));
    RecordProperty("sah_binned", std::to_string(sah_binned));
    std::printf("[ info ] %s: tree SAH cbvh %.4f, binned %.4f\n", shared.key, sah_cbvh, sah_binned);
    EXPECT_GT(sah_cbvh, 0.0);
    EXPECT_LE(sah_cbvh, sah_binned);
}

INSTANTIATE_TEST_SUITE_P(Shared, SharedSceneOnly, ::testing::ValuesIn(kSharedScenes), scene_name);
