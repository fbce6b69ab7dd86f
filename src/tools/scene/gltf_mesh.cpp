// SPDX-License-Identifier: MIT
// glTF meshes and node transforms from a parsed model: every index, offset and length is checked
// again here, since tinygltf 2.7 does not bound-check accessors against their buffers.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "tools/scene/gltf_internal.hpp"

namespace spacebvh::tools::scene_detail {

GltfMatrix gltf_multiply(const GltfMatrix& a, const GltfMatrix& b) {
    GltfMatrix r{};
    for (int column = 0; column < 4; ++column)
        for (int row = 0; row < 4; ++row) {
            double sum = 0;
            for (int k = 0; k < 4; ++k) sum += a[k * 4 + row] * b[column * 4 + k];
            r[column * 4 + row] = sum;
        }
    return r;
}

GltfMatrix gltf_local_matrix(const tinygltf::Node& node, const std::string& where, const std::string& path) {
    if (node.matrix.size() == 16) {
        GltfMatrix m;
        std::copy(node.matrix.begin(), node.matrix.end(), m.begin());
        for (double v : m)
            if (!std::isfinite(v)) fail_at(path, where, "non-finite matrix");
        return m;
    }
    if (!node.matrix.empty()) fail_at(path, where, "matrix must have 16 numbers");
    GltfMatrix translation = kGltfIdentity, rotation = kGltfIdentity, scale = kGltfIdentity;
    if (node.translation.size() == 3) {
        translation[12] = node.translation[0];
        translation[13] = node.translation[1];
        translation[14] = node.translation[2];
    } else if (!node.translation.empty()) {
        fail_at(path, where, "translation must have 3 numbers");
    }
    if (node.rotation.size() == 4) {
        // Unit quaternion (x, y, z, w) to matrix; normalised first, as viewers do.
        double x = node.rotation[0], y = node.rotation[1], z = node.rotation[2], w = node.rotation[3];
        double norm = std::sqrt(x * x + y * y + z * z + w * w);
        if (!(norm > 0) || !std::isfinite(norm)) fail_at(path, where, "rotation quaternion is zero or not finite");
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
        fail_at(path, where, "rotation must have 4 numbers");
    }
    if (node.scale.size() == 3) {
        scale[0] = node.scale[0];
        scale[5] = node.scale[1];
        scale[10] = node.scale[2];
    } else if (!node.scale.empty()) {
        fail_at(path, where, "scale must have 3 numbers");
    }
    GltfMatrix m = gltf_multiply(translation, gltf_multiply(rotation, scale));
    for (double v : m)
        if (!std::isfinite(v)) fail_at(path, where, "non-finite transform");
    return m;
}

void walk_gltf_nodes(const tinygltf::Model& model, const std::string& path, const GltfNodeVisit& visit) {
    std::vector<int> scenes;
    if (model.defaultScene >= 0) {
        if (static_cast<size_t>(model.defaultScene) >= model.scenes.size())
            fail_at(path, "asset", "default scene " + std::to_string(model.defaultScene) + " does not exist");
        scenes.push_back(model.defaultScene);
    } else {
        for (size_t s = 0; s < model.scenes.size(); ++s) scenes.push_back(static_cast<int>(s));
    }
    if (scenes.empty()) fail_at(path, "asset", "no scenes: nothing to place");
    for (int scene : scenes) {
        const std::string where = "scene " + std::to_string(scene);
        std::vector<char> visited(model.nodes.size(), 0);
        // Explicit stack: a deep (or malicious) hierarchy must not overflow the call stack.
        std::vector<std::pair<int, GltfMatrix>> stack;
        for (auto root = model.scenes[scene].nodes.rbegin(); root != model.scenes[scene].nodes.rend(); ++root)
            stack.push_back({*root, kGltfIdentity});
        while (!stack.empty()) {
            auto [node_index, parent] = stack.back();
            stack.pop_back();
            if (node_index < 0 || static_cast<size_t>(node_index) >= model.nodes.size())
                fail_at(path, where, "node " + std::to_string(node_index) + " does not exist");
            if (visited[node_index])
                fail_at(path, "node " + std::to_string(node_index),
                        "reached twice from " + where + ": glTF nodes must form a tree (a cycle, or two parents)");
            visited[node_index] = 1;
            const tinygltf::Node& node = model.nodes[node_index];
            const GltfMatrix world =
                gltf_multiply(parent, gltf_local_matrix(node, "node " + std::to_string(node_index), path));
            visit(node_index, node, world);
            // Reverse push so that children are visited in their listed order.
            for (auto child = node.children.rbegin(); child != node.children.rend(); ++child)
                stack.push_back({*child, world});
        }
    }
}

namespace {

class MeshDecoder {
public:
    MeshDecoder(const std::string& path, const tinygltf::Model& model) : path_(path), model_(model) {}

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
            fail_at(path_, what, "does not exist");
        const tinygltf::Accessor& accessor = model_.accessors[accessor_index];
        if (accessor.sparse.isSparse) fail_at(path_, what, "sparse accessors are not supported");
        if (accessor.type != expected_type)
            fail_at(path_, what, "unexpected element type " + std::to_string(accessor.type));
        const int component_size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(accessor.componentType));
        const int component_count = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type));
        if (component_size <= 0 || component_count <= 0)
            fail_at(path_, what, "bad component type " + std::to_string(accessor.componentType));
        const size_t element_size = static_cast<size_t>(component_size) * static_cast<size_t>(component_count);
        if (accessor.bufferView < 0 || static_cast<size_t>(accessor.bufferView) >= model_.bufferViews.size())
            fail_at(path_, what, "buffer view " + std::to_string(accessor.bufferView) + " does not exist");
        const tinygltf::BufferView& buffer_view = model_.bufferViews[accessor.bufferView];
        if (buffer_view.buffer < 0 || static_cast<size_t>(buffer_view.buffer) >= model_.buffers.size())
            fail_at(path_, what, "buffer " + std::to_string(buffer_view.buffer) + " does not exist");
        const std::vector<unsigned char>& buffer = model_.buffers[buffer_view.buffer].data;
        if (buffer_view.byteOffset > buffer.size() || buffer_view.byteLength > buffer.size() - buffer_view.byteOffset)
            fail_at(path_, what,
                    "buffer view " + std::to_string(accessor.bufferView) + " (byte offset " +
                        std::to_string(buffer_view.byteOffset) + ", length " + std::to_string(buffer_view.byteLength) +
                        ") exceeds its buffer of " + std::to_string(buffer.size()) + " bytes");
        View view;
        view.stride = buffer_view.byteStride != 0 ? buffer_view.byteStride : element_size;
        if (view.stride < element_size) fail_at(path_, what, "byte stride smaller than an element");
        view.count = accessor.count;
        if (view.count > 0) {
            // Last element must end inside the view; written to avoid overflow on absurd counts.
            const size_t length = buffer_view.byteLength;
            if (accessor.byteOffset > length || element_size > length - accessor.byteOffset ||
                (view.count - 1) > (length - accessor.byteOffset - element_size) / view.stride)
                fail_at(path_, what,
                        "count " + std::to_string(view.count) + " at byte offset " +
                            std::to_string(accessor.byteOffset) + " exceeds buffer view " +
                            std::to_string(accessor.bufferView) + " of " + std::to_string(length) + " bytes");
        }
        view.buffer_offset = buffer_view.byteOffset + accessor.byteOffset;
        view.base = buffer.data() + view.buffer_offset;
        return view;
    }

    void add_mesh(int mesh_index, const GltfMatrix& world, std::vector<Triangle>& out) const {
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
                fail_at(path_, where, "unknown primitive mode " + std::to_string(mode));
            auto position = primitive.attributes.find("POSITION");
            if (position == primitive.attributes.end()) fail_at(path_, where, "no POSITION attribute");
            const View positions = view_of(position->second, TINYGLTF_TYPE_VEC3, where + " POSITION");
            if (model_.accessors[position->second].componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
                fail_at(path_, where + " POSITION accessor " + std::to_string(position->second),
                        "component type must be FLOAT (5126)");
            std::vector<Vec3> points(positions.count);
            for (size_t i = 0; i < positions.count; ++i) {
                float xyz[3];
                std::memcpy(xyz, positions.base + i * positions.stride, sizeof xyz);
                const double x = xyz[0], y = xyz[1], z = xyz[2];
                if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
                    fail_at(path_,
                            where + " POSITION accessor " + std::to_string(position->second) + " element " +
                                std::to_string(i) + " (byte offset " +
                                std::to_string(positions.buffer_offset + i * positions.stride) + ")",
                            "NaN or infinite coordinate");
                Vec3 world_point{static_cast<float>(world[0] * x + world[4] * y + world[8] * z + world[12]),
                                 static_cast<float>(world[1] * x + world[5] * y + world[9] * z + world[13]),
                                 static_cast<float>(world[2] * x + world[6] * y + world[10] * z + world[14])};
                if (!is_finite(world_point))
                    fail_at(path_, where + " POSITION element " + std::to_string(i),
                            "node transform overflows float range");
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
                        fail_at(path_, index_where, "index component type must be an unsigned integer type");
                    }
                    if (value >= points.size())
                        fail_at(path_,
                                index_where + " element " + std::to_string(i) + " (byte offset " +
                                    std::to_string(view.buffer_offset + i * view.stride) + ")",
                                "vertex index " + std::to_string(value) +
                                    " out of range: " + std::to_string(points.size()) + " positions");
                    indices[i] = value;
                }
            } else {
                indices.resize(points.size());
                for (size_t i = 0; i < points.size(); ++i) indices[i] = static_cast<uint32_t>(i);
            }
            add_triangles(mode, indices, points, where, out);
        }
    }

    // glTF 2.0 spec, section 3.7.2.1 "Topology types".
    void add_triangles(int mode, const std::vector<uint32_t>& idx, const std::vector<Vec3>& points,
                       const std::string& where, std::vector<Triangle>& out) const {
        const size_t n = idx.size();
        if (mode == TINYGLTF_MODE_TRIANGLES) {
            if (n % 3 != 0) fail_at(path_, where, std::to_string(n) + " vertices is not a multiple of 3 for TRIANGLES");
            for (size_t i = 0; i < n; i += 3) out.push_back({points[idx[i]], points[idx[i + 1]], points[idx[i + 2]]});
        } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
            for (size_t i = 0; i + 2 < n; ++i) {
                const size_t odd = i % 2;
                out.push_back({points[idx[i]], points[idx[i + 1 + odd]], points[idx[i + 2 - odd]]});
            }
        } else {  // fan
            for (size_t i = 1; i + 1 < n; ++i) out.push_back({points[idx[0]], points[idx[i]], points[idx[i + 1]]});
        }
    }

    std::vector<float> floats(int accessor_index, int expected_type, const std::string& where) const {
        const View view = view_of(accessor_index, expected_type, where);
        const tinygltf::Accessor& accessor = model_.accessors[accessor_index];
        const int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type));
        const int size = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(accessor.componentType));
        const int type = accessor.componentType;
        if (type != TINYGLTF_COMPONENT_TYPE_FLOAT && !accessor.normalized)
            fail_at(path_, where + " accessor " + std::to_string(accessor_index),
                    "component type must be FLOAT (5126) or a normalized integer type");
        if (type == TINYGLTF_COMPONENT_TYPE_INT || type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT ||
            type == TINYGLTF_COMPONENT_TYPE_DOUBLE)
            fail_at(path_, where + " accessor " + std::to_string(accessor_index),
                    "component type " + std::to_string(type) + " cannot be normalized");
        std::vector<float> out(view.count * size_t(components));
        for (size_t i = 0; i < view.count; ++i)
            for (int c = 0; c < components; ++c) {
                const unsigned char* at = view.base + i * view.stride + size_t(c) * size_t(size);
                out[i * components + c] = component(at, type);
            }
        return out;
    }

