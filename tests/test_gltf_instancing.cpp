// SPDX-License-Identifier: MIT
// glTF 2.0 files as instanced scenes (load_instanced_scene): files the test writes (JSON + .bin) with
// a node hierarchy (matrix and T * R * S, mirrors, shears), a mesh placed by several nodes and
// EXT_mesh_gpu_instancing. The placements must equal the flat glTF reader's triangles (an independent
// composition) and the quaternion formula evaluated here; answers are checked against the exact
// arbiter per placement and on the flattened scene. Bad files (cycles, singular or non-finite
// transforms, out-of-range indices, buffer URIs naming folders, devices or files outside the glTF's
// folder) give errors naming what and where.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "instanced_test_support.hpp"
#include "test_support.hpp"
#include "tools/scene/instanced_internal.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using namespace spacebvh::scene_testing;
namespace fs = std::filesystem;

namespace {

// Buffer views and accessors over one .bin, appended to as the test adds data.
struct GltfFile {
    std::string bin, views, accessors;
    int count = 0;
    template <typename T>
    int add(const std::vector<T>& data, int component, const char* type, size_t elements) {
        const size_t offset = bin.size();
        bin.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(T));
        while (bin.size() % 4) bin.push_back(0);
        const std::string sep = count ? "," : "";
        views += sep + R"({"buffer":0,"byteOffset":)" + std::to_string(offset) + R"(,"byteLength":)" +
                 std::to_string(data.size() * sizeof(T)) + "}";
        accessors += sep + R"({"bufferView":)" + std::to_string(count) + R"(,"componentType":)" +
                     std::to_string(component) + R"(,"count":)" + std::to_string(elements) + R"(,"type":")" + type +
                     "\"}";
        return count++;
    }
    int vec3(const std::vector<float>& xyz) { return add(xyz, 5126, "VEC3", xyz.size() / 3); }
    int vec4(const std::vector<float>& xyzw) { return add(xyzw, 5126, "VEC4", xyzw.size() / 4); }
};

std::vector<float> coordinates(const std::vector<Triangle>& triangles) {
    std::vector<float> out;
    for (const Triangle& t : triangles)
        for (const Vec3& v : {t.v0, t.v1, t.v2}) out.insert(out.end(), {v.x, v.y, v.z});
    return out;
}

// EXT_mesh_gpu_instancing entries of node 4: translations, unit-ish quaternions (x, y, z, w), scales
// (one mirrored).
const std::vector<float> kEntryT = {0, 0, 0, 6, 1, -2, -5, 3, 4, 1, -7, 2, 9, 9, 9};
const std::vector<float> kEntryR = {0, 0, 0, 1, 0.2f, 0.3f, 0.1f, 0.9f, 0, 1, 0, 0, 0.5f, 0.5f, 0.5f, 0.5f, 1, 1, 0, 0};
const std::vector<float> kEntryS = {1, 1, 1, 2, 0.5f, 1, -1, 1, 1, 0.3f, 0.3f, 0.3f, 1, 3, 1};

