// SPDX-License-Identifier: MIT
// Tree files (include/spacebvh/tree_file.hpp, docs/tree-format.md): a round trip gives the same tree
// byte for byte and the same answers, for every builder; a file that is truncated, corrupted (every
// byte flipped in turn), of another version, built over other geometry, or crafted to describe a bad
// tree under a valid checksum fails with an Error naming the file, never a crash or a tree that
// answers wrongly.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/tools/embree_builder.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tree_file.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using namespace spacebvh::testing_support;
namespace fs = std::filesystem;

namespace {

Bvh build_named(const Scene& scene, const std::string& name) {
    if (is_embree_tree(name)) return build_embree_tree(scene, name, config_for("binned"));
    return spacebvh::build(scene, options_for_tree(name));
}

// Every preset, an optimised tree (reinsertion moves subtrees) and Embree's spatial-split tree.
std::vector<std::string> every_tree_name() {
    std::vector<std::string> names = builder_names();
    names.push_back("binned+opt");
    names.push_back("embree-high");
    return names;
}

// The message of the Error `load` throws; fails the test when it throws nothing (or anything else).
template <class Load>
std::string error_of(Load&& load) {
    try {
        load();
    } catch (const Error& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "not an Error: " << e.what();
        return "";
    }
    ADD_FAILURE() << "no error";
    return "";
}

bool starts_with(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

// Closest hits and occlusion of `rays` under a tree, as hit records; equal when every record is the
// same bit for bit.
struct Answers {
    std::vector<HitRecord> closest, occlusion;
    bool operator==(const Answers& other) const {
        auto same = [](const std::vector<HitRecord>& a, const std::vector<HitRecord>& b) {
            return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const HitRecord& x, const HitRecord& y) {
                return std::bit_cast<uint32_t>(x.t) == std::bit_cast<uint32_t>(y.t) && x.primitive == y.primitive;
            });
        };
        return same(closest, other.closest) && same(occlusion, other.occlusion);
    }
};
Answers answers_of(const Scene& scene, const Bvh& bvh, std::span<const Ray> rays) {
    const Tracer tracer(scene, bvh, Kernel::binary);
    return {closest_records(tracer, rays), occlusion_records(tracer, rays)};
}

// A small tree over a few hundred triangles: its file is small enough to damage byte by byte.
const Scene& small_scene() {
    static const Scene scene = soup_prefix(40);
    return scene;
}
const Bvh& small_tree() {
    static const Bvh bvh = spacebvh::build(small_scene(), config_for("spatial"));
    return bvh;
}

// The file of a tree altered after the build: a valid checksum over a bad tree.
std::string crafted_error(const Bvh& bvh, const Scene& scene = small_scene()) {
    const std::vector<std::byte> bytes = serialize_bvh(bvh, scene.triangles);
    return error_of([&] { deserialize_bvh(bytes, scene.triangles, "crafted.sbvh"); });
}

}  // namespace

// Every builder's tree comes back byte for byte, with its label and cost model, writes the same bytes
// again, and answers every ray as before: every builder on the interior, the fast object and spatial
// builders on the other built-in scenes (every builder on all of them would take a minute).
TEST(TreeFile, RoundTripEveryBuilderOnTheBuiltinScenes) {
    for (const std::string& scene_name : builtin_scene_names()) {
        const Scene& scene = cached_builtin_scene(scene_name);
        const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 2000, 7);
        const std::vector<std::string> names =
            scene_name == "interior" ? every_tree_name() : std::vector<std::string>{"binned", "spatial"};
        for (const std::string& name : names) {
            SCOPED_TRACE(scene_name + " / " + name);
            const Bvh built = build_named(scene, name);
            const std::vector<std::byte> bytes = serialize_bvh(built, scene.triangles, "settings of " + name);
            TreeFileInfo info;
            const Bvh loaded = deserialize_bvh(bytes, scene.triangles, "t.sbvh", &info);
            EXPECT_EQ(first_difference(built, loaded), "");
            EXPECT_EQ(loaded.builder, built.builder);
            EXPECT_EQ(loaded.cost.traversal_cost, built.cost.traversal_cost);
            EXPECT_EQ(loaded.cost.intersection_cost, built.cost.intersection_cost);
            EXPECT_EQ(loaded.cost.overlap_penalty, built.cost.overlap_penalty);
            EXPECT_EQ(loaded.cost.leaf_block, built.cost.leaf_block);
            EXPECT_EQ(info.settings, "settings of " + name);
            EXPECT_EQ(info.format_version, kTreeFileVersion);
            EXPECT_EQ(info.triangle_count, scene.triangles.size());
            EXPECT_EQ(info.geometry_hash, geometry_hash(scene.triangles));
            EXPECT_TRUE(serialize_bvh(loaded, scene.triangles, "settings of " + name) == bytes);
            EXPECT_TRUE(answers_of(scene, loaded, rays) == answers_of(scene, built, rays));
        }
    }
}

