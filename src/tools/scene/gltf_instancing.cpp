// SPDX-License-Identifier: MIT
// A glTF 2.0 file as an instanced scene: each glTF mesh that a node places is decoded once (in its own
// space) and becomes one mesh; each node that places it, and each entry of the node's
// EXT_mesh_gpu_instancing attributes, becomes one instance whose transform is the node's world
// transform (matrix or T * R * S, composed down the hierarchy in double) times the entry's T * R * S,
// rounded once to float. Nodes are walked as the flat reader walks them (walk_gltf_nodes), so the
// placements come in the flat reader's triangle order.
#include <filesystem>
#include <map>

#include "tools/scene/gltf_internal.hpp"
#include "tools/scene/instanced_internal.hpp"

namespace spacebvh::tools::scene_detail {
namespace {

constexpr const char* kGpuInstancing = "EXT_mesh_gpu_instancing";

class InstancingReader {
public:
    InstancingReader(const std::string& path, const tinygltf::Model& model) : path_(path), model_(model) {}

    InstancedScene read() {
        scene_.name = std::filesystem::path(path_).stem().string();
        walk_gltf_nodes(model_, path_, [&](int node_index, const tinygltf::Node& node, const GltfMatrix& world) {
            if (node.mesh >= 0) place(node, node_index, world);
        });
        if (scene_.instances.empty()) throw Error(path_ + ": no triangles in the glTF scene(s)");
        return std::move(scene_);
    }

private:
    void place(const tinygltf::Node& node, int node_index, const GltfMatrix& world) {
        const std::string where = "node " + std::to_string(node_index);
        if (static_cast<size_t>(node.mesh) >= model_.meshes.size())
            fail_at(path_, where, "mesh " + std::to_string(node.mesh) + " does not exist");
        const int mesh = mesh_slot(node.mesh);
        const auto extension = node.extensions.find(kGpuInstancing);
        if (extension == node.extensions.end()) {
            if (mesh >= 0) add_instance(uint32_t(mesh), world, where);
            return;
        }
        const std::vector<GltfMatrix> entries = gpu_instances(extension->second, where + " " + kGpuInstancing);
        if (mesh < 0) return;
        for (size_t i = 0; i < entries.size(); ++i)
            add_instance(uint32_t(mesh), gltf_multiply(world, entries[i]),
                         where + " " + kGpuInstancing + " instance " + std::to_string(i));
    }

    // The scene's mesh for glTF mesh `index`, decoded on first use; -1 for a mesh without triangles
    // (points and lines only), which places nothing.
    int mesh_slot(int index) {
        auto [slot, inserted] = slots_.try_emplace(index, -1);
        if (!inserted) return slot->second;
        Scene mesh;
        const std::string& name = model_.meshes[index].name;
        mesh.name = scene_.name + ":" + (name.empty() ? "mesh " + std::to_string(index) : name);
        gltf_mesh_triangles(model_, path_, index, kGltfIdentity, mesh.triangles);
        if (mesh.triangles.empty()) return -1;
        mesh.degenerate_count = count_degenerate(mesh.triangles);
        slot->second = int(scene_.meshes.size());
        scene_.meshes.push_back(std::move(mesh));
        return slot->second;
    }

    void add_instance(uint32_t mesh, const GltfMatrix& world, const std::string& where) {
        if (scene_.instances.size() >= kMaxGltfInstances)
            fail_at(path_, where, "more than " + std::to_string(kMaxGltfInstances) + " instances in one file");
        const Affine transform = Affine64::from_column_major(world).rounded();
        const std::string reason = invalid_instance_transform(transform);
        if (!reason.empty()) fail_at(path_, where, "transform " + reason);
        scene_.instances.push_back({mesh, nullptr, transform, 0xFFFFFFFFu});
    }

    int accessor_of(const tinygltf::Value& attributes, const char* name, const std::string& where) const {
        if (!attributes.Has(name)) return -1;
        const tinygltf::Value& value = attributes.Get(name);
        const double index = value.IsNumber() ? value.GetNumberAsDouble() : -1.0;
        if (!(index >= 0 && index < double(model_.accessors.size())) || index != std::floor(index))
            fail_at(path_, where + " " + name, "accessor is not an index of the file's accessors");
        return int(index);
    }

    // EXT_mesh_gpu_instancing: TRANSLATION, ROTATION (unit quaternion x, y, z, w) and SCALE per entry,
    // each optional, all of one count; each entry's matrix is T * R * S.
    std::vector<GltfMatrix> gpu_instances(const tinygltf::Value& extension, const std::string& where) const {
        if (!extension.IsObject() || !extension.Has("attributes")) fail_at(path_, where, "no 'attributes' object");
        const tinygltf::Value& attributes = extension.Get("attributes");
        const int accessors[3] = {accessor_of(attributes, "TRANSLATION", where),
                                  accessor_of(attributes, "ROTATION", where), accessor_of(attributes, "SCALE", where)};
        const int types[3] = {TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4, TINYGLTF_TYPE_VEC3};
        const char* names[3] = {"TRANSLATION", "ROTATION", "SCALE"};
        std::vector<float> values[3];
        size_t count = 0;
        bool counted = false;
        for (int a = 0; a < 3; ++a) {
            if (accessors[a] < 0) continue;
            values[a] = gltf_float_elements(model_, path_, accessors[a], types[a], where + " " + names[a]);
            const size_t n = values[a].size() / (a == 1 ? 4 : 3);
            if (counted && n != count)
                fail_at(path_, where + " " + names[a],
                        std::to_string(n) + " entries, but another attribute has " + std::to_string(count));
            count = n;
            counted = true;
        }
        if (!counted) fail_at(path_, where, "none of TRANSLATION, ROTATION, SCALE");
        std::vector<GltfMatrix> out(count);
        for (size_t i = 0; i < count; ++i) {
            tinygltf::Node entry;
            if (!values[0].empty()) entry.translation.assign(&values[0][3 * i], &values[0][3 * i + 3]);
            if (!values[1].empty()) entry.rotation.assign(&values[1][4 * i], &values[1][4 * i + 4]);
            if (!values[2].empty()) entry.scale.assign(&values[2][3 * i], &values[2][3 * i + 3]);
            out[i] = gltf_local_matrix(entry, where + " instance " + std::to_string(i), path_);
        }
        return out;
    }

    const std::string& path_;
    const tinygltf::Model& model_;
    InstancedScene scene_;
    std::map<int, int> slots_;  // glTF mesh index -> scene mesh index, or -1 for no triangles
};

}  // namespace

InstancedScene load_gltf_instanced(const std::string& path) {
    return parse_gltf_instanced(read_file_bytes(path), path);
}

InstancedScene parse_gltf_instanced(std::string_view bytes, const std::string& path) {
    tinygltf::Model model;
    read_gltf_model(bytes, path, model);
    return InstancingReader(path, model).read();
}

}  // namespace spacebvh::tools::scene_detail
