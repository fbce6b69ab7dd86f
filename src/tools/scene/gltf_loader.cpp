// SPDX-License-Identifier: MIT
// glTF 2.0 reader (.gltf and .glb) on top of tinygltf (header-only, Debian libtinygltf-dev 2.7).
// Triangles of every mesh instance in the default scene (or of all scenes when there is no default),
// in node order (depth first, children in listed order) and primitive order, with node transforms
// (matrix, or T * R * S) composed down the hierarchy. tinygltf parses the JSON and loads the buffers;
// every index, offset and length used here is checked again, since tinygltf 2.7 does not bound-check
// accessors against their buffers.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include <array>
#include <cctype>
#include <cstring>
#include <filesystem>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools::scene_detail {
namespace {

using Matrix4 = std::array<double, 16>;  // column-major, as glTF stores it

constexpr Matrix4 kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

Matrix4 multiply(const Matrix4& a, const Matrix4& b) {
    Matrix4 r{};
    for (int column = 0; column < 4; ++column)
        for (int row = 0; row < 4; ++row) {
            double sum = 0;
            for (int k = 0; k < 4; ++k) sum += a[k * 4 + row] * b[column * 4 + k];
            r[column * 4 + row] = sum;
        }
    return r;
}

// Images are irrelevant for ray tracing geometry: accept and ignore them.
bool ignore_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
    return true;
}

class GltfReader {
public:
    GltfReader(const std::string& path, const tinygltf::Model& model) : path_(path), model_(model) {}

    std::vector<Triangle> read() {
        for (const std::string& extension : model_.extensionsRequired)
            if (extension == "KHR_draco_mesh_compression" || extension == "EXT_meshopt_compression" ||
                extension == "KHR_mesh_quantization")
                fail("asset", "required extension '" + extension + "' is not supported");
        std::vector<int> scenes;
        if (model_.defaultScene >= 0) {
            if (static_cast<size_t>(model_.defaultScene) >= model_.scenes.size())
                fail("asset", "default scene " + std::to_string(model_.defaultScene) + " does not exist");
            scenes.push_back(model_.defaultScene);
        } else {
            for (size_t s = 0; s < model_.scenes.size(); ++s) scenes.push_back(static_cast<int>(s));
        }
        for (int scene : scenes) {
            std::vector<char> visited(model_.nodes.size(), 0);
            for (int root : model_.scenes[scene].nodes)
                visit(root, kIdentity, visited, "scene " + std::to_string(scene));
        }
        if (scenes.empty()) fail("asset", "no scenes: nothing to place");
        if (triangles_.empty()) throw Error(path_ + ": no triangles in the glTF scene(s)");
        return std::move(triangles_);
    }

private:
    [[noreturn]] void fail(const std::string& where, const std::string& what) const { fail_at(path_, where, what); }

    void visit(int root, const Matrix4& root_parent, std::vector<char>& visited, const std::string& where) {
        // Explicit stack: a deep (or malicious) hierarchy must not overflow the call stack.
        std::vector<std::pair<int, Matrix4>> stack{{root, root_parent}};
        while (!stack.empty()) {
            auto [node_index, parent] = stack.back();
            stack.pop_back();
            if (node_index < 0 || static_cast<size_t>(node_index) >= model_.nodes.size())
                fail(where, "node " + std::to_string(node_index) + " does not exist");
            if (visited[node_index])
                fail("node " + std::to_string(node_index), "reached twice: glTF nodes must form a tree (cycle?)");
            visited[node_index] = 1;
            const tinygltf::Node& node = model_.nodes[node_index];
            const Matrix4 world = multiply(parent, local_matrix(node, node_index));
            if (node.mesh >= 0) add_mesh(node.mesh, world, node_index);
            // Reverse push so that children are visited in their listed order.
            for (auto child = node.children.rbegin(); child != node.children.rend(); ++child)
                stack.push_back({*child, world});
        }
    }