// save_bvh / load_bvh through a real file; the file's errors name its path.
TEST(TreeFile, SaveAndLoadAFile) {
    const fs::path dir = fs::temp_directory_path() / ("spacebvh_tree_file_" + std::to_string(getpid()));
    fs::create_directories(dir);
    const std::string path = (dir / "tree.sbvh").string();
    save_bvh(path, small_tree(), small_scene().triangles);
    EXPECT_EQ(first_difference(load_bvh(path, small_scene().triangles), small_tree()), "");

    const Scene other = soup_prefix(41);
    EXPECT_TRUE(starts_with(error_of([&] { load_bvh(path, other.triangles); }), path + ": built over other geometry"));
    {
        std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
        file.seekp(200);
        file.put('\x5a');
    }
    EXPECT_TRUE(starts_with(error_of([&] { load_bvh(path, small_scene().triangles); }), path + ": corrupt"));
    const std::string missing = (dir / "missing.sbvh").string();
    EXPECT_TRUE(starts_with(error_of([&] { load_bvh(missing, small_scene().triangles); }), missing + ": cannot open"));
    EXPECT_TRUE(starts_with(error_of([&] { load_bvh(dir.string(), small_scene().triangles); }), dir.string() + ":"));
    const std::string unwritable = (dir / "no" / "such" / "dir.sbvh").string();
    EXPECT_TRUE(
        starts_with(error_of([&] { save_bvh(unwritable, small_tree(), small_scene().triangles); }), unwritable + ":"));
    fs::remove_all(dir);
}

// Each byte of the file changed in turn (one bit, and all eight) fails with an Error naming the file.
TEST(TreeFile, EveryFlippedByteFails) {
    const std::vector<std::byte> bytes = serialize_bvh(small_tree(), small_scene().triangles, "max leaf 8");
    ASSERT_GT(bytes.size(), 500u);
    size_t failures = 0;
    for (size_t at = 0; at < bytes.size(); ++at) {
        for (const std::byte flip : {std::byte{0x01}, std::byte{0xFF}}) {
            std::vector<std::byte> damaged = bytes;
            damaged[at] ^= flip;
            const std::string message =
                error_of([&] { deserialize_bvh(damaged, small_scene().triangles, "tree.sbvh"); });
            if (!starts_with(message, "tree.sbvh: ") && failures++ < 5)
                ADD_FAILURE() << "byte " << at << " flipped by " << std::to_integer<int>(flip) << ": '" << message
                              << "'";
        }
    }
    EXPECT_EQ(failures, 0u);
}

// Every shorter length, and a longer file, fails; the message says what the header expected.
TEST(TreeFile, EveryTruncationFails) {
    const std::vector<std::byte> bytes = serialize_bvh(small_tree(), small_scene().triangles);
    for (size_t length = 0; length < bytes.size(); ++length) {
        const std::string message =
            error_of([&] { deserialize_bvh(std::span(bytes).first(length), small_scene().triangles, "tree.sbvh"); });
        ASSERT_TRUE(starts_with(message, "tree.sbvh: truncated: ")) << length << ": " << message;
    }
    const std::string nodes = std::to_string(small_tree().nodes.size());
    EXPECT_NE(error_of([&] {
                  deserialize_bvh(std::span(bytes).first(bytes.size() - 40), small_scene().triangles, "t");
              }).find("header says " + nodes + " nodes"),
              std::string::npos);
    std::vector<std::byte> longer = bytes;
    longer.push_back(std::byte{0});
    EXPECT_TRUE(starts_with(error_of([&] { deserialize_bvh(longer, small_scene().triangles, "tree.sbvh"); }),
                            "tree.sbvh: 1 bytes past the end"));
}

