// SPDX-License-Identifier: MIT
// Writes the seed corpora of the fuzz targets: small files of every format made from built-in
// geometry, and the first bytes of the scene files in a scene folder when one is given.
// Usage: fuzz_make_seeds OUT_DIR [SCENES_DIR]   (OUT_DIR/<target>/<seed>)
#include <bit>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "fuzz_targets.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/scene_file.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/tree_file.hpp"

namespace fs = std::filesystem;
using namespace spacebvh;

namespace {

fs::path out_root;

void write_seed(const std::string& target, const std::string& name, std::string_view bytes) {
    const fs::path dir = out_root / target;
    fs::create_directories(dir);
    std::ofstream out(dir / name, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

// An indexed mesh: vertices shared between triangles, as the file formats store them.
struct IndexedMesh {
    std::vector<Vec3> vertices;
    std::vector<uint32_t> indices;
};

IndexedMesh indexed(const std::vector<Triangle>& triangles) {
    IndexedMesh mesh;
    for (const Triangle& t : triangles)
        for (int v = 0; v < 3; ++v) {
            const Vec3 p = t.vertex(v);
            uint32_t index = 0;
            while (index < mesh.vertices.size() && !(mesh.vertices[index] == p)) ++index;
            if (index == mesh.vertices.size()) mesh.vertices.push_back(p);
            mesh.indices.push_back(index);
        }
    return mesh;
}

std::string obj_text(const IndexedMesh& mesh, bool fancy) {
    std::ostringstream out;
    out.precision(9);
    out << "# spacebvh fuzz seed\no mesh\n";
    for (const Vec3& p : mesh.vertices) out << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
    if (fancy) out << "vt 0 0\nvn 0 0 1\ng group\nusemtl m\ns 1\n";
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        out << 'f';
        for (int c = 0; c < 3; ++c) {
            const uint32_t i = mesh.indices[t + c];
            if (!fancy)
                out << ' ' << i + 1;
            else if (t % 2 == 0)
                out << ' ' << i + 1 << "/1/1";
            else
                out << ' ' << int64_t(i) - int64_t(mesh.vertices.size()) << "//1";
        }
        out << '\n';
    }
    if (fancy) out << "f 1 2 3 4 5\nl 1 2\n";
    return out.str();
}

enum class PlyEncoding { ascii, little, big };

template <class T>
void put_binary(std::string& out, T value, bool big) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (big) std::reverse(bytes, bytes + sizeof(T));
    out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

std::string ply_bytes(const IndexedMesh& mesh, PlyEncoding encoding, bool extras) {
    const char* format = encoding == PlyEncoding::ascii    ? "ascii"
                         : encoding == PlyEncoding::little ? "binary_little_endian"
                                                           : "binary_big_endian";
    std::ostringstream header;
    header << "ply\nformat " << format << " 1.0\ncomment spacebvh fuzz seed\n";
    header << "element vertex " << mesh.vertices.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
    if (extras) header << "property uchar red\nproperty double confidence\n";
    header << "element face " << mesh.indices.size() / 3 << "\n";
    header << (extras ? "property list uint int vertex_indices\nproperty list uchar float texcoord\n"
                      : "property list uchar uint vertex_indices\n");
    if (extras) header << "element edge 1\nproperty int vertex1\nproperty int vertex2\n";
    header << "end_header\n";
    std::string out = header.str();
    const bool big = encoding == PlyEncoding::big;
    if (encoding == PlyEncoding::ascii) {
        std::ostringstream body;
        body.precision(9);
        for (const Vec3& p : mesh.vertices) body << p.x << ' ' << p.y << ' ' << p.z << (extras ? " 255 0.5\n" : "\n");
        for (size_t t = 0; t < mesh.indices.size(); t += 3)
            body << "3 " << mesh.indices[t] << ' ' << mesh.indices[t + 1] << ' ' << mesh.indices[t + 2]
                 << (extras ? " 2 0.5 0.25\n" : "\n");
        if (extras) body << "0 1\n";
        return out + body.str();
    }
    for (const Vec3& p : mesh.vertices) {
        for (int axis = 0; axis < 3; ++axis) put_binary(out, p[axis], big);
        if (extras) {
            put_binary<uint8_t>(out, 255, big);
            put_binary(out, 0.5, big);
        }
    }
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        if (extras)
            put_binary<uint32_t>(out, 3, big);
        else
            put_binary<uint8_t>(out, 3, big);
        for (int c = 0; c < 3; ++c) {
            if (extras)
                put_binary<int32_t>(out, int32_t(mesh.indices[t + c]), big);
            else
                put_binary<uint32_t>(out, mesh.indices[t + c], big);
        }
        if (extras) {
            put_binary<uint8_t>(out, 2, big);
            put_binary(out, 0.5f, big);
            put_binary(out, 0.25f, big);
        }
    }
    if (extras) {
        put_binary<int32_t>(out, 0, big);
        put_binary<int32_t>(out, 1, big);
    }
    return out;
}

std::string base64(std::string_view bytes) {
    static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < bytes.size(); i += 3) {
        const size_t n = std::min<size_t>(3, bytes.size() - i);
        uint32_t word = 0;
        for (size_t k = 0; k < 3; ++k) word = (word << 8) | (k < n ? uint8_t(bytes[i + k]) : 0u);
        out += digits[(word >> 18) & 63];
        out += digits[(word >> 12) & 63];
        out += n > 1 ? digits[(word >> 6) & 63] : '=';
        out += n > 2 ? digits[word & 63] : '=';
    }
    return out;
}

