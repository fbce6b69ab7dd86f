// SPDX-License-Identifier: MIT
// glTF 2.0 reader (.gltf and .glb) on top of tinygltf (header-only, Debian libtinygltf-dev 2.7).
// Triangles of every mesh instance in the default scene (or of all scenes when there is no default),
// in node order (depth first, children in listed order) and primitive order, with node transforms
// (matrix, or T * R * S) composed down the hierarchy. tinygltf parses the JSON and loads the buffers,
// through our file callbacks: only regular files inside the glTF's folder, of bounded size, are read
// (a URI naming a folder or a device would otherwise make tinygltf allocate the 2^63 - 1 bytes its
// stream reports). gltf_mesh.cpp decodes the meshes, checking every accessor against its buffer.
#define TINYGLTF_IMPLEMENTATION
#include "tools/scene/gltf_internal.hpp"

#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace spacebvh::tools::scene_detail {
namespace {

namespace fs = std::filesystem;

// Images are irrelevant for ray tracing geometry: accept and ignore them.
bool ignore_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
    return true;
}

// Names and tinygltf's messages (which quote names from the file as they are) with bytes outside
// printable ASCII as \xNN, and at most the last `most` characters.
std::string printable(const std::string& text, size_t most = std::string::npos) {
    std::string shown = text.size() > most ? "..." : "";
    for (char c : std::string_view(text).substr(text.size() > most ? text.size() - most : 0)) {
        const auto u = static_cast<unsigned char>(c);
        if ((u >= 32 && u < 127) || c == '\n') {
            shown += c;
        } else {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", u);
            shown += hex;
        }
    }
    return shown;
}

// The folder external buffers must lie in (canonical), for the file callbacks below.
struct BufferFolder {
    fs::path folder;
};

// Every name "exists" as far as tinygltf's search goes, so that the first candidate (the URI joined
// to the glTF's folder) reaches read_buffer_file, which says precisely why it cannot be read.
bool any_name_exists(const std::string& name, void*) { return !name.empty(); }
// No `~` or `$VAR` expansion (tinygltf's default runs wordexp): a URI is a path relative to the glTF.
std::string keep_path(const std::string& name, void*) { return name; }
bool refuse_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
    if (err) *err = "writing files is not supported";
    return false;
}

bool read_buffer_file(std::vector<unsigned char>* out, std::string* err, const std::string& name, void* user) {
    auto refuse = [&](const std::string& why) {
        if (err) *err = "buffer file '" + printable(name, 300) + "' " + why;
        return false;
    };
    if (name.find('\0') != std::string::npos) return refuse("has a NUL byte in its name");
    std::error_code error;
    const fs::path resolved = fs::weakly_canonical(fs::absolute(fs::path(name), error), error);
    if (error) return refuse("cannot be resolved: " + error.message());
    const fs::path inside = resolved.lexically_relative(static_cast<const BufferFolder*>(user)->folder);
    if (inside.empty() || *inside.begin() == "..") return refuse("lies outside the glTF's folder");
    const fs::file_status status = fs::status(resolved, error);
    if (error || !fs::is_regular_file(status)) return refuse("is not a regular file");
    const uintmax_t size = fs::file_size(resolved, error);
    if (error) return refuse("has no size: " + error.message());
    if (size > kMaxGltfBufferFileBytes)
        return refuse("is " + std::to_string(size) + " bytes, more than the " +
                      std::to_string(kMaxGltfBufferFileBytes) + " a glTF buffer may have");
    std::ifstream in(resolved, std::ios::binary);
    out->resize(size);
    if (!in || !in.read(reinterpret_cast<char*>(out->data()), std::streamsize(size))) {
        out->clear();
        return refuse("could not be read");
    }
    return true;
}