private:
    // glTF 2.0 spec, section 3.11 "Animations" (normalized integers): signed types map to [-1, 1]
    // with the most negative value clamped, unsigned ones to [0, 1].
    static float component(const unsigned char* at, int type) {
        switch (type) {
            case TINYGLTF_COMPONENT_TYPE_BYTE:
                return std::max(float(int8_t(at[0])) / 127.0f, -1.0f);
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
                return float(at[0]) / 255.0f;
            case TINYGLTF_COMPONENT_TYPE_SHORT: {
                int16_t v;
                std::memcpy(&v, at, 2);
                return std::max(float(v) / 32767.0f, -1.0f);
            }
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
                uint16_t v;
                std::memcpy(&v, at, 2);
                return float(v) / 65535.0f;
            }
            default: {
                float v;
                std::memcpy(&v, at, 4);
                return v;
            }
        }
    }

    const std::string& path_;
    const tinygltf::Model& model_;
};

}  // namespace

void gltf_mesh_triangles(const tinygltf::Model& model, const std::string& path, int mesh_index,
                         const GltfMatrix& transform, std::vector<Triangle>& out) {
    MeshDecoder(path, model).add_mesh(mesh_index, transform, out);
}

std::vector<float> gltf_float_elements(const tinygltf::Model& model, const std::string& path, int accessor_index,
                                       int expected_type, const std::string& where) {
    return MeshDecoder(path, model).floats(accessor_index, expected_type, where);
}

}  // namespace spacebvh::tools::scene_detail