// glTF 2.0: one mesh with positions and indices of `index_type` (5121, 5123, 5125) in primitive
// `mode`, placed by two nodes (a TRS parent and a matrix child). GLB puts the buffer in its BIN chunk.
std::string gltf_bytes(const IndexedMesh& mesh, int index_type, int mode, bool glb) {
    std::string buffer;
    Vec3 low = mesh.vertices[0], high = mesh.vertices[0];
    for (const Vec3& p : mesh.vertices) {
        for (int axis = 0; axis < 3; ++axis) put_binary(buffer, p[axis], false);
        low = min(low, p);
        high = max(high, p);
    }
    const size_t index_offset = buffer.size();
    for (uint32_t i : mesh.indices) {
        if (index_type == 5121)
            put_binary<uint8_t>(buffer, uint8_t(i), false);
        else if (index_type == 5123)
            put_binary<uint16_t>(buffer, uint16_t(i), false);
        else
            put_binary<uint32_t>(buffer, i, false);
    }
    while (buffer.size() % 4 != 0) buffer += '\0';
    std::ostringstream json;
    json << R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],)"
         << R"("nodes":[{"children":[1],"translation":[1,2,3],"rotation":[0,0,0.7071068,0.7071068],"scale":[1,2,1]},)"
         << R"({"mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0.5,0,0,1]}],)"
         << R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":)" << mode << "}]}],"
         << R"("accessors":[{"bufferView":0,"componentType":5126,"count":)" << mesh.vertices.size()
         << R"(,"type":"VEC3","min":[)" << low.x << ',' << low.y << ',' << low.z << "],\"max\":[" << high.x << ','
         << high.y << ',' << high.z << "]},"
         << R"({"bufferView":1,"componentType":)" << index_type << ",\"count\":" << mesh.indices.size()
         << R"(,"type":"SCALAR"}],)"
         << R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":)" << index_offset << "},"
         << R"({"buffer":0,"byteOffset":)" << index_offset << ",\"byteLength\":" << buffer.size() - index_offset
         << "}],"
         << R"("buffers":[{"byteLength":)" << buffer.size();
    if (!glb) json << R"(,"uri":"data:application/octet-stream;base64,)" << base64(buffer) << '"';
    json << "}]}";
    std::string text = json.str();
    if (!glb) return text;
    while (text.size() % 4 != 0) text += ' ';
    std::string out = "glTF";
    put_binary<uint32_t>(out, 2, false);
    put_binary<uint32_t>(out, uint32_t(12 + 8 + text.size() + 8 + buffer.size()), false);
    put_binary<uint32_t>(out, uint32_t(text.size()), false);
    out += "JSON" + text;
    put_binary<uint32_t>(out, uint32_t(buffer.size()), false);
    out += std::string("BIN\0", 4) + buffer;
    return out;
}