    Matrix4 local_matrix(const tinygltf::Node& node, int node_index) const {
        const std::string where = "node " + std::to_string(node_index);
        if (node.matrix.size() == 16) {
            Matrix4 m;
            std::copy(node.matrix.begin(), node.matrix.end(), m.begin());
            for (double v : m)
                if (!std::isfinite(v)) fail(where, "non-finite matrix");
            return m;
        }
        if (!node.matrix.empty()) fail(where, "matrix must have 16 numbers");
        Matrix4 translation = kIdentity, rotation = kIdentity, scale = kIdentity;
        if (node.translation.size() == 3) {
            translation[12] = node.translation[0];
            translation[13] = node.translation[1];
            translation[14] = node.translation[2];
        } else if (!node.translation.empty()) {
            fail(where, "translation must have 3 numbers");
        }
        if (node.rotation.size() == 4) {
            // Unit quaternion (x, y, z, w) to matrix; normalised first, as viewers do.
            double x = node.rotation[0], y = node.rotation[1], z = node.rotation[2], w = node.rotation[3];
            double norm = std::sqrt(x * x + y * y + z * z + w * w);
            if (!(norm > 0) || !std::isfinite(norm)) fail(where, "rotation quaternion is zero or not finite");
            x /= norm;
            y /= norm;
            z /= norm;
            w /= norm;
            rotation = {1 - 2 * (y * y + z * z),
                        2 * (x * y + z * w),
                        2 * (x * z - y * w),
                        0,
                        2 * (x * y - z * w),
                        1 - 2 * (x * x + z * z),
                        2 * (y * z + x * w),
                        0,
                        2 * (x * z + y * w),
                        2 * (y * z - x * w),
                        1 - 2 * (x * x + y * y),
                        0,
                        0,
                        0,
                        0,
                        1};
        } else if (!node.rotation.empty()) {
            fail(where, "rotation must have 4 numbers");
        }
        if (node.scale.size() == 3) {
            scale[0] = node.scale[0];
            scale[5] = node.scale[1];
            scale[10] = node.scale[2];
        } else if (!node.scale.empty()) {
            fail(where, "scale must have 3 numbers");
        }
        Matrix4 m = multiply(translation, multiply(rotation, scale));
        for (double v : m)
            if (!std::isfinite(v)) fail(where, "non-finite transform");
        return m;
    }

    // A validated view of an accessor's elements inside its buffer.
    struct View {
        const unsigned char* base = nullptr;
        size_t stride = 0;
        size_t count = 0;
        size_t buffer_offset = 0;  // of element 0 in its buffer, for messages
    };

