// SPDX-License-Identifier: MIT
// The view-independent ray samples (spacebvh/tools/sample_rays.hpp) and the termination-aware split
// choice (BuildConfig::termination): valid trees that answer as the exact arbiter does, the same tree
// for 1 and 2 threads, the plain tree where no node is met by enough segments, and clear errors.
#include <gtest/gtest.h>

#include "cli_support.hpp"
#include "test_support.hpp"

#include <cmath>
#include <cstring>

#include "builders/optimize/reinsertion_optimizer.hpp"
#include "builders/driver/termination_term.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/sample_rays.hpp"
#include "spacebvh/trace.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using namespace spacebvh::testing_support;

namespace {

bool same_rays(const std::vector<Ray>& a, const std::vector<Ray>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(Ray)) == 0);
}

// The termination-aware price of a tree, summed node by node over every segment: each inner node
// costs the segments meeting its box plus `prior` times its area over the root's.
double sampled_price(const Bvh& bvh, const std::vector<Ray>& segments, float prior) {
    double price = 0.0;
    const double root_area = area_in_double(bvh.root().bounds);
    for (const BvhNode& node : bvh.nodes) {
        if (node.is_leaf()) continue;
        price += double(prior) * area_in_double(node.bounds) / root_area;
        for (const Ray& ray : segments) price += builders::segment_meets(builders::SampleSegment::of(ray), node.bounds);
    }
    return price;
}

}  // namespace

TEST(SampleRays, CountSeedAndTraceability) {
    const Scene& scene = cached_builtin_scene("interior");
    const Tracer tracer(scene, spacebvh::build(scene, Quality::fast), Kernel::binary);
    for (const SampleKind kind : {SampleKind::bounce, SampleKind::area}) {
        const std::vector<Ray> rays = generate_sample_rays(kind, scene, tracer, 3000, 5);
        EXPECT_EQ(rays.size(), 3000u) << to_string(kind);
        for (const Ray& ray : rays) ASSERT_EQ(untraceable_ray_reason(ray), nullptr) << to_string(kind);
        EXPECT_TRUE(same_rays(rays, generate_sample_rays(kind, scene, tracer, 3000, 5))) << to_string(kind);
        EXPECT_FALSE(same_rays(rays, generate_sample_rays(kind, scene, tracer, 3000, 6))) << to_string(kind);
        // Every bounce starts on a surface: a closed room's rays leave it only through no wall, so
        // almost every one hits something.
        std::vector<Hit> hits(rays.size());
        tracer.intersect(rays, hits);
        size_t hit_count = 0;
        for (const Hit& hit : hits) hit_count += hit.is_hit();
        EXPECT_GT(hit_count, rays.size() / 2) << to_string(kind);
    }
    EXPECT_EQ(parse_sample_kind("area"), SampleKind::area);
    EXPECT_THROW(parse_sample_kind("camera"), Error);
}

TEST(TerminationSegments, EndAtTheClosestHit) {
    const Scene& scene = cached_builtin_scene("interior");
    const Tracer tracer(scene, spacebvh::build(scene, Quality::fast), Kernel::binary);
    const std::vector<Ray> segments = termination_segments(scene, tracer, 500, 3);
    const std::vector<Ray> rays = generate_sample_rays(SampleKind::bounce, scene, tracer, 500, 3);
    ASSERT_EQ(segments.size(), rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        const Hit hit = tracer.intersect(rays[i]);
        EXPECT_EQ(segments[i].tmax, hit.is_hit() ? hit.t : kInfinity);
    }
}