// glTF 2.0 as an instanced scene: the mesh placed by three nodes (a parent's T * R * S, a mirroring
// matrix child, a root) and by a node with EXT_mesh_gpu_instancing entries (translations, rotations
// as normalized shorts, scales).
std::string gltf_instanced_bytes(const IndexedMesh& mesh) {
    std::string buffer;
    for (const Vec3& p : mesh.vertices)
        for (int axis = 0; axis < 3; ++axis) put_binary(buffer, p[axis], false);
    const size_t index_offset = buffer.size();
    for (uint32_t i : mesh.indices) put_binary<uint32_t>(buffer, i, false);
    const size_t entries_offset = buffer.size();
    for (float v : {0.0f, 0.0f, 0.0f, 5.0f, 1.0f, -2.0f, -4.0f, 3.0f, 8.0f}) put_binary(buffer, v, false);
    const size_t rotations_offset = buffer.size();
    for (int16_t v : {0, 0, 0, 32767, 0, 23170, 0, 23170, 16384, 16384, 16384, 16384})
        put_binary<int16_t>(buffer, v, false);
    const size_t scales_offset = buffer.size();
    for (float v : {1.0f, 1.0f, 1.0f, -1.0f, 2.0f, 0.5f, 0.3f, 0.3f, 0.3f}) put_binary(buffer, v, false);
    std::ostringstream json;
    json << R"({"asset":{"version":"2.0"},"extensionsUsed":["EXT_mesh_gpu_instancing"],"scene":0,)"
         << R"("scenes":[{"nodes":[0,2,3]}],"nodes":[)"
         << R"({"children":[1],"translation":[1,2,3],"rotation":[0,0,0.7071068,0.7071068],"scale":[1,2,1],"mesh":0},)"
         << R"({"mesh":0,"matrix":[-1,0,0,0,0,1,0,0,0,0,1,0,0.5,0,0,1]},{"mesh":0,"translation":[9,0,0]},)"
         << R"({"mesh":0,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":2,"ROTATION":3,)"
         << R"("SCALE":4}}}}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],)"
         << R"("accessors":[{"bufferView":0,"componentType":5126,"count":)" << mesh.vertices.size()
         << R"(,"type":"VEC3"},{"bufferView":1,"componentType":5125,"count":)" << mesh.indices.size()
         << R"(,"type":"SCALAR"},{"bufferView":2,"componentType":5126,"count":3,"type":"VEC3"},)"
         << R"({"bufferView":3,"componentType":5122,"normalized":true,"count":3,"type":"VEC4"},)"
         << R"({"bufferView":4,"componentType":5126,"count":3,"type":"VEC3"}],"bufferViews":[)";
    const size_t offsets[] = {0, index_offset, entries_offset, rotations_offset, scales_offset, buffer.size()};
    for (int v = 0; v < 5; ++v)
        json << (v ? "," : "") << R"({"buffer":0,"byteOffset":)" << offsets[v] << R"(,"byteLength":)"
             << offsets[v + 1] - offsets[v] << "}";
    json << R"(],"buffers":[{"byteLength":)" << buffer.size() << R"(,"uri":"data:application/octet-stream;base64,)"
         << base64(buffer) << R"("}]})";
    return json.str();
}