class GltfInstancing : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("spacebvh_gltf_instancing_" + std::to_string(::getpid()) + "_" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        organic_ = testing_support::cached_builtin_scene("organic").triangles;
        organic_.resize(600);
        file_.vec3(coordinates(organic_));  // accessor 0: mesh 0, not indexed
        file_.vec3({-1, -1, -1, 1, -1, -1, -1, 1, -1, 1, 1, -1, -1, -1, 1, 1, -1, 1, -1, 1, 1, 1, 1, 1});  // 1
        const std::vector<uint16_t> box = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                           2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
        file_.add(box, 5123, "SCALAR", box.size());                                // accessor 2: mesh 1's indices
        file_.vec3(kEntryT);                                                       // 3
        file_.vec4(kEntryR);                                                       // 4
        file_.vec3(kEntryS);                                                       // 5
        file_.vec3({NAN, 0, 0});                                                   // 6
        file_.vec4({0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0});  // 7: zero quaternions
        std::ofstream(dir_ / "scene.bin", std::ios::binary) << file_.bin;
    }
    void TearDown() override { fs::remove_all(dir_); }

    // node 4 gets `node4` spliced in (an extension, say); `nodes` replaces the whole node list.
    std::string json(const std::string& node4 = "", const std::string& nodes = "",
                     const std::string& uri = "scene.bin") {
        const std::string default_nodes =
            R"({"translation":[5,0,0],"rotation":[0.1,0.7,0.2,0.68],"scale":[1,2,0.5],"children":[1,2]},)"
            R"({"mesh":0,"matrix":[-1,0,0,0, 0.3,1,0,0, 0,0,1.5,0, 1,2,3,1]},)"
            R"({"mesh":0,"translation":[0,10,0],"children":[3]},)"
            R"({"mesh":1,"scale":[-1,1,3]},)"
            R"({"mesh":1,"translation":[0,-8,1])" +
            node4 +
            R"(},)"
            R"({"mesh":0})";
        return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,4,5]}],"nodes":[)" +
               (nodes.empty() ? default_nodes : nodes) +
               R"(],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]},)"
               R"({"name":"box","primitives":[{"attributes":{"POSITION":1},"indices":2}]}],)"
               R"("buffers":[{"byteLength":)" +
               std::to_string(file_.bin.size()) + R"(,"uri":")" + uri + R"("}],"bufferViews":[)" + file_.views +
               R"(],"accessors":[)" + file_.accessors + "]}";
    }
    std::string write(const std::string& name, const std::string& text) {
        std::ofstream(dir_ / name, std::ios::binary) << text;
        return (dir_ / name).string();
    }
    // The error text of loading `text` as an instanced scene ("" when it loads).
    std::string error_of(const std::string& text) {
        try {
            load_instanced_scene(write("bad.gltf", text));
        } catch (const Error& e) {
            return e.what();
        }
        return "";
    }

    fs::path dir_;
    GltfFile file_;
    std::vector<Triangle> organic_;
};

const std::string kGpuInstances =
    R"(,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":3,"ROTATION":4,"SCALE":5}}})";

TEST_F(GltfInstancing, NodesPlacingAMeshBecomeInstancesOfOneMesh) {
    const std::string path = write("scene.gltf", json());
    const InstancedScene scene = load_instanced_scene(path);
    ASSERT_EQ(scene.meshes.size(), 2u);  // mesh 0 is placed three times, decoded once
    ASSERT_EQ(scene.instances.size(), 5u);
    ASSERT_EQ(scene.meshes[0].triangles.size(), organic_.size());  // in its own space, bit for bit
    EXPECT_EQ(std::memcmp(scene.meshes[0].triangles.data(), organic_.data(), organic_.size() * sizeof(Triangle)), 0);
    EXPECT_EQ(scene.meshes[1].triangles.size(), 12u);
    EXPECT_EQ(scene.meshes[1].name, "scene:box");
    const std::vector<uint32_t> meshes = {0, 0, 1, 1, 0};  // node order: 1, 2, 3, 4, 5
    for (size_t i = 0; i < meshes.size(); ++i) EXPECT_EQ(scene.instances[i].mesh, meshes[i]);
    // The flat reader composes the same transforms in double and rounds each vertex once; the
    // instances round the transform once, then place each vertex: a few ulps apart.
    const Scene flat = load_scene(path);
    const Scene placed = flatten_scene(scene);
    ASSERT_EQ(flat.triangles.size(), placed.triangles.size());
    for (size_t i = 0; i < flat.triangles.size(); ++i)
        for (auto corner : {&Triangle::v0, &Triangle::v1, &Triangle::v2}) {
            const Vec3 a = flat.triangles[i].*corner, b = placed.triangles[i].*corner;
            ASSERT_LE(length(a - b), 1e-5f * (1.0f + length(a))) << "triangle " << i;
        }
    EXPECT_LT(scene_detail::Affine64(scene.instances[0].transform).determinant(), 0.0);  // node 1 mirrors
}

// q v q* for a quaternion (x, y, z, w) normalised first, in double.
Vec3 rotate(const float* q, Vec3 v) {
    const double n = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
    const double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
    // t = 2 (q.xyz x v); v' = v + w t + q.xyz x t
    const double tx = 2 * (y * v.z - z * v.y), ty = 2 * (z * v.x - x * v.z), tz = 2 * (x * v.y - y * v.x);
    return Vec3(float(v.x + w * tx + (y * tz - z * ty)), float(v.y + w * ty + (z * tx - x * tz)),
                float(v.z + w * tz + (x * ty - y * tx)));
}