// Another format version, another byte order, not a tree file at all.
TEST(TreeFile, OtherVersionsAndFormatsFail) {
    std::vector<std::byte> bytes = serialize_bvh(small_tree(), small_scene().triangles);
    bytes[8] = std::byte{3};  // the version field, little-endian
    EXPECT_EQ(error_of([&] { deserialize_bvh(bytes, small_scene().triangles, "tree.sbvh"); }),
              "tree.sbvh: format version 3, this library reads 1");
    bytes[8] = std::byte{1};
    std::swap(bytes[12], bytes[15]);
    std::swap(bytes[13], bytes[14]);
    EXPECT_EQ(error_of([&] { deserialize_bvh(bytes, small_scene().triangles, "tree.sbvh"); }),
              "tree.sbvh: written big-endian; tree files are little-endian");
    const std::string text = "REFRAYS1 and then some text that is no tree file at all, long enough for a header.......";
    const std::vector<std::byte> other(reinterpret_cast<const std::byte*>(text.data()),
                                       reinterpret_cast<const std::byte*>(text.data()) + text.size());
    EXPECT_TRUE(starts_with(error_of([&] { deserialize_bvh(other, small_scene().triangles, "rays.bin"); }),
                            "rays.bin: not a spacebvh tree file"));
}

// The same file against other geometry: another count, one coordinate bit, another order.
TEST(TreeFile, OtherGeometryFails) {
    const std::vector<std::byte> bytes = serialize_bvh(small_tree(), small_scene().triangles);
    std::vector<Triangle> triangles = small_scene().triangles;
    EXPECT_NO_THROW(deserialize_bvh(bytes, triangles, "tree.sbvh"));

    triangles.pop_back();
    EXPECT_TRUE(starts_with(error_of([&] { deserialize_bvh(bytes, triangles, "tree.sbvh"); }),
                            "tree.sbvh: built over other geometry (40 triangles, this geometry has 39)"));
    triangles = small_scene().triangles;
    triangles[17].v2.y = std::nextafter(triangles[17].v2.y, kInfinity);
    EXPECT_TRUE(starts_with(error_of([&] { deserialize_bvh(bytes, triangles, "tree.sbvh"); }),
                            "tree.sbvh: built over other geometry (hash "));
    triangles = small_scene().triangles;
    std::swap(triangles[3], triangles[4]);
    EXPECT_NE(geometry_hash(triangles), geometry_hash(small_scene().triangles));
    EXPECT_NE(geometry_hash(std::span(triangles).first(39)), geometry_hash(small_scene().triangles));
}