TEST(TerminationAwareBuild, ValidCorrectDeterministicAndOffBelowTheRayMinimum) {
    const Scene soup = soup_prefix(6000);  // big enough for the parallel subtrees (4096 references)
    const Tracer quick(soup, spacebvh::build(soup, Quality::fast), Kernel::binary);
    for (const char* builder : {"spatial", "cbvh", "binned"}) {
        BuildConfig options = config_for(builder);
        options.termination.segments = termination_segments(soup, quick, 4000, 9);
        const Bvh bvh = build_in_arena(2, soup, options);
        EXPECT_EQ(tree_violations(soup, bvh, options), "") << builder;
        const Tracer tracer(soup, bvh, Kernel::binary);
        EXPECT_EQ(wrong_against_arbiter(soup, tracer, probing_rays(soup, 1500, 17)), "") << builder;
        EXPECT_EQ(first_difference(build_in_arena(1, soup, options), bvh), "") << builder << ": 1 vs 2 threads";
        // No node is met by more segments than there are: the term never applies.
        options.termination.min_rays = uint32_t(options.termination.segments.size()) + 1;
        EXPECT_EQ(first_difference(spacebvh::build(soup, options), spacebvh::build(soup, config_for(builder))), "")
            << builder;
    }
}

TEST(TerminationAwareBuild, BadSegmentsAndSettingsThrow) {
    const Scene& scene = cached_builtin_scene("interior");
    BuildConfig options = config_for("spatial");
    options.termination.segments.resize(3, Ray{{0, 0, 0}, {1, 0, 0}, 0.0f, 1.0f});
    options.termination.segments[2].dir = {0, 0, 0};
    try {
        (void)spacebvh::build(scene, options);
        FAIL() << "a zero direction was accepted";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("termination segment 2"), std::string::npos) << error.what();
    }
    options.termination.segments.resize(2);
    options.termination.candidates = 0;
    EXPECT_THROW((void)spacebvh::build(scene, options), Error);
    options.termination.candidates = 4;
    options.termination.shrinkage = -1.0f;
    EXPECT_THROW((void)spacebvh::build(scene, options), Error);
}

// The reinsertion priced by the segments: the applied gains are the exact fall of the price summed
// over the tree, which never rises (the refit alone only shrinks boxes), with and without the prior.
TEST(TerminationReinsertion, GainsArePricedExactlyAndThePriceNeverRises) {
    const Scene& scene = cached_builtin_scene("interior");
    for (const float prior : {0.0f, 64.0f}) {
        Bvh bvh = spacebvh::build(scene, config_for("spatial"));
        const Tracer tracer(scene, bvh, Kernel::binary);
        const std::vector<Ray> segments = termination_segments(scene, tracer, 3000, 4);
        const double before = sampled_price(bvh, segments, prior);
        builders::ReinsertionOptions options;
        options.iterations = 8;
        options.segments = segments;
        options.area_prior = prior;
        const builders::ReinsertionReport report = builders::optimize_by_reinsertion(bvh, options);
        EXPECT_GT(report.moves, 10u) << prior;
        EXPECT_NEAR(report.inner_area_before, before, 1e-9 * before) << prior;
        EXPECT_LE(report.inner_area_refitted, report.inner_area_before) << prior;
        const double after = sampled_price(bvh, segments, prior);
        EXPECT_NEAR(report.inner_area_after, after, 1e-9 * before) << prior;
        EXPECT_NEAR(report.inner_area_refitted - report.inner_area_after, report.applied_gain, 1e-9 * before) << prior;
        EXPECT_LT(after, before) << prior;
    }
}

TEST(TerminationReinsertion, ValidCorrectDeterministicAndOffWithoutIterations) {
    const Scene soup = soup_prefix(6000);
    for (const char* builder : {"spatial", "cbvh"}) {
        BuildConfig options = config_for(builder);
        const Bvh plain = spacebvh::build(soup, options);
        options.termination.segments = termination_segments(soup, Tracer(soup, plain, Kernel::binary), 4000, 9);
        options.termination.split_choice = false;
        // The segments alone change nothing: the split choice is off and so is the reinsertion.
        EXPECT_EQ(first_difference(spacebvh::build(soup, options), plain), "") << builder;
        options.termination.reinsertion_iterations = 8;
        const Bvh bvh = build_in_arena(2, soup, options);
        EXPECT_EQ(bvh.builder, std::string(builder) + "+topt");
        EXPECT_EQ(tree_violations(soup, bvh, options), "") << builder;
        const Tracer tracer(soup, bvh, Kernel::binary);
        EXPECT_EQ(wrong_against_arbiter(soup, tracer, probing_rays(soup, 1500, 17)), "") << builder;
        EXPECT_EQ(first_difference(build_in_arena(1, soup, options), bvh), "") << builder << ": 1 vs 2 threads";
        EXPECT_LT(sampled_price(bvh, options.termination.segments, 64.0f),
                  sampled_price(plain, options.termination.segments, 64.0f))
            << builder;
    }
}

