// SPDX-License-Identifier: MIT
// Scene loading: OBJ, PLY (ascii and both binary byte orders), glTF (.gltf and .glb), the load
// transform, cameras, the built-in scenes, the error corpus, and the shared scenes when present.
// Binary inputs are generated into a temporary directory rather than checked in.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <unistd.h>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh {

using namespace spacebvh::tools;
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class SceneFiles : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("spacebvh_scene_" + std::to_string(getpid()) + "_" + info->test_suite_name() + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string write(const std::string& name, const std::string& bytes) const {
        const fs::path path = dir_ / name;
        std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        return path.string();
    }

    fs::path dir_;
};

// Appends a value in the requested byte order.
template <typename T>
void put(std::string& out, T value, bool big_endian) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (big_endian != (std::endian::native == std::endian::big))
        for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    out.append(bytes, sizeof(T));
}

void expect_triangle(const Triangle& t, Vec3 a, Vec3 b, Vec3 c) {
    EXPECT_EQ(t.v0, a);
    EXPECT_EQ(t.v1, b);
    EXPECT_EQ(t.v2, c);
}

// Expects load_scene to throw an Error whose message names the file and contains `where`.
void expect_load_error(const std::string& path, const std::string& where) {
    try {
        Scene scene = load_scene(path);
        ADD_FAILURE() << path << ": loaded " << scene.triangles.size() << " triangles, expected an Error";
    } catch (const Error& e) {
        const std::string message = e.what();
        if (std::getenv("SPACEBVH_PRINT_ERRORS")) std::printf("  %s\n", message.c_str());  // to review wording
        EXPECT_NE(message.find(fs::path(path).filename().string()), std::string::npos) << message;
        EXPECT_NE(message.find(where), std::string::npos) << "expected '" << where << "' in: " << message;
    }
}

// ---------------------------------------------------------------- OBJ

TEST_F(SceneFiles, ObjFanTriangulatesInFileOrderAcrossGroups) {
    const std::string path = write("shapes.obj",
                                   "# a quad, a pentagon and a triangle in three groups\n"
                                   "mtllib none.mtl\n"
                                   "o first\n"
                                   "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                   "vt 0 0\nvn 0 0 1\n"
                                   "g quad\n"
                                   "f 1/1/1 2/1/1 3//1 4/1\n"
                                   "g pentagon\r\n"
                                   "v 0 0 2\nv 2 0 2\nv 3 1 2\nv 1 3 2\nv -1 1 2\n"
                                   "usemtl stone\n"
                                   "s off\n"
                                   "f -5 -4 -3 -2 -1   # relative indices\n"
                                   "o last\n"
                                   "f 1 3 +4e0\n"
                                   "f 9 8 7\n");
    // "+4e0" is not an index: that face (line 22) is malformed.
    expect_load_error(path, "shapes.obj:22:");
    const std::string good = write("shapes2.obj",
                                   "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                   "g quad\n"
                                   "f 1/1/1 2/1/1 3//1 4/1\n"
                                   "g pentagon\n"
                                   "v 0 0 2\nv 2 0 2\nv 3 1 2\nv 1 3 2\nv -1 1 2\n"
                                   "f -5 -4 -3 -2 -1\n"
                                   "o last\n"
                                   "f 1 3 9\n");
    Scene scene = load_scene(good);
    EXPECT_EQ(scene.name, "shapes2");
    ASSERT_EQ(scene.triangles.size(), 2u + 3u + 1u);
    // Quad (v0, vi, vi+1): (1,2,3), (1,3,4).
    expect_triangle(scene.triangles[0], {0, 0, 0}, {1, 0, 0}, {1, 1, 0});
    expect_triangle(scene.triangles[1], {0, 0, 0}, {1, 1, 0}, {0, 1, 0});
    // Pentagon 5..9: (5,6,7), (5,7,8), (5,8,9).
    expect_triangle(scene.triangles[2], {0, 0, 2}, {2, 0, 2}, {3, 1, 2});
    expect_triangle(scene.triangles[3], {0, 0, 2}, {3, 1, 2}, {1, 3, 2});
    expect_triangle(scene.triangles[4], {0, 0, 2}, {1, 3, 2}, {-1, 1, 2});
    expect_triangle(scene.triangles[5], {0, 0, 0}, {1, 1, 0}, {-1, 1, 2});
    EXPECT_EQ(scene.degenerate_count, 0u);
}

TEST_F(SceneFiles, ObjKeepsAndCountsDegenerateTrianglesAndForwardReferences) {
    const std::string path = write("DEGEN.OBJ",  // extension is case-insensitive
                                   "f 1 2 3\nf 1 1 2\nf 1 2 4\n"
                                   "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\n");
    Scene scene = load_scene(path);
    ASSERT_EQ(scene.triangles.size(), 3u);
    EXPECT_EQ(scene.degenerate_count, 2u);  // repeated vertex, and collinear
    EXPECT_TRUE(scene.triangles[1].is_degenerate());
}