// Trees that a file could describe under a valid checksum but that are unsafe or unfaithful.
TEST(TreeFile, CraftedBadTreesFail) {
    const Bvh& good = small_tree();
    ASSERT_FALSE(good.root().is_leaf());
    auto expect_invalid = [](const Bvh& bad, const std::string& words, const Scene& scene = small_scene()) {
        const std::string message = crafted_error(bad, scene);
        EXPECT_TRUE(starts_with(message, "crafted.sbvh: invalid tree: ")) << message;
        EXPECT_NE(message.find(words), std::string::npos) << message;
    };
    size_t leaf = 0;
    while (!good.nodes[leaf].is_leaf()) ++leaf;
    Bvh bad = good;
    bad.nodes[0].first = uint32_t(good.nodes.size() - 1);
    expect_invalid(bad, "has children at");
    bad = good;
    bad.nodes[good.root().first].first = 0;  // a child pointing back at the root
    bad.nodes[good.root().first].reference_count = 0;
    expect_invalid(bad, "reached twice");
    bad = good;
    bad.nodes.push_back(good.nodes[leaf]);
    expect_invalid(bad, "not reached from the root");
    bad = good;
    bad.nodes[leaf].first = uint32_t(good.primitives.size());
    expect_invalid(bad, "lists primitives");
    bad = good;
    bad.primitives[good.nodes[leaf].first] = 40;
    expect_invalid(bad, "names triangle 40 of only 40");
    bad = good;
    bad.nodes[3].bounds.lo.x = std::nanf("");
    expect_invalid(bad, "non-finite or inverted box");
    bad = good;
    std::swap(bad.nodes[3].bounds.lo.y, bad.nodes[3].bounds.hi.y);
    expect_invalid(bad, "non-finite or inverted box");
    bad = good;
    bad.nodes[good.root().first].bounds.hi.x = std::nextafter(good.root().bounds.hi.x, kInfinity);
    expect_invalid(bad, "does not contain its child");
    // A leaf box shrunk to a corner of the root: it misses its triangles (all parents still contain it).
    bad = good;
    {
        std::vector<uint32_t> path{0};
        while (!bad.nodes[path.back()].is_leaf()) path.push_back(bad.nodes[path.back()].first);
        const Vec3 corner = bad.nodes[0].bounds.lo - Vec3(1.0f);
        for (const uint32_t n : path) bad.nodes[n].bounds.extend(corner);
        bad.nodes[path.back()].bounds = AABB::of_point(corner);
    }
    expect_invalid(bad, "misses its triangle");
    // A triangle dropped from its leaf (replaced by its neighbour, so the leaf lists it twice, or not).
    bad = good;
    {
        const auto pair =
            std::find_if(good.nodes.begin(), good.nodes.end(), [](const BvhNode& n) { return n.reference_count >= 2; });
        ASSERT_NE(pair, good.nodes.end());
        bad.primitives[pair->first] = bad.primitives[pair->first + 1];
    }
    expect_invalid(bad, "twice");
    // A chain deeper than the traversal stacks allow, over triangles it covers correctly.
    Scene deep;
    deep.name = "deep";
    Bvh chain;
    const uint32_t levels = kTreeFileMaxDepth + 1;
    for (uint32_t i = 0; i <= levels; ++i) {
        const float x = float(i);
        deep.triangles.push_back({{x, 0, 0}, {x + 0.5f, 0, 0}, {x, 1, 0}});
    }
    chain.nodes.resize(2 * size_t(levels) + 1);
    chain.primitives.resize(levels + 1);
    for (uint32_t i = 0; i <= levels; ++i) chain.primitives[i] = i;
    // Node 2i is the inner node of level i (children 2i+1, a leaf of triangle i, and 2i+2); the last
    // node is the leaf of the last triangle.
    for (uint32_t i = 0; i <= levels; ++i) {
        AABB rest;
        for (uint32_t t = i; t <= levels; ++t) rest.extend(deep.triangles[t].bounds());
        BvhNode& node = chain.nodes[2 * i];
        node.bounds = rest;
        if (i == levels) {
            node.first = i;
            node.reference_count = 1;
            break;
        }
        node.first = 2 * i + 1;
        chain.nodes[2 * i + 1] = {deep.triangles[i].bounds(), i, 1};
    }
    expect_invalid(chain, "deeper than 1024 levels", deep);
    // The same chain cut to the depth limit loads.
    chain.nodes.resize(2 * size_t(levels) - 1);
    chain.nodes.back() = {deep.triangles[levels - 1].bounds(), levels - 1, 2};
    chain.nodes.back().bounds.extend(deep.triangles[levels].bounds());
    EXPECT_NO_THROW(deserialize_bvh(serialize_bvh(chain, deep.triangles), deep.triangles, "chain.sbvh"));
}

TEST(TreeFile, EmptyTreesAreNotSaved) { EXPECT_THROW(serialize_bvh(Bvh{}, small_scene().triangles), Error); }

// The shared scenes (../shared/scenes), when present: a few builders' trees through a file answer
// random rays (closest hit and occlusion) exactly as the built trees do.
TEST(TreeFile, SharedScenesRoundTripThroughAFile) {
    const fs::path scenes = fs::path(SPACEBVH_SHARED_DIR) / "scenes";
    if (!fs::exists(scenes)) GTEST_SKIP() << "no shared scenes at " << scenes;
    const fs::path file =
        fs::temp_directory_path() / ("spacebvh_tree_file_shared_" + std::to_string(getpid()) + ".sbvh");
    size_t scenes_done = 0;
    for (const char* stem : {"bunny", "sibenik", "coffee_maker", "crytek_sponza", "living_room_3"}) {
        const fs::path path = scenes / stem / (std::string(stem) + ".obj");
        if (!fs::exists(path)) continue;
        const Scene scene = load_scene(path.string());
        const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 20000, 3);
        for (const char* builder : {"binned", "spatial"}) {
            SCOPED_TRACE(std::string(stem) + " / " + builder);
            const Bvh built = spacebvh::build(scene, config_for(builder));
            save_bvh(file.string(), built, scene.triangles);
            const Bvh loaded = load_bvh(file.string(), scene.triangles);
            EXPECT_EQ(first_difference(built, loaded), "");
            EXPECT_TRUE(answers_of(scene, loaded, rays) == answers_of(scene, built, rays));
        }
        ++scenes_done;
    }
    fs::remove(file);
    EXPECT_GT(scenes_done, 0u);
}