// Scene files of a few shapes over the fuzz geometry: one mesh; two meshes around a detached slot,
// traced by bvh4; three levels (a mesh scene instanced rotated and mirrored inside a scene that has
// a mesh of its own, placed scaled by the root), with masks on every level.
std::vector<std::pair<std::string, std::vector<std::byte>>> scene_files(const std::vector<Triangle>& geometry) {
    const std::vector<Triangle> half(geometry.begin(), geometry.begin() + geometry.size() / 2);
    std::vector<std::pair<std::string, std::vector<std::byte>>> files;
    auto one = std::make_shared<RenderScene>(SceneConfig{}, "one");
    one->attach_mesh(MeshView(geometry), 0x1u);
    one->commit();
    files.push_back({"one_mesh", serialize_render_scene(*one, "--builder binned")});

    SceneConfig bvh4;
    bvh4.tracer = TracerConfig{Kernel::bvh4};
    bvh4.recipe = TreeRecipe::for_builder("spatial");
    RenderScene two(bvh4, "two");
    two.attach_mesh(MeshView(half), 0x2u);
    two.detach(two.attach_mesh(MeshView(geometry)));
    two.attach_mesh(MeshView(geometry), 0x4u);
    two.commit();
    files.push_back({"two_meshes_detached_slot", serialize_render_scene(two)});

    const Affine rotated{{0, -1, 0, 3, 1, 0, 0, -2, 0, 0, 1, 0.5f}};
    const Affine mirrored{{-1, 0, 0, 9, 0, 1, 0, 0, 0, 0, 1, 0}};
    const Affine scaled{{2, 0, 0, 0, 0, 0.5f, 0, 1, 0, 0, 3, -1}};
    auto middle = std::make_shared<RenderScene>(SceneConfig{}, "middle");
    middle->attach_instance(one, rotated, 0x3u);
    middle->attach_instance(one, mirrored, 0x4u);
    middle->attach_mesh(MeshView(half), 0x8u);
    middle->commit();
    RenderScene root(SceneConfig{}, "root");
    root.attach_instance(middle, scaled, 0x5u);
    root.attach_instance(one, Affine::identity());
    root.commit();
    files.push_back({"nested", serialize_render_scene(root, "nested")});
    return files;
}

std::string read_bytes(const fs::path& path, size_t limit) {
    std::ifstream in(path, std::ios::binary);
    std::string bytes(limit, '\0');
    in.read(bytes.data(), std::streamsize(limit));
    bytes.resize(size_t(in.gcount()));
    return bytes;
}