    View view_of(int accessor_index, int expected_type, const std::string& where) const {
        const std::string what = where + " accessor " + std::to_string(accessor_index);
        if (accessor_index < 0 || static_cast<size_t>(accessor_index) >= model_.accessors.size())
            fail(what, "does not exist");
        const tinygltf::Accessor& accessor = model_.accessors[accessor_index];
        if (accessor.sparse.isSparse) fail(what, "sparse accessors are not supported");
        if (accessor.type != expected_type) fail(what, "unexpected element type " + std::to_string(accessor.type));
        const int component_size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(accessor.componentType));
        const int component_count = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type));
        if (component_size <= 0 || component_count <= 0)
            fail(what, "bad component type " + std::to_string(accessor.componentType));
        const size_t element_size = static_cast<size_t>(component_size) * static_cast<size_t>(component_count);
        if (accessor.bufferView < 0 || static_cast<size_t>(accessor.bufferView) >= model_.bufferViews.size())
            fail(what, "buffer view " + std::to_string(accessor.bufferView) + " does not exist");
        const tinygltf::BufferView& buffer_view = model_.bufferViews[accessor.bufferView];
        if (buffer_view.buffer < 0 || static_cast<size_t>(buffer_view.buffer) >= model_.buffers.size())
            fail(what, "buffer " + std::to_string(buffer_view.buffer) + " does not exist");
        const std::vector<unsigned char>& buffer = model_.buffers[buffer_view.buffer].data;
        if (buffer_view.byteOffset > buffer.size() || buffer_view.byteLength > buffer.size() - buffer_view.byteOffset)
            fail(what, "buffer view " + std::to_string(accessor.bufferView) + " (byte offset " +
                           std::to_string(buffer_view.byteOffset) + ", length " +
                           std::to_string(buffer_view.byteLength) + ") exceeds its buffer of " +
                           std::to_string(buffer.size()) + " bytes");
        View view;
        view.stride = buffer_view.byteStride != 0 ? buffer_view.byteStride : element_size;
        if (view.stride < element_size) fail(what, "byte stride smaller than an element");
        view.count = accessor.count;
        if (view.count > 0) {
            // Last element must end inside the view; written to avoid overflow on absurd counts.
            const size_t length = buffer_view.byteLength;
            if (accessor.byteOffset > length || element_size > length - accessor.byteOffset ||
                (view.count - 1) > (length - accessor.byteOffset - element_size) / view.stride)
                fail(what, "count " + std::to_string(view.count) + " at byte offset " +
                               std::to_string(accessor.byteOffset) + " exceeds buffer view " +
                               std::to_string(accessor.bufferView) + " of " + std::to_string(length) + " bytes");
        }
        view.buffer_offset = buffer_view.byteOffset + accessor.byteOffset;
        view.base = buffer.data() + view.buffer_offset;
        return view;
    }

    void add_mesh(int mesh_index, const Matrix4& world, int node_index) {
        if (static_cast<size_t>(mesh_index) >= model_.meshes.size())
            fail("node " + std::to_string(node_index), "mesh " + std::to_string(mesh_index) + " does not exist");
        const tinygltf::Mesh& mesh = model_.meshes[mesh_index];
        for (size_t p = 0; p < mesh.primitives.size(); ++p) {
            const tinygltf::Primitive& primitive = mesh.primitives[p];
            const std::string where = "mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(p);
            const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
            if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
                mode == TINYGLTF_MODE_LINE_STRIP)
                continue;  // points and lines have no surface to hit
            if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
                mode != TINYGLTF_MODE_TRIANGLE_FAN)
                fail(where, "unknown primitive mode " + std::to_string(mode));
            auto position = primitive.attributes.find("POSITION");
            if (position == primitive.attributes.end()) fail(where, "no POSITION attribute");
            const View positions = view_of(position->second, TINYGLTF_TYPE_VEC3, where + " POSITION");
            if (model_.accessors[position->second].componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
                fail(where + " POSITION accessor " + std::to_string(position->second),
                     "component type must be FLOAT (5126)");
            std::vector<Vec3> points(positions.count);
            for (size_t i = 0; i < positions.count; ++i) {
                float xyz[3];
                std::memcpy(xyz, positions.base + i * positions.stride, sizeof xyz);
                const double x = xyz[0], y = xyz[1], z = xyz[2];
                if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
                    fail(where + " POSITION accessor " + std::to_string(position->second) + " element " +
                             std::to_string(i) + " (byte offset " +
                             std::to_string(positions.buffer_offset + i * positions.stride) + ")",
                         "NaN or infinite coordinate");
                Vec3 world_point{static_cast<float>(world[0] * x + world[4] * y + world[8] * z + world[12]),
                                 static_cast<float>(world[1] * x + world[5] * y + world[9] * z + world[13]),
                                 static_cast<float>(world[2] * x + world[6] * y + world[10] * z + world[14])};
                if (!is_finite(world_point))
                    fail(where + " POSITION element " + std::to_string(i), "node transform overflows float range");
                points[i] = world_point;
            }

            std::vector<uint32_t> indices;
            if (primitive.indices >= 0) {
                const std::string index_where = where + " indices accessor " + std::to_string(primitive.indices);
                const View view = view_of(primitive.indices, TINYGLTF_TYPE_SCALAR, where + " indices");
                const int component = model_.accessors[primitive.indices].componentType;
                indices.resize(view.count);
                for (size_t i = 0; i < view.count; ++i) {
                    const unsigned char* at = view.base + i * view.stride;
                    uint32_t value = 0;
                    if (component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
                        value = at[0];
                    } else if (component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
                        uint16_t v;
                        std::memcpy(&v, at, 2);
                        value = v;
                    } else if (component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
                        std::memcpy(&value, at, 4);
                    } else {
                        fail(index_where, "index component type must be an unsigned integer type");
                    }
                    if (value >= points.size())
                        fail(index_where + " element " + std::to_string(i) + " (byte offset " +
                                 std::to_string(view.buffer_offset + i * view.stride) + ")",
                             "vertex index " + std::to_string(value) +
                                 " out of range: " + std::to_string(points.size()) + " positions");
                    indices[i] = value;
                }
            } else {
                indices.resize(points.size());
                for (size_t i = 0; i < points.size(); ++i) indices[i] = static_cast<uint32_t>(i);
            }
            add_triangles(mode, indices, points, where);
        }
    }

    // glTF 2.0 spec, section 3.7.2.1 "Topology types".
    void add_triangles(int mode, const std::vector<uint32_t>& idx, const std::vector<Vec3>& points,
                       const std::string& where) {
        const size_t n = idx.size();
        if (mode == TINYGLTF_MODE_TRIANGLES) {
            if (n % 3 != 0) fail(where, std::to_string(n) + " vertices is not a multiple of 3 for TRIANGLES");
            for (size_t i = 0; i < n; i += 3)
                triangles_.push_back({points[idx[i]], points[idx[i + 1]], points[idx[i + 2]]});
        } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
            for (size_t i = 0; i + 2 < n; ++i) {
                const size_t odd = i % 2;
                triangles_.push_back({points[idx[i]], points[idx[i + 1 + odd]], points[idx[i + 2 - odd]]});
            }
        } else {  // fan
            for (size_t i = 1; i + 1 < n; ++i)
                triangles_.push_back({points[idx[0]], points[idx[i]], points[idx[i + 1]]});
        }
    }

    const std::string& path_;
    const tinygltf::Model& model_;
    std::vector<Triangle> triangles_;
};

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

std::vector<Triangle> load_gltf(const std::string& path) { return parse_gltf(read_file_bytes(path), path); }

std::vector<Triangle> parse_gltf(std::string_view bytes, const std::string& path) {
    if (bytes.size() > std::numeric_limits<unsigned int>::max()) throw Error(path + ": file too large for tinygltf");
    const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    std::string extension = std::filesystem::path(path).extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    // A .glb without the magic is reported as such; a .gltf that holds GLB bytes is read as GLB.
    if (binary || extension == ".glb") check_glb_container(path, bytes);

    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&ignore_image, nullptr);
    tinygltf::Model model;
    std::string error, warning;
    const std::string base_dir = std::filesystem::path(path).parent_path().string();
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
        throw Error(path +
                    ": invalid glTF: " + (error.empty() ? std::string("tinygltf failed without a message") : error));
    }
    return GltfReader(path, model).read();
}

}  // namespace spacebvh::tools::scene_detail
