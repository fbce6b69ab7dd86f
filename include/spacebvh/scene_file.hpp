// SPDX-License-Identifier: MIT
// Scene tree files: a committed RenderScene (its instanced scenes, every mesh's triangles and tree,
// transforms, masks, ids, kernel settings and top levels) saved to bytes or a file and loaded later
// without building anything.
//
// The format (docs/tree-format.md, "Scene files") is versioned little-endian binary with a checksum
// over everything before it, like the tree files of one mesh (spacebvh/tree_file.hpp), whose format
// each mesh's tree and each top level is stored in. A scene file holds its meshes' triangles, so it
// loads on its own. Loading validates all of it before the scene is handed out: a truncated,
// corrupted or altered file, or one of another format version, throws Error naming the source and
// what is wrong; a scene that loads gives the answers the saved scene gave.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "spacebvh/scene.hpp"

namespace spacebvh {

// The scene file format version this library writes and the only one it reads.
inline constexpr uint32_t kSceneFileVersion = 1;

// What a scene file says about itself besides the scenes.
struct SceneFileInfo {
    uint32_t format_version = 0;
    uint64_t scene_count = 0;     // the saved scene and every scene it instances, each once
    uint64_t mesh_count = 0;      // meshes over all those scenes
    uint64_t instance_count = 0;  // instances over all those scenes (not multiplied out)
    uint64_t triangle_count = 0;  // triangles over all meshes (each mesh once)
    std::string settings;         // free text the saver attached (the CLI: the build flags); may be empty
};

// How a loaded scene is traced.
struct SceneLoadOptions {
    // Empty: every scene keeps the tracer settings it was saved with. Else these, for every scene
    // (single-ray kernels only, as RenderScene).
    std::optional<TracerConfig> tracer;
};

// The scene file of `scene` and every scene it instances. `settings` is stored as given (at most
// 1 MiB). Throws Error for a scene that is not traceable (not committed, or instancing a scene
// refitted since) or too large for the format.
std::vector<std::byte> serialize_render_scene(const RenderScene& scene, std::string_view settings = {});

// The scene in `bytes`, validated (see above); `source_name` (the file name) starts every error
// message. Fills `info` when given. The loaded scenes own their meshes' triangles: refit(id) on them
// re-reads those copies. Ids, masks, names, transforms and trees are the saved ones; the scenes'
// TreeRecipe (for meshes attached later) is the default one.
std::shared_ptr<RenderScene> deserialize_render_scene(std::span<const std::byte> bytes, const std::string& source_name,
                                                      const SceneLoadOptions& options = {},
                                                      SceneFileInfo* info = nullptr);

// serialize_render_scene to a file (replaced if present). Throws Error naming the path when it cannot be written.
void save_render_scene(const std::string& path, const RenderScene& scene, std::string_view settings = {});

// The file read in one read, then deserialize_render_scene with the path as the source name.
std::shared_ptr<RenderScene> load_render_scene(const std::string& path, const SceneLoadOptions& options = {},
                                               SceneFileInfo* info = nullptr);

// Whether `bytes` start like a scene file (its magic), to tell it from a one-mesh tree file.
bool is_scene_file(std::span<const std::byte> bytes);
// The same for the file at `path`; false when it cannot be read.
bool is_scene_file(const std::string& path);

}  // namespace spacebvh