std::string file_bytes_of(const std::string& path) { return read_bytes(path, size_t(1) << 30); }

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2 || argc > 3) {
        std::cerr << "usage: fuzz_make_seeds OUT_DIR [SCENES_DIR]\n";
        return 2;
    }
    out_root = argv[1];
    const std::vector<Triangle>& geometry = fuzz::fuzz_geometry();
    std::vector<std::pair<std::string, IndexedMesh>> meshes = {{"grid", indexed(geometry)}};
    for (const char* name : {"organic", "soup"}) {  // the first triangles of two built-in scenes
        const tools::Scene scene = tools::make_builtin_scene(name);
        const size_t count = std::min<size_t>(scene.triangles.size(), 40);
        meshes.push_back({name, indexed({scene.triangles.begin(), scene.triangles.begin() + count})});
    }

    for (const auto& [name, mesh] : meshes) {
        write_seed("obj", name + ".obj", obj_text(mesh, false));
        write_seed("obj", name + "_records.obj", obj_text(mesh, true));
        write_seed("ply", name + "_ascii.ply", ply_bytes(mesh, PlyEncoding::ascii, false));
        write_seed("ply", name + "_little.ply", ply_bytes(mesh, PlyEncoding::little, false));
        write_seed("ply", name + "_big.ply", ply_bytes(mesh, PlyEncoding::big, false));
        write_seed("ply", name + "_ascii_extras.ply", ply_bytes(mesh, PlyEncoding::ascii, true));
        write_seed("ply", name + "_little_extras.ply", ply_bytes(mesh, PlyEncoding::little, true));
        if (mesh.vertices.size() <= 255) write_seed("gltf", name + "_u8.gltf", gltf_bytes(mesh, 5121, 4, false));
        write_seed("gltf", name + "_u16_strip.gltf", gltf_bytes(mesh, 5123, 5, false));
        write_seed("gltf", name + "_u32.glb", gltf_bytes(mesh, 5125, 4, true));
        write_seed("gltf", name + "_u16_fan.glb", gltf_bytes(mesh, 5123, 6, true));
        write_seed("gltf_instances", name + "_nodes.gltf", gltf_instanced_bytes(mesh));
        write_seed("gltf_instances", name + "_u32.glb", gltf_bytes(mesh, 5125, 4, true));
    }

    // Ray and hit files through the writers, then read back as bytes.
    const fs::path scratch = out_root / "scratch";
    fs::create_directories(scratch);
    const std::vector<Ray> rays = tools::generate_random_rays(bounds_of(geometry), 5, 1);
    for (size_t count : {size_t(0), size_t(1), rays.size()}) {
        const std::string ray_path = (scratch / "seed.rays").string(), hit_path = (scratch / "seed.hits").string();
        tools::write_ray_file(ray_path, std::span(rays).first(count));
        std::vector<tools::HitRecord> hits(count);
        for (size_t i = 0; i < count; ++i)
            hits[i] = i % 2 ? tools::occlusion_record(true) : tools::HitRecord{1.5f, uint32_t(i)};
        tools::write_hit_file(hit_path, hits);
        write_seed("ray_file", std::to_string(count) + ".rays", file_bytes_of(ray_path));
        write_seed("hit_file", std::to_string(count) + ".hits", file_bytes_of(hit_path));
    }
    fs::remove_all(scratch);

    // Tree files of several builders over the fuzz geometry, with the mode byte in front.
    for (const std::string& builder : builder_names()) {
        const Bvh bvh = build(MeshView(geometry), config_for(builder));
        const std::vector<std::byte> file = serialize_bvh(bvh, geometry, "--builder " + builder);
        const std::string bytes(reinterpret_cast<const char*>(file.data()), file.size());
        write_seed("tree_file", builder + "_checked.sbvh", std::string(1, '\0') + bytes);
        write_seed("tree_file", builder + "_repaired.sbvh", std::string(1, '\1') + bytes);
    }

    // Scene files, with the same mode byte in front.
    for (const auto& [name, file] : scene_files(geometry)) {
        const std::string bytes(reinterpret_cast<const char*>(file.data()), file.size());
        write_seed("scene_file", name + "_checked.sbvh", std::string(1, '\0') + bytes);
        write_seed("scene_file", name + "_repaired.sbvh", std::string(1, '\1') + bytes);
    }

    // Rows of `compare --builders`.
    std::vector<std::string> rows = {
        "binned",
        "binned+opt@budget=1.5",
        "spatial@co=0.3;ct=3;ci=1;leaf=8;block=4;budget=1.5;bins=64;spatialbins=64;gate=1e-5;search=object+grid;"
        "grid=2;gridmax=8;lookahead=2;top=0.25;optimize=16",
        "spatial@sweep=1;samples=4;candidates=3",
        "embree-high@ct=2",
        "binned@co=inf"};
    for (const std::string& name : builder_names()) rows.push_back(name);
    for (size_t i = 0; i < rows.size(); ++i) write_seed("builder_spec", "row" + std::to_string(i), rows[i]);

    // The first bytes of outside scene files: real exporters' headers and number formats.
    if (argc == 3 && fs::is_directory(argv[2])) {
        for (const auto& entry : fs::recursive_directory_iterator(argv[2])) {
            if (!entry.is_regular_file()) continue;
            std::string extension = entry.path().extension().string();
            for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
            const std::string target = extension == ".obj"                           ? "obj"
                                       : extension == ".ply"                         ? "ply"
                                       : extension == ".gltf" || extension == ".glb" ? "gltf"
                                                                                     : "";
            if (target.empty()) continue;
            const std::string stem = "shared_" + entry.path().stem().string();
            std::string head = read_bytes(entry.path(), 8192);
            if (target != "obj") {
                write_seed(target, stem + extension, head);
                continue;
            }
            // An OBJ's head is all vertices: the first face records make a second seed.
            auto whole_lines = [](std::string text) {
                if (text.rfind('\n') != std::string::npos) text.resize(text.rfind('\n') + 1);
                return text;
            };
            write_seed(target, stem + extension, whole_lines(head));
            const std::string all = file_bytes_of(entry.path().string());
            const size_t faces = all.find("\nf ");
            if (faces != std::string::npos)
                write_seed(target, stem + "_faces" + extension,
                           whole_lines(head.substr(0, 2048)) + whole_lines(all.substr(faces + 1, 4096)));
        }
    }
    return 0;
}