// GLB container (glTF 2.0 spec, section 4.4): checked here so that a truncated or lying header is
// reported with its byte offset instead of reaching tinygltf.
void check_glb_container(const std::string& path, std::string_view bytes) {
    auto u32 = [&](size_t offset) {
        uint32_t v;
        std::memcpy(&v, bytes.data() + offset, 4);
        return v;  // GLB is little-endian; so are all our targets
    };
    if (bytes.size() < 20)
        fail_at(path, "byte offset 0", "GLB file too short (" + std::to_string(bytes.size()) + " bytes)");
    if (std::memcmp(bytes.data(), "glTF", 4) != 0) fail_at(path, "byte offset 0", "not a GLB file (no 'glTF' magic)");
    if (u32(4) != 2) fail_at(path, "byte offset 4", "GLB version " + std::to_string(u32(4)) + ", expected 2");
    const uint64_t total = u32(8);
    if (total > bytes.size())
        fail_at(path, "byte offset 8",
                "GLB length " + std::to_string(total) + " but the file has " + std::to_string(bytes.size()) +
                    " bytes (truncated?)");
    const uint64_t json_length = u32(12);
    if (u32(16) != 0x4E4F534Au) fail_at(path, "byte offset 16", "first GLB chunk is not JSON");
    if (20 + json_length > total) fail_at(path, "byte offset 12", "JSON chunk length exceeds the file (truncated?)");
    const uint64_t bin_header = 20 + ((json_length + 3) & ~uint64_t{3});
    if (bin_header < total) {
        if (bin_header + 8 > total)
            fail_at(path, "byte offset " + std::to_string(bin_header), "truncated chunk header");
        const uint64_t bin_length = u32(bin_header);
        if (bin_header + 8 + bin_length > total)
            fail_at(path, "byte offset " + std::to_string(bin_header),
                    "BIN chunk length exceeds the file (truncated?)");
    }
}

}  // namespace

void read_gltf_model(std::string_view bytes, const std::string& path, tinygltf::Model& model) {
    if (bytes.size() > std::numeric_limits<unsigned int>::max()) throw Error(path + ": file too large for tinygltf");
    const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    std::string extension = fs::path(path).extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    // A .glb without the magic is reported as such; a .gltf that holds GLB bytes is read as GLB.
    if (binary || extension == ".glb") check_glb_container(path, bytes);

    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&ignore_image, nullptr);
    const std::string base_dir = fs::path(path).parent_path().string();
    std::error_code folder_error;
    BufferFolder folder{
        fs::weakly_canonical(fs::absolute(base_dir.empty() ? fs::path(".") : fs::path(base_dir)), folder_error)};
    loader.SetFsCallbacks({&any_name_exists, &keep_path, &read_buffer_file, &refuse_write, &folder});
    std::string error, warning;
    const auto length = static_cast<unsigned int>(bytes.size());
    bool ok = false;
    try {
        ok = binary
                 ? loader.LoadBinaryFromMemory(&model, &error, &warning,
                                               reinterpret_cast<const unsigned char*>(bytes.data()), length, base_dir)
                 : loader.LoadASCIIFromString(&model, &error, &warning, bytes.data(), length, base_dir);
    } catch (const std::exception& e) {  // nlohmann::json may throw on type mismatches
        error = e.what();
        ok = false;
    }
    if (!ok) {
        while (!error.empty() && (error.back() == '\n' || error.back() == ' ')) error.pop_back();
        throw Error(path + ": invalid glTF: " +
                    (error.empty() ? std::string("tinygltf failed without a message") : printable(error)));
    }
    for (const std::string& required : model.extensionsRequired)
        if (required == "KHR_draco_mesh_compression" || required == "EXT_meshopt_compression" ||
            required == "KHR_mesh_quantization")
            fail_at(path, "asset", "required extension '" + required + "' is not supported");
}

std::vector<Triangle> load_gltf(const std::string& path) { return parse_gltf(read_file_bytes(path), path); }

std::vector<Triangle> parse_gltf(std::string_view bytes, const std::string& path) {
    tinygltf::Model model;
    read_gltf_model(bytes, path, model);
    std::vector<Triangle> triangles;
    walk_gltf_nodes(model, path, [&](int node_index, const tinygltf::Node& node, const GltfMatrix& world) {
        if (node.mesh < 0) return;
        if (static_cast<size_t>(node.mesh) >= model.meshes.size())
            fail_at(path, "node " + std::to_string(node_index),
                    "mesh " + std::to_string(node.mesh) + " does not exist");
        gltf_mesh_triangles(model, path, node.mesh, world, triangles);
    });
    if (triangles.empty()) throw Error(path + ": no triangles in the glTF scene(s)");
    return triangles;
}

}  // namespace spacebvh::tools::scene_detail