TEST_F(GltfInstancing, GpuInstancingEntriesAreInstances) {
    const std::string path = write("scene.gltf", json(kGpuInstances));
    const InstancedScene scene = load_instanced_scene(path);
    ASSERT_EQ(scene.meshes.size(), 2u);
    ASSERT_EQ(scene.instances.size(), 4u + 5u);  // node 4's five entries replace its one placement
    // Entry e places box corner p at node 4's transform (translation (0, -8, 1)) of T_e + R_e (S_e p).
    const Vec3 corner{1, -1, 1};
    for (int e = 0; e < 5; ++e) {
        const SceneInstance& instance = scene.instances[3 + e];
        EXPECT_EQ(instance.mesh, 1u);
        const Vec3 scaled{corner.x * kEntryS[3 * e], corner.y * kEntryS[3 * e + 1], corner.z * kEntryS[3 * e + 2]};
        const Vec3 expected = rotate(&kEntryR[4 * e], scaled) +
                              Vec3(kEntryT[3 * e], kEntryT[3 * e + 1] - 8.0f, kEntryT[3 * e + 2] + 1.0f);
        EXPECT_LE(length(instance.transform.apply(corner) - expected), 1e-5f * (1.0f + length(expected))) << e;
    }
    EXPECT_LT(scene_detail::Affine64(scene.instances[5].transform).determinant(), 0.0);  // entry 2 mirrors
}

TEST_F(GltfInstancing, AnswersMatchTheArbiterPerPlacementAndFlattened) {
    const InstancedScene scene = load_instanced_scene(write("scene.gltf", json(kGpuInstances)));
    for (const char* builder : {"binned", "spatial"}) {
        SceneConfig config;
        config.recipe = TreeRecipe::for_builder(builder);
        config.tracer.kernel = Kernel::bvh4;
        const std::shared_ptr<RenderScene> render = make_render_scene(scene, config);
        EXPECT_EQ(render->geometry_count(), scene.instances.size());
        const std::vector<Ray> rays = generate_random_rays(render->bounds(), 300, 7);
        const Check check = check_against_arbiter(*render, scene, rays);
        EXPECT_EQ(check.wrong, 0u) << check.first;
        EXPECT_EQ(check.misnamed, 0u) << check.first;
        EXPECT_EQ(check.flat_disagree, 0u);
        EXPECT_GT(check.hits, 10u);
    }
}

TEST_F(GltfInstancing, BadNodesAndTransformsNameTheNode) {
    const struct {
        std::string nodes, expected;
    } cases[] = {
        {R"({"mesh":0,"children":[1]},{"mesh":0,"children":[0]},{},{},{},{})", "reached twice"},         // cycle
        {R"({"children":[4]},{},{},{},{"mesh":0},{"mesh":0})", "node 4: reached twice"},                 // two parents
        {R"({"mesh":7},{},{},{},{},{})", "node 0: mesh 7 does not exist"},                               //
        {R"({"mesh":0,"scale":[1,0,1]},{},{},{},{},{})", "node 0: transform is singular"},               //
        {R"({"mesh":0,"scale":[1,1,1e-6]},{},{},{},{},{})", "node 0: transform is nearly singular"},     //
        {R"({"scale":[1e30,1,1],"children":[1]},{"mesh":0,"scale":[1e30,1,1]},{},{},{},{})", "node 1"},  // overflow
        {R"({"mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0]},{},{},{},{},{})", "16 numbers"},         //
        {R"({"mesh":0,"rotation":[0,0,0,0]},{},{},{},{},{})", "node 0: rotation quaternion is zero"},    //
        {R"({"mesh":0,"children":[9]},{},{},{},{},{})", "node 9 does not exist"},                        //
    };
    for (const auto& c : cases) {
        const std::string error = error_of(json("", c.nodes));
        EXPECT_NE(error.find(c.expected), std::string::npos) << c.nodes << " -> " << error;
        EXPECT_NE(error.find("bad.gltf"), std::string::npos) << error;
    }
    EXPECT_NE(error_of(json("", R"({"scale":[1e30,1,1],"children":[1]},{"mesh":0,"scale":[1e30,1,1]},{},{},{},{})"))
                  .find("NaN or infinite entry"),
              std::string::npos);
}