TEST(CheckedInSamples, LoadFromTestDataDir) {
    const std::string dir = SPACEBVH_TEST_DATA_DIR;
    Scene obj = load_scene(dir + "/quad_and_pentagon.obj");
    ASSERT_EQ(obj.triangles.size(), 5u);
    expect_triangle(obj.triangles[4], {0, 0, 2}, {1, 3, 2}, {-1, 1, 2});
    Scene ply = load_scene(dir + "/tetrahedron_ascii.ply");
    ASSERT_EQ(ply.triangles.size(), 4u);
    expect_triangle(ply.triangles[3], {1, 0, 0}, {0, 1, 0}, {0, 0, 1});
    expect_load_error(dir + "/bad_index.obj", "bad_index.obj:6:");
}

// ---------------------------------------------------------------- PLY

// A PLY with extra vertex properties of several types, double coordinates in one variant, a quad and a
// triangle with assorted count/index types, and extra face and element data to skip.
std::string make_ply(const std::string& format, bool double_coordinates) {
    const bool ascii = format == "ascii";
    const bool big = format == "binary_big_endian";
    const std::string coord = double_coordinates ? "double" : "float32";
    std::string out =
        "ply\nformat " + format +
        " 1.0\ncomment generated by test_scene\n"
        "element vertex 5\n"
        "property uchar red\nproperty " +
        coord + " x\nproperty short tag\nproperty " + coord + " y\nproperty " + coord +
        " z\nproperty list uchar int extra\nproperty float nx\n"
        "element face 2\n"
        "property int8 flags\nproperty list ushort uint vertex_indices\nproperty list uchar double weights\n"
        "element edge 1\nproperty int a\nproperty int b\n"
        "end_header\n";
    const float xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.25f, -3.75f}};
    for (int v = 0; v < 5; ++v) {
        if (ascii) {
            out += "200 " + std::to_string(xyz[v][0]) + " -7 " + std::to_string(xyz[v][1]) + " " +
                   std::to_string(xyz[v][2]) + " 2 11 12 0.5\n";
            continue;
        }
        put<uint8_t>(out, 200, big);
        double_coordinates ? put<double>(out, xyz[v][0], big) : put<float>(out, xyz[v][0], big);
        put<int16_t>(out, -7, big);
        double_coordinates ? put<double>(out, xyz[v][1], big) : put<float>(out, xyz[v][1], big);
        double_coordinates ? put<double>(out, xyz[v][2], big) : put<float>(out, xyz[v][2], big);
        put<uint8_t>(out, 2, big);
        put<int32_t>(out, 11, big);
        put<int32_t>(out, 12, big);
        put<float>(out, 0.5f, big);
    }
    const std::vector<std::vector<uint32_t>> faces = {{0, 1, 2, 3}, {4, 0, 2}};
    for (const auto& face : faces) {
        if (ascii) {
            out.append("-1 ").append(std::to_string(face.size()));
            for (uint32_t i : face)
                out.append(" ").append(std::to_string(i));  // (avoids a GCC 12 -Wrestrict false positive)
            out += " 1 0.25\n";
            continue;
        }
        put<int8_t>(out, -1, big);
        put<uint16_t>(out, static_cast<uint16_t>(face.size()), big);
        for (uint32_t i : face) put<uint32_t>(out, i, big);
        put<uint8_t>(out, 1, big);
        put<double>(out, 0.25, big);
    }
    if (ascii)
        out += "0 1\n";
    else {
        put<int32_t>(out, 0, big);
        put<int32_t>(out, 1, big);
    }
    return out;
}

TEST_F(SceneFiles, PlyAllEncodingsGiveTheSameTriangles) {
    for (const std::string format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
        for (bool double_coordinates : {false, true}) {
            SCOPED_TRACE(format + (double_coordinates ? " double" : " float"));
            const std::string path = write("mesh.ply", make_ply(format, double_coordinates));
            Scene scene = load_scene(path);
            EXPECT_EQ(scene.name, "mesh");
            ASSERT_EQ(scene.triangles.size(), 3u);
            expect_triangle(scene.triangles[0], {0, 0, 0}, {1, 0, 0}, {1, 1, 0});
            expect_triangle(scene.triangles[1], {0, 0, 0}, {1, 1, 0}, {0, 1, 0});
            expect_triangle(scene.triangles[2], {0.5f, 0.25f, -3.75f}, {0, 0, 0}, {1, 1, 0});
        }
    }
}

TEST_F(SceneFiles, PlyAcceptsVertexIndexNameAndCrLfHeader) {
    const std::string path = write("crlf.PLY",
                                   "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\n"
                                   "property float y\r\nproperty float z\r\nelement face 1\r\n"
                                   "property list uint8 int32 vertex_index\r\nend_header\r\n"
                                   "0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n");
    Scene scene = load_scene(path);
    ASSERT_EQ(scene.triangles.size(), 1u);
    expect_triangle(scene.triangles[0], {0, 0, 0}, {1, 0, 0}, {0, 1, 0});
}

// ---------------------------------------------------------------- glTF

