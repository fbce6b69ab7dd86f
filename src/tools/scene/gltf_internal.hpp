// SPDX-License-Identifier: MIT
// The glTF readers' shared pieces (not installed): the model as tinygltf parses it (with file access
// limited to regular files in the glTF's folder), node transforms, and a mesh's triangles decoded
// from checked accessors. tinygltf's implementation is compiled in gltf_loader.cpp.
#pragma once

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include <array>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "tools/scene/scene_internal.hpp"

namespace spacebvh::tools::scene_detail {

using GltfMatrix = std::array<double, 16>;  // column-major, as glTF stores it
inline constexpr GltfMatrix kGltfIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// The largest external buffer file read (tinygltf takes lengths as unsigned int).
inline constexpr uint64_t kMaxGltfBufferFileBytes = 0xFFFFFFFFull;

// Parses .gltf or GLB bytes (the GLB container checked first) with buffers loaded; an external buffer
// URI must name a regular file of at most kMaxGltfBufferFileBytes inside the folder of `path` (the
// error names the URI otherwise). Throws Error "path: invalid glTF: ...".
void read_gltf_model(std::string_view bytes, const std::string& path, tinygltf::Model& model);

GltfMatrix gltf_multiply(const GltfMatrix& a, const GltfMatrix& b);
// A node's local transform: its matrix, or T * R * S (the quaternion normalised first). Throws Error
// naming `where` (the node) for a wrong number of entries, a zero or non-finite quaternion, non-finite
// values.
GltfMatrix gltf_local_matrix(const tinygltf::Node& node, const std::string& where, const std::string& path);

// The most instances one glTF file may place (nodes and EXT_mesh_gpu_instancing entries together):
// 16 times builtin:forest's largest, far beyond real files, and a few GB of description at most.
inline constexpr uint64_t kMaxGltfInstances = 16'000'000;

// Walks the nodes of the default scene (of every scene when there is no default) depth first, children
// in listed order, calling visit(node index, node, world transform) with the transforms composed down
// the hierarchy. Throws Error for a missing default scene, no scenes, a node index out of range, or a
// node reached twice from one scene (a cycle, or a node with two parents).
using GltfNodeVisit = std::function<void(int node_index, const tinygltf::Node& node, const GltfMatrix& world)>;
void walk_gltf_nodes(const tinygltf::Model& model, const std::string& path, const GltfNodeVisit& visit);

// Appends the triangles of mesh `mesh_index`, primitives in order (points and lines skipped), each
// vertex p as float(transform * p) computed in double. Throws Error naming mesh, primitive, accessor
// and element for anything out of range or malformed. Precondition: mesh_index is a valid index.
void gltf_mesh_triangles(const tinygltf::Model& model, const std::string& path, int mesh_index,
                         const GltfMatrix& transform, std::vector<Triangle>& out);

// The elements of an accessor of `expected_type` (TINYGLTF_TYPE_VEC3, ...) as floats, components in
// order: FLOAT as is, normalized integer types scaled as glTF says. Throws Error naming `where`.
std::vector<float> gltf_float_elements(const tinygltf::Model& model, const std::string& path, int accessor_index,
                                       int expected_type, const std::string& where);

}  // namespace spacebvh::tools::scene_detail