TEST_F(GltfInstancing, BadGpuInstancingNamesTheAttribute) {
    const std::string ext = R"(,"extensions":{"EXT_mesh_gpu_instancing":)";
    const struct {
        std::string extension, expected;
    } cases[] = {
        {ext + "{}}", "no 'attributes' object"},
        {ext + R"({"attributes":{}}})", "no 'attributes' object"},  // tinygltf drops empty objects
        {ext + R"({"attributes":{"_OTHER":1}}})", "none of TRANSLATION, ROTATION, SCALE"},
        {ext + R"({"attributes":{"TRANSLATION":99}}})", "TRANSLATION: accessor is not an index"},
        {ext + R"({"attributes":{"TRANSLATION":-1}}})", "accessor is not an index"},
        {ext + R"({"attributes":{"TRANSLATION":1.5}}})", "accessor is not an index"},
        {ext + R"({"attributes":{"TRANSLATION":4}}})", "unexpected element type"},
        {ext + R"({"attributes":{"TRANSLATION":1,"SCALE":3}}})", "entries, but another attribute has"},
        {ext + R"({"attributes":{"TRANSLATION":6}}})", "instance 0: non-finite transform"},
        {ext + R"({"attributes":{"ROTATION":7}}})", "instance 0: rotation quaternion is zero"},
        {ext + R"({"attributes":{"ROTATION":2}}})", "unexpected element type"},
    };
    for (const auto& c : cases) {
        const std::string error = error_of(json(c.extension));
        EXPECT_NE(error.find(c.expected), std::string::npos) << c.extension << " -> " << error;
        EXPECT_NE(error.find("node 4 EXT_mesh_gpu_instancing"), std::string::npos) << error;
    }
}

// Buffer URIs are read only when they name a regular file inside the glTF's folder (tinygltf alone
// would try to allocate the 2^63 - 1 bytes a folder's stream reports), by both glTF readers.
TEST_F(GltfInstancing, BufferUrisReadOnlyRegularFilesInTheFolder) {
    fs::create_directories(dir_ / "sub");
    std::ofstream(dir_.parent_path() / "spacebvh_outside.bin", std::ios::binary) << file_.bin;
    std::error_code ignored;
    fs::create_symlink("/dev/zero", dir_ / "zero.bin", ignored);
    const struct {
        std::string uri, expected;
    } cases[] = {
        {"sub", "sub' is not a regular file"},
        {".", "is not a regular file"},
        {"sub/", "is not a regular file"},
        {"../spacebvh_outside.bin", "lies outside the glTF's folder"},
        {"/etc/hostname", "etc/hostname' is not a regular file"},  // joined to the folder
        {"zero.bin", "zero.bin' lies outside the glTF's folder"},  // the link resolved
        {"nowhere.bin", "nowhere.bin' is not a regular file"},
        {"%00x.bin", "NUL byte"},
    };
    for (const auto& c : cases) {
        const std::string text = json("", "", c.uri);
        const std::string error = error_of(text);
        EXPECT_NE(error.find(c.expected), std::string::npos) << c.uri << " -> " << error;
        EXPECT_THROW(load_scene(write("flat.gltf", text)), Error) << c.uri;
    }
    fs::remove(dir_.parent_path() / "spacebvh_outside.bin");
    // A symlink inside the folder to a regular file inside it is read.
    fs::create_symlink(dir_ / "scene.bin", dir_ / "link.bin", ignored);
    EXPECT_EQ(load_instanced_scene(write("linked.gltf", json("", "", "link.bin"))).instances.size(), 5u);
}

// The fuzz harness's crash input: a buffer URI of percent signs and text that tinygltf's URL decoding
// turns into a name of the working folder.
TEST(GltfFuzzRegression, BufferUriOfTheCrashInputIsRefusedCleanly) {
    const fs::path input = fs::path(SPACEBVH_TEST_DATA_DIR) / "fuzz" / "gltf" / "buffer_uri_names_a_folder";
    std::ifstream in(input, std::ios::binary);
    ASSERT_TRUE(in) << input;
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    try {
        scene_detail::parse_gltf(bytes, "fuzz.gltf");
        ADD_FAILURE() << "loaded";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("buffer file"), std::string::npos) << e.what();
    }
    EXPECT_THROW(scene_detail::parse_gltf_instanced(bytes, "fuzz.gltf"), Error);
}

}  // namespace