// Buffer: 4 float positions (48 bytes) then 6 ushort indices (12 bytes) then 5 float positions of a strip.
std::string gltf_buffer() {
    std::string bin;
    const float quad[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    for (auto& p : quad)
        for (float c : p) put<float>(bin, c, false);
    for (uint16_t i : {0, 1, 2, 0, 2, 3}) put<uint16_t>(bin, i, false);
    const float strip[5][3] = {{0, 0, 5}, {0, 1, 5}, {1, 0, 5}, {1, 1, 5}, {2, 0, 5}};
    for (auto& p : strip)
        for (float c : p) put<float>(bin, c, false);
    return bin;  // 48 + 12 + 60 = 120 bytes
}

// Scene 0 is the default: node 0 (translate x+10) -> child node 1 (scale 2) with the indexed quad;
// node 2 (matrix: translate y+100) with the non-indexed strip. Scene 1 (not default) has node 3.
std::string gltf_json(const std::string& buffer_entry) {
    return R"({"asset":{"version":"2.0"},"scene":0,
"scenes":[{"nodes":[0,2]},{"nodes":[3]}],
"nodes":[{"translation":[10,0,0],"children":[1]},{"scale":[2,2,2],"mesh":0},
         {"matrix":[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,100,0,1],"mesh":1},{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]},
          {"primitives":[{"attributes":{"POSITION":2},"mode":5},{"attributes":{"POSITION":2},"mode":0}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
             {"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"},
             {"bufferView":2,"componentType":5126,"count":5,"type":"VEC3","min":[0,0,5],"max":[2,1,5]}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":12},
               {"buffer":0,"byteOffset":60,"byteLength":60}],
"buffers":[)" +
           buffer_entry + "]}";
}

std::string make_glb(std::string json, const std::string& bin) {
    while (json.size() % 4 != 0) json += ' ';
    std::string padded_bin = bin;
    while (padded_bin.size() % 4 != 0) padded_bin += '\0';
    std::string out = "glTF";
    put<uint32_t>(out, 2, false);
    put<uint32_t>(out, static_cast<uint32_t>(12 + 8 + json.size() + 8 + padded_bin.size()), false);
    put<uint32_t>(out, static_cast<uint32_t>(json.size()), false);
    put<uint32_t>(out, 0x4E4F534Au, false);  // "JSON"
    out += json;
    put<uint32_t>(out, static_cast<uint32_t>(padded_bin.size()), false);
    put<uint32_t>(out, 0x004E4942u, false);  // "BIN\0"
    out += padded_bin;
    return out;
}

void expect_gltf_test_scene(const Scene& scene) {
    ASSERT_EQ(scene.triangles.size(), 2u + 3u);
    // Quad scaled by 2 then translated by x+10.
    expect_triangle(scene.triangles[0], {10, 0, 0}, {12, 0, 0}, {12, 2, 0});
    expect_triangle(scene.triangles[1], {10, 0, 0}, {12, 2, 0}, {10, 2, 0});
    // Strip (glTF 3.7.2.1): {v0,v1,v2}, {v2,v1,v3}... written as {p, p+1+p%2, p+2-p%2}, moved y+100.
    expect_triangle(scene.triangles[2], {0, 100, 5}, {0, 101, 5}, {1, 100, 5});
    expect_triangle(scene.triangles[3], {0, 101, 5}, {1, 101, 5}, {1, 100, 5});
    expect_triangle(scene.triangles[4], {1, 100, 5}, {1, 101, 5}, {2, 100, 5});
}

TEST_F(SceneFiles, GltfWithExternalBufferAndNodeHierarchy) {
    write("mesh.bin", gltf_buffer());
    const std::string path = write("mesh.gltf", gltf_json(R"({"byteLength":120,"uri":"mesh.bin"})"));
    Scene scene = load_scene(path);
    EXPECT_EQ(scene.name, "mesh");
    expect_gltf_test_scene(scene);
}

TEST_F(SceneFiles, GlbWithBinaryChunk) {
    const std::string path = write("mesh.glb", make_glb(gltf_json(R"({"byteLength":120})"), gltf_buffer()));
    expect_gltf_test_scene(load_scene(path));
}

TEST_F(SceneFiles, GltfWithoutDefaultSceneUsesAllScenesAndFans) {
    write("mesh.bin", gltf_buffer());
    std::string json = gltf_json(R"({"byteLength":120,"uri":"mesh.bin"})");
    json.replace(json.find("\"scene\":0,"), 10, "");
    json.replace(json.find("\"mode\":5"), 8, "\"mode\":6");
    Scene scene = load_scene(write("all.gltf", json));
    // Scene 0: quad (2) + fan of 5 (3); scene 1: the quad again, untransformed (2).
    ASSERT_EQ(scene.triangles.size(), 7u);
    expect_triangle(scene.triangles[2], {0, 100, 5}, {0, 101, 5}, {1, 100, 5});
    expect_triangle(scene.triangles[3], {0, 100, 5}, {1, 100, 5}, {1, 101, 5});
    expect_triangle(scene.triangles[5], {0, 0, 0}, {1, 0, 0}, {1, 1, 0});
}

// ---------------------------------------------------------------- transform and cameras

TEST(SceneTransform, RotationOrderIsRzRyRx) {
    // Rx(90) takes y to z, Ry(90) takes z to x, Rz(90) takes x to y: y comes back to y only in this order.
    SceneTransform t;
    t.rotate_degrees = {90, 90, 90};
    EXPECT_EQ(t.apply({0, 1, 0}), Vec3(0, 1, 0));
    EXPECT_EQ(t.apply({1, 0, 0}), Vec3(0, 0, -1));
    // General angles against an explicit product of the three matrices.
    const double a = 30 * std::numbers::pi / 180, b = -50 * std::numbers::pi / 180, c = 110 * std::numbers::pi / 180;
    const double rx[3][3] = {{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}};
    const double ry[3][3] = {{std::cos(b), 0, std::sin(b)}, {0, 1, 0}, {-std::sin(b), 0, std::cos(b)}};
    const double rz[3][3] = {{std::cos(c), -std::sin(c), 0}, {std::sin(c), std::cos(c), 0}, {0, 0, 1}};
    const double p[3] = {0.3, -1.7, 2.9};
    double q[3], r[3], s[3];
    for (int i = 0; i < 3; ++i) q[i] = rx[i][0] * p[0] + rx[i][1] * p[1] + rx[i][2] * p[2];
    for (int i = 0; i < 3; ++i) r[i] = ry[i][0] * q[0] + ry[i][1] * q[1] + ry[i][2] * q[2];
    for (int i = 0; i < 3; ++i) s[i] = rz[i][0] * r[0] + rz[i][1] * r[1] + rz[i][2] * r[2];
    t.rotate_degrees = {30, -50, 110};
    t.scale = 2.5f;
    t.translate = {1, -2, 3};
    const Vec3 got = t.apply({0.3f, -1.7f, 2.9f});
    EXPECT_NEAR(got.x, 1 + 2.5 * s[0], 1e-5);
    EXPECT_NEAR(got.y, -2 + 2.5 * s[1], 1e-5);
    EXPECT_NEAR(got.z, 3 + 2.5 * s[2], 1e-5);
}

TEST(SceneTransform, ParseRotation) {
    EXPECT_EQ(SceneTransform::parse_rotation("x:45,y:45,z:45"), Vec3(45, 45, 45));
    EXPECT_EQ(SceneTransform::parse_rotation("z:10, X:-5.5"), Vec3(-5.5f, 0, 10));
    EXPECT_EQ(SceneTransform::parse_rotation("y:90"), Vec3(0, 90, 0));
    EXPECT_EQ(SceneTransform::parse_rotation(""), Vec3(0.0f));
    for (const char* bad : {"x45", "w:3", "x:1,x:2", "x:abc", "x:", "x:1,", "x:nan", "x:1e99"})
        EXPECT_THROW(SceneTransform::parse_rotation(bad), Error) << bad;
}

TEST(Camera, ParseAndErrors) {
    Camera camera = Camera::parse("-0.016,0.11,0.25,-0.016,0.11,0,0,1,0,45");
    EXPECT_EQ(camera.eye, Vec3(-0.016f, 0.11f, 0.25f));
    EXPECT_EQ(camera.target, Vec3(-0.016f, 0.11f, 0));
    EXPECT_EQ(camera.up, Vec3(0, 1, 0));
    EXPECT_EQ(camera.fovy_degrees, 45.0f);
    for (const char* bad :
         {"", "1,2,3", "0,0,1,0,0,0,0,1,0,45,7", "0,0,1,0,0,0,0,1,0,x", "0,0,1,0,0,0,0,1,0,0", "0,0,1,0,0,0,0,1,0,180",
          "0,0,0,0,0,0,0,1,0,45", "0,0,1,0,0,0,0,0,1,45", "0,0,1,0,0,0,0,1,0,inf"})
        EXPECT_THROW(Camera::parse(bad), Error) << bad;
    try {
        Camera::parse("1,2,3");
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("got 3"), std::string::npos) << e.what();
    }
}

TEST(Camera, DefaultCameraFollowsTheSpec) {
    Scene scene;
    scene.triangles = {{{-1, 0, 2}, {3, 0, 2}, {-1, 4, 6}}};
    const Camera camera = default_camera(scene);
    const Vec3 center{1, 2, 4};
    const float diagonal = std::sqrt(16.0f + 16.0f + 16.0f);
    const Vec3 direction = Vec3(1.0f, 0.6f, 1.0f) / std::sqrt(1.0f + 0.36f + 1.0f);
    EXPECT_EQ(camera.target, center);
    EXPECT_NEAR(camera.eye.x, center.x + direction.x * 1.5f * diagonal, 1e-5);
    EXPECT_NEAR(camera.eye.y, center.y + direction.y * 1.5f * diagonal, 1e-5);
    EXPECT_NEAR(camera.eye.z, center.z + direction.z * 1.5f * diagonal, 1e-5);
    EXPECT_EQ(camera.up, Vec3(0, 1, 0));
    EXPECT_EQ(camera.fovy_degrees, 45.0f);
    EXPECT_THROW(default_camera(Scene{}), Error);
}

TEST_F(SceneFiles, CameraFromManifestTableIsTransformed) {
    fs::create_directories(dir_ / "scenes" / "thing");
    const std::string manifest = write("scenes/MANIFEST.md",
                                       "| scene | camera |\n|---|---|\n"
                                       "| other | `9,9,9,0,0,0,0,1,0,30` |\n"
                                       "| thing | `0,0,5,0,0,0,0,1,0,50` |\n");
    const std::string path = write("scenes/thing/thing.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    SceneTransform transform;
    transform.rotate_degrees = {0, 90, 0};
    transform.translate = {1, 2, 3};
    Scene scene = load_scene(path, transform);
    EXPECT_EQ(scene.name, "thing@y:90,t:(1,2,3)");
    // Only a manifest the caller names is read: the file beside the scene's folder is not looked up.
    EXPECT_EQ(camera_for_scene(scene, path, transform).eye, default_camera(scene).eye);
    Camera camera = camera_for_scene(scene, path, transform, manifest);
    EXPECT_EQ(camera.eye, Vec3(6, 2, 3));  // Ry(90) takes z to x, then translate
    EXPECT_EQ(camera.target, Vec3(1, 2, 3));
    EXPECT_EQ(camera.up, Vec3(0, 1, 0));  // rotated, not translated
    EXPECT_EQ(camera.fovy_degrees, 50.0f);
    // Not in the table: the default camera.
    const std::string other = write("scenes/thing/unlisted.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    Scene unlisted = load_scene(other);
    EXPECT_EQ(camera_for_scene(unlisted, other, {}, manifest).eye, default_camera(unlisted).eye);
    // A named manifest that cannot be read is an error, not a silent default.
    EXPECT_THROW(camera_for_scene(scene, path, transform, manifest + ".absent"), Error);
}

// ---------------------------------------------------------------- built-in scenes

TEST(BuiltinScenes, LoadAreDeterministicAndSized) {
    const std::vector<std::string> expected = {"interior", "interior-rotated", "organic", "soup"};
    EXPECT_EQ(builtin_scene_names(), expected);
    for (const std::string& name : builtin_scene_names()) {
        SCOPED_TRACE(name);
        Scene a = load_scene("builtin:" + name);
        Scene b = make_builtin_scene(name);
        EXPECT_EQ(a.name, name);
        ASSERT_EQ(a.triangles.size(), b.triangles.size());
        EXPECT_EQ(std::memcmp(a.triangles.data(), b.triangles.data(), a.triangles.size() * sizeof(Triangle)), 0);
        EXPECT_GE(a.triangles.size(), 20000u);
        EXPECT_LE(a.triangles.size(), 150000u);
        EXPECT_EQ(a.degenerate_count, b.degenerate_count);
        EXPECT_FALSE(a.bounds().is_empty());
        for (const Triangle& t : a.triangles) ASSERT_TRUE(is_finite(t.v0) && is_finite(t.v1) && is_finite(t.v2));
        Camera camera = camera_for_scene(a, "builtin:" + name, {});
        EXPECT_TRUE(is_finite(camera.eye));
    }
    EXPECT_EQ(make_builtin_scene("interior").degenerate_count, 3u);
    EXPECT_GE(make_builtin_scene("interior").triangles.size(), 50000u);
    EXPECT_GE(make_builtin_scene("interior-rotated").degenerate_count, 2u);
}

TEST(BuiltinScenes, InteriorCameraIsInsideTheRoom) {
    Scene interior = make_builtin_scene("interior");
    Camera camera = camera_for_scene(interior, "builtin:interior", {});
    EXPECT_TRUE(interior.bounds().contains(camera.eye));
    EXPECT_TRUE(interior.bounds().contains(camera.target));
}

TEST(BuiltinScenes, RotatedInteriorIsTheInteriorRotated) {
    Scene interior = make_builtin_scene("interior");
    SceneTransform rotation;
    rotation.rotate_degrees = {45, 45, 45};
    Scene rotated_by_loader = load_scene("builtin:interior", rotation);
    Scene rotated = make_builtin_scene("interior-rotated");
    EXPECT_EQ(rotated_by_loader.name, "interior@x:45,y:45,z:45");
    ASSERT_EQ(rotated.triangles.size(), interior.triangles.size());
    for (size_t i = 0; i < rotated.triangles.size(); i += 97) {
        EXPECT_EQ(rotated.triangles[i].v0, rotated_by_loader.triangles[i].v0);
        EXPECT_EQ(rotated.triangles[i].v2, rotation.apply(interior.triangles[i].v2));
    }
    Camera camera = camera_for_scene(rotated, "builtin:interior-rotated", {});
    Camera original = camera_for_scene(interior, "builtin:interior", {});
    EXPECT_EQ(camera.eye, rotation.apply(original.eye));
}

TEST(BuiltinScenes, OrganicIsWatertight) {
    // Every directed edge appears once and its reverse once: closed, consistently oriented 2-manifold.
    Scene organic = make_builtin_scene("organic");
    using Edge = std::array<float, 6>;
    auto key = [](Vec3 a, Vec3 b) { return Edge{a.x, a.y, a.z, b.x, b.y, b.z}; };
    std::map<Edge, int> edges;
    for (const Triangle& t : organic.triangles)
        for (int e = 0; e < 3; ++e) ++edges[key(t.vertex(e), t.vertex((e + 1) % 3))];
    size_t bad = 0;
    for (const auto& [edge, count] : edges) {
        auto reverse = edges.find(Edge{edge[3], edge[4], edge[5], edge[0], edge[1], edge[2]});
        if (count != 1 || reverse == edges.end() || reverse->second != 1) ++bad;
    }
    EXPECT_EQ(bad, 0u);
    EXPECT_EQ(organic.degenerate_count, 0u);
}

TEST(BuiltinScenes, UnknownNameListsValidNames) {
    try {
        load_scene("builtin:nope");
        ADD_FAILURE() << "expected an Error";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("nope"), std::string::npos) << message;
        for (const std::string& name : builtin_scene_names())
            EXPECT_NE(message.find(name), std::string::npos) << message;
    }
}

// ---------------------------------------------------------------- error corpus

struct BadInput {
    std::string file;
    std::string content;
    std::string where;  // must appear in the message (besides the file name)
};

std::string binary_ply_header(const std::string& vertex_count, const std::string& face_count,
                              const std::string& index_type = "int") {
    return "ply\nformat binary_little_endian 1.0\nelement vertex " + vertex_count +
           "\nproperty float x\nproperty float y\nproperty float z\nelement face " + face_count +
           "\nproperty list uchar " + index_type + " vertex_indices\nend_header\n";
}

std::string three_binary_vertices(float nan_at_y = 0) {
    std::string out;
    const float v[3][3] = {{0, 0, 0}, {1, nan_at_y, 0}, {0, 1, 0}};
    for (auto& p : v)
        for (float c : p) put<float>(out, c, false);
    return out;
}

std::string binary_face(std::initializer_list<int32_t> indices) {
    std::string out;
    put<uint8_t>(out, static_cast<uint8_t>(indices.size()), false);
    for (int32_t i : indices) put<int32_t>(out, i, false);
    return out;
}

const std::string kAsciiPlyHeader =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";  // body starts at line 10

std::vector<BadInput> bad_inputs() {
    // Binary PLY messages give absolute file offsets: the header is followed by 3 x 12 vertex bytes.
    const size_t body = binary_ply_header("3", "1").size();
    const std::string at_face = "(byte offset " + std::to_string(body + 36) + ")";
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    const std::string nan_bits = [] {
        std::string s = three_binary_vertices(std::numeric_limits<float>::quiet_NaN());
        return s;
    }();
    return {
        // OBJ
        {"malformed.obj", tri + "v 1 2 x3\nf 1 2 3\n", "malformed.obj:4:"},
        {"nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", "nan.obj:2:"},
        {"inf.obj", "v 0 0 0\nv 1 0 -inf\nv 0 1 0\nf 1 2 3\n", "inf.obj:2:"},
        {"huge.obj", "v 0 0 0\nv 1 0 1e60\nv 0 1 0\nf 1 2 3\n", "huge.obj:2:"},
        {"short_vertex.obj", tri + "v 1 2\n", "short_vertex.obj:4:"},
        {"index_range.obj", tri + "f 1 2 3\nf 1 2 4\n", "index_range.obj:5:"},
        {"index_zero.obj", tri + "f 0 1 2\n", "index_zero.obj:4:"},
        {"index_negative.obj", tri + "f -1 -2 -4\n", "index_negative.obj:4:"},
        {"index_overflow.obj", tri + "f 1 2 99999999999999999999999\n", "index_overflow.obj:4:"},
        {"two_vertices.obj", tri + "f 1 2\n", "two_vertices.obj:4:"},
        {"bad_index.obj", tri + "f 1 2 3x\n", "bad_index.obj:4:"},
        {"bad_slash.obj", tri + "f 1/a 2 3\n", "bad_slash.obj:4:"},
        {"no_faces.obj", tri + "vn 0 0 1\n", "no triangles"},
        {"empty.obj", "", "no triangles"},
        // ascii PLY
        {"no_magic.ply", "plx\nformat ascii 1.0\nend_header\n", "no_magic.ply:1:"},
        {"no_end.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", "no_end.ply:4:"},
        {"bad_type.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty quad x\nend_header\n", "bad_type.ply:4:"},
        {"bad_format.ply", "ply\nformat ebcdic 1.0\nend_header\n", "bad_format.ply:2:"},
        {"bad_count.ply", "ply\nformat ascii 1.0\nelement vertex -3\nend_header\n", "bad_count.ply:3:"},
        {"ascii_malformed.ply", kAsciiPlyHeader + "0 0 0\n1 0x 0\n0 1 0\n3 0 1 2\n", "ascii_malformed.ply:11:"},
        {"ascii_nan.ply", kAsciiPlyHeader + "0 0 0\n1 0 0\n0 NaN 0\n3 0 1 2\n", "ascii_nan.ply:12:"},
        {"ascii_truncated.ply", kAsciiPlyHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "element 'face' #0"},
        {"ascii_range.ply", kAsciiPlyHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "ascii_range.ply:13:"},
        {"ascii_negative.ply", kAsciiPlyHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "ascii_negative.ply:13:"},
        {"ascii_two.ply", kAsciiPlyHeader + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "ascii_two.ply:13:"},
        {"ascii_fraction.ply", kAsciiPlyHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", "ascii_fraction.ply:13:"},
        {"ascii_huge_count.ply",
         "ply\nformat ascii 1.0\nelement vertex 99999999999\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n",
         "ascii_huge_count.ply:3:"},
        {"no_face.ply",
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n",
         "no 'face'"},
        {"no_xyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
         "no_xyz.ply:3:"},
        // binary PLY
        {"bin_truncated.ply",
         binary_ply_header("3", "1") + three_binary_vertices() + binary_face({0, 1, 2}).substr(0, 7),
         "element 'face' #0 " + at_face},
        {"bin_truncated_vertex.ply", binary_ply_header("3", "1") + three_binary_vertices().substr(0, 30),
         "bin_truncated_vertex.ply:3: element 'vertex' count 3 cannot fit"},
        {"bin_absurd.ply", binary_ply_header("4000000000", "1") + three_binary_vertices() + binary_face({0, 1, 2}),
         "cannot fit"},
        {"bin_absurd_faces.ply",
         binary_ply_header("3", "4000000000") + three_binary_vertices() + binary_face({0, 1, 2}), "cannot fit"},
        {"bin_nan.ply", binary_ply_header("3", "1") + nan_bits + binary_face({0, 1, 2}), "element 'vertex' #1"},
        {"bin_negative.ply", binary_ply_header("3", "1") + three_binary_vertices() + binary_face({0, -1, 2}),
         "element 'face' #0 " + at_face},
        {"bin_range.ply", binary_ply_header("3", "1") + three_binary_vertices() + binary_face({0, 1, 7}),
         "element 'face' #0"},
        {"bin_one.ply", binary_ply_header("3", "1") + three_binary_vertices() + binary_face({0}), "element 'face' #0"},
        {"bin_empty_faces.ply", binary_ply_header("3", "0") + three_binary_vertices(), "no triangles"},
        // glTF
        {"bad_json.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"scenes\": [ }", "invalid glTF"},
        {"no_asset.gltf", "{}", "invalid glTF"},
        {"empty_scene.gltf", R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"scene":0})", "no triangles"},
        {"not_glb.glb", "this is not a glb file at all", "byte offset 0"},
        {"truncated.glb", make_glb(gltf_json(R"({"byteLength":120})"), gltf_buffer()).substr(0, 300), "byte offset 8"},
        {"missing_bin.gltf", gltf_json(R"({"byteLength":120,"uri":"nowhere.bin"})"), "nowhere.bin"},
    };
}

TEST_F(SceneFiles, ErrorCorpusNamesFileAndPlace) {
    for (const BadInput& bad : bad_inputs()) {
        SCOPED_TRACE(bad.file);
        expect_load_error(write(bad.file, bad.content), bad.where);
    }
}

// glTF structures that parse as JSON but point outside their data.
TEST_F(SceneFiles, GltfBadAccessorsAreReportedWithElement) {
    const std::string bin = gltf_buffer();
    auto glb_with = [&](const std::string& from, const std::string& to, std::string bytes = "") {
        std::string json = gltf_json(R"({"byteLength":120})");
        json.replace(json.find(from), from.size(), to);
        return make_glb(json, bytes.empty() ? bin : bytes);
    };
    // Count larger than the buffer view (an absurd count must not allocate or read out of bounds).
    expect_load_error(write("count.glb", glb_with("\"count\":4,", "\"count\":4000000000,")), "accessor 0");
    // Index 9 in a 4-vertex accessor.
    std::string bad_index = bin;
    bad_index[48 + 2 * 4] = 9;
    expect_load_error(write("index.glb", glb_with("", "", bad_index)), "indices accessor 1 element 4");
    // NaN position.
    std::string nan_position = bin;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(&nan_position[12 * 2 + 4], &nan, 4);
    expect_load_error(write("nan.glb", glb_with("", "", nan_position)), "POSITION accessor 0 element 2");
    // Buffer view past the end of the buffer.
    expect_load_error(
        write("view.glb", glb_with("\"byteOffset\":60,\"byteLength\":60", "\"byteOffset\":60,\"byteLength\":600")),
        "buffer view");
    // A node that is its own child.
    expect_load_error(write("cycle.glb", glb_with("\"scale\":[2,2,2],", "\"scale\":[2,2,2],\"children\":[1],")),
                      "node 1");
    // Accessor that does not exist.
    expect_load_error(write("missing.glb", glb_with("\"POSITION\":0", "\"POSITION\":42")), "accessor 42");
}

TEST_F(SceneFiles, MissingFileUnknownFormatAndDirectory) {
    expect_load_error((dir_ / "absent.obj").string(), "cannot open");
    expect_load_error(write("scene.stl", "solid x\n"), "unknown scene format");
    expect_load_error(write("noextension", "v 0 0 0\n"), "unknown scene format");
    fs::create_directories(dir_ / "folder.obj");
    expect_load_error((dir_ / "folder.obj").string(), "directory");
}

TEST_F(SceneFiles, TransformThatOverflowsIsAnError) {
    const std::string path = write("big.obj", "v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n");
    SceneTransform transform;
    transform.scale = 1e30f;
    EXPECT_THROW(load_scene(path, transform), Error);
    transform.scale = 0.0f;
    EXPECT_THROW(load_scene(path, transform), Error);
}

// ---------------------------------------------------------------- shared scenes (when present)

const std::string kShared = SPACEBVH_SHARED_DIR;

TEST(SharedScenes, Bunny) {
    const std::string path = kShared + "/scenes/bunny/bunny.obj";
    if (!fs::exists(path)) GTEST_SKIP() << path << " not present";
    Scene scene = load_scene(path);
    EXPECT_EQ(scene.name, "bunny");
    EXPECT_EQ(scene.triangles.size(), 69451u);
    EXPECT_EQ(scene.degenerate_count, 0u);
    // MANIFEST bounding box over referenced vertices.
    const AABB box = scene.bounds();
    EXPECT_EQ(box.lo, Vec3(-0.09469f, 0.032987f, -0.061874f));
    EXPECT_EQ(box.hi, Vec3(0.061009f, 0.187321f, 0.0588f));
    const Camera camera = camera_for_scene(scene, path, {}, kShared + "/scenes/MANIFEST.md");
    EXPECT_EQ(camera.eye, Vec3(-0.016f, 0.11f, 0.25f));
    EXPECT_EQ(camera.fovy_degrees, 45.0f);
}

TEST(SharedScenes, CrytekSponzaAndItsRotatedVariant) {
    const std::string path = kShared + "/scenes/crytek_sponza/crytek_sponza.obj";
    if (!fs::exists(path)) GTEST_SKIP() << path << " not present";
    Scene scene = load_scene(path);
    EXPECT_EQ(scene.triangles.size(), 262205u);
    EXPECT_EQ(scene.degenerate_count, 1u);  // MANIFEST: 1 zero-area triangle (float32)
    const AABB box = scene.bounds();
    EXPECT_EQ(box.lo, Vec3(-192.095f, -12.6443f, -118.281f));
    EXPECT_EQ(box.hi, Vec3(179.991f, 142.943f, 110.543f));

    SceneTransform rotation;
    rotation.rotate_degrees = SceneTransform::parse_rotation("x:45,y:45,z:45");
    Scene rotated = load_scene(path, rotation);
    EXPECT_EQ(rotated.name, "crytek_sponza@x:45,y:45,z:45");
    ASSERT_EQ(rotated.triangles.size(), scene.triangles.size());
    EXPECT_EQ(rotated.triangles[1000].v1, rotation.apply(scene.triangles[1000].v1));
    const Camera camera = camera_for_scene(rotated, path, rotation, kShared + "/scenes/MANIFEST.md");
    EXPECT_EQ(camera.eye, rotation.apply(Vec3(-110, 20, -4)));
    EXPECT_EQ(camera.target, rotation.apply(Vec3(0, 35, -4)));
    EXPECT_EQ(camera.up, rotation.apply(Vec3(0, 1, 0)));
    EXPECT_EQ(camera.fovy_degrees, 60.0f);
}

TEST(IndexedScene, BuildsTrianglesInIndexOrderAndCountsDegenerates) {
    const std::vector<float> vertices = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 2, 2};
    const std::vector<int64_t> indices = {0, 1, 2, 3, 2, 1, 0, 0, 3};  // the last one has a repeated vertex
    const Scene scene = make_indexed_scene(vertices, indices, "mesh");
    ASSERT_EQ(scene.triangles.size(), 3u);
    EXPECT_EQ(scene.triangles[1].v0, Vec3(2, 2, 2));
    EXPECT_EQ(scene.triangles[1].v1, Vec3(0, 1, 0));
    EXPECT_EQ(scene.triangles[1].v2, Vec3(1, 0, 0));
    EXPECT_EQ(scene.degenerate_count, 1u);
    EXPECT_EQ(scene.name, "mesh");
}

TEST(IndexedScene, RejectsBadArraysNamingTheElement) {
    const std::vector<float> vertices = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    auto message = [](auto&& call) {
        try {
            call();
        } catch (const Error& error) {
            return std::string(error.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message([&] {
                  make_indexed_scene(vertices, std::vector<int64_t>{0, 1, 3}, "m");
              }).find("triangle 0 uses vertex 3"),
              std::string::npos);
    EXPECT_NE(message([&] {
                  make_indexed_scene(vertices, std::vector<int64_t>{0, -1, 2}, "m");
              }).find("vertex -1"),
              std::string::npos);
    EXPECT_NE(message([&] { make_indexed_scene(vertices, std::vector<int64_t>{}, "m"); }).find("no triangles"),
              std::string::npos);
    EXPECT_NE(message([&] {
                  make_indexed_scene(vertices, std::vector<int64_t>{0, 1}, "m");
              }).find("not a multiple of 3"),
              std::string::npos);
    EXPECT_NE(message([&] {
                  make_indexed_scene(std::vector<float>{0, 0}, std::vector<int64_t>{0, 0, 0}, "m");
              }).find("not a multiple of 3"),
              std::string::npos);
    std::vector<float> nan_vertices = vertices;
    nan_vertices[4] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_NE(message([&] {
                  make_indexed_scene(nan_vertices, std::vector<int64_t>{0, 1, 2}, "m");
              }).find("vertex 1"),
              std::string::npos);
    nan_vertices[4] = std::numeric_limits<float>::infinity();
    EXPECT_NE(message([&] {
                  make_indexed_scene(nan_vertices, std::vector<int64_t>{0, 1, 2}, "m");
              }).find("not finite"),
              std::string::npos);
}

TEST(SharedScenes, AllScenesMatchManifestCounts) {
    // name, triangles, zero-area triangles (float32 column of the MANIFEST degeneracy table).
    const std::vector<std::tuple<std::string, size_t, size_t>> scenes = {{"bunny", 69451, 0},
                                                                         {"sibenik", 73564, 8},
                                                                         {"coffee_maker", 235271, 224},
                                                                         {"crytek_sponza", 262205, 1},
                                                                         {"living_room_3", 786208, 256}};
    for (const auto& [name, triangles, degenerate] : scenes) {
        const std::string path = kShared + "/scenes/" + name + "/" + name + ".obj";
        if (!fs::exists(path)) GTEST_SKIP() << path << " not present";
        Scene scene = load_scene(path);
        EXPECT_EQ(scene.triangles.size(), triangles) << name;
        EXPECT_EQ(scene.degenerate_count, degenerate) << name;
    }
}

}  // namespace
}  // namespace spacebvh