TEST(TerminationReinsertion, BadSettingsThrow) {
    const Scene& scene = cached_builtin_scene("interior");
    BuildConfig options = config_for("spatial");
    options.termination.segments.resize(2, Ray{{0, 0, 0}, {1, 0, 0}, 0.0f, 1.0f});
    options.termination.reinsertion_iterations = 2;
    for (const float prior : {-1.0f, kInfinity, std::nanf("")}) {
        options.termination.reinsertion_prior = prior;
        EXPECT_THROW((void)spacebvh::build(scene, options), Error) << prior;
    }
    options.termination.reinsertion_prior = 64.0f;
    options.termination.reinsertion_iterations = kMaxReinsertionIterations + 1;
    EXPECT_THROW((void)spacebvh::build(scene, options), Error);
}

// The command line: `rays --kind bounce|area`, `--termination-rays` on build and `@trays=N` in compare
// (answers checked by the arbiter), and clear errors for what does not apply.
TEST_F(Cli, SampleRaysAndTerminationRays) {
    for (const char* kind : {"bounce", "area"}) {
        const CliResult r = run(std::string("rays builtin:interior --kind ") + kind + " --count 700 -o s.bin");
        ASSERT_EQ(r.exit_code, 0) << r.output;
        EXPECT_EQ(read_ray_file(path("s.bin")).size(), 700u) << kind;
    }
    const CliResult build = run("build builtin:soup --builder cbvh --termination-rays 2000 --no-epo");
    ASSERT_EQ(build.exit_code, 0) << build.output;
    nlohmann::json rows;
    ASSERT_NO_FATAL_FAILURE(
        compare_rows("builtin:soup --builders 'spatial,spatial@trays=2000;tcand=2;tn0=8' --embree medium "
                     "--embree-packets none --random 2000 --width 32 --height 32 --runs 1 --build-runs 1 --no-epo",
                     3, rows));
    EXPECT_EQ(rows[1]["builder"].get<std::string>().rfind("spatial@trays=2000", 0), 0u) << rows[1];
    for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(rows[1][kind]["wrong"], 0) << kind;
    expect_clean_failure("build builtin:soup --builder embree-high --termination-rays 100 --no-epo",
                         {"termination-rays"});
    expect_clean_failure("build builtin:soup --termination-rays 100 --termination-candidates 0 --no-epo",
                         {"termination candidates"});
    expect_clean_failure("rays builtin:soup --kind camera -o r.bin", {"camera"});
    const CliResult optimized =
        run("build builtin:soup --builder spatial --termination-rays 2000 --no-termination-split "
            "--termination-optimize 4 --no-epo");
    ASSERT_EQ(optimized.exit_code, 0) << optimized.output;
    EXPECT_NE(optimized.output.find("spatial+topt"), std::string::npos) << optimized.output;
    ASSERT_NO_FATAL_FAILURE(
        compare_rows("builtin:soup --builders 'spatial,spatial@trays=2000;tsplit=0;topt=4;tprior=16' --embree medium "
                     "--embree-packets none --random 2000 --width 32 --height 32 --runs 1 --build-runs 1 --no-epo",
                     3, rows));
    for (const char* kind : {"random", "primary", "diffuse"}) EXPECT_EQ(rows[1][kind]["wrong"], 0) << kind;
    expect_clean_failure("build builtin:soup --termination-optimize 4 --no-epo", {"termination-rays"});
    expect_clean_failure("compare builtin:soup --builders 'spatial@topt=4' --embree none --no-epo",
                         {"topt", "needs", "trays"});
    expect_clean_failure("build builtin:soup --termination-rays 10 --termination-prior -1 --no-epo", {"prior"});
}
