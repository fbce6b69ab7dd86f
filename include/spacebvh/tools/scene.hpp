// SPDX-License-Identifier: MIT
// Scenes: a flat list of triangles numbered in file order (polygons fan-triangulated), loaded from
// OBJ, PLY or glTF 2.0, or generated (`builtin:NAME`). docs/rays.md gives the numbering.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/mesh.hpp"

namespace spacebvh::tools {

// Load-time transform, applied to every vertex before anything else:
// p' = translate + scale * (Rz(rotate.z) * Ry(rotate.y) * Rx(rotate.x) * p), angles in degrees.
struct SceneTransform {
    Vec3 rotate_degrees{0.0f};
    float scale = 1.0f;
    Vec3 translate{0.0f};

    bool is_identity() const { return rotate_degrees == Vec3(0.0f) && scale == 1.0f && translate == Vec3(0.0f); }
    Vec3 apply(Vec3 p) const;
    // Why this transform cannot be applied ("scale must be a finite non-zero number", "translate must
    // be finite"), or nullptr when it can. The CLI and the Python module refuse such transforms with it.
    const char* invalid_reason() const;
    // Parses "x:45,y:45,z:45" (any subset, any order). Throws Error on malformed text.
    static Vec3 parse_rotation(const std::string& text);
};

// A camera as in the MANIFEST: eye, target, up, vertical field of view in degrees.
struct Camera {
    Vec3 eye, target, up{0.0f, 1.0f, 0.0f};
    float fovy_degrees = 45.0f;

    // "ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy". Throws Error on malformed text.
    static Camera parse(const std::string& text);
};

struct Scene {
    std::string name;                 // file stem or builtin name, plus the transform if any
    std::vector<Triangle> triangles;  // in file order
    size_t degenerate_count = 0;      // zero-area triangles (kept, never hit)

    AABB bounds() const { return bounds_of(triangles); }
    float diagonal() const { return length(bounds().extent()); }
    // The triangles as the core library takes them (build, Tracer), named after the scene.
    MeshView mesh() const { return MeshView(triangles).named(name); }
    operator MeshView() const { return mesh(); }
};

// Loads a scene from a path (.obj, .ply, .gltf, .glb) or `builtin:NAME`, then applies the transform.
// Throws Error naming the file and line/element for malformed, truncated or invalid input
// (NaN/inf coordinates, out-of-range or negative indices, empty meshes, unknown formats).
Scene load_scene(const std::string& source, const SceneTransform& transform = {});

// A scene from an indexed triangle mesh in memory (the Python module's numpy arrays): `vertices` holds
// x, y, z per vertex, `indices` three vertex indices per triangle (0-based). Throws Error naming the
// vertex or triangle for a length that is not a multiple of 3, an empty mesh, a NaN/inf coordinate
// or an index out of range.
Scene make_indexed_scene(std::span<const float> vertices, std::span<const int64_t> indices, const std::string& name);

// Names accepted after `builtin:`.
std::vector<std::string> builtin_scene_names();
Scene make_builtin_scene(const std::string& name);

// The default camera of docs/rays.md for a scene: eye = center + normalize(1, 0.6, 1) *
// (1.5 * |diagonal|), looking at the center, up = +y, fovy = 45.
Camera default_camera(const Scene& scene);

// The camera that the "| scene | `camera` |" table of a scene collection's MANIFEST.md lists for `stem` (a scene
// file's stem), if any. Throws Error when the file cannot be read or the listed camera is malformed.
std::optional<Camera> manifest_camera(const std::string& manifest, const std::string& stem);

// A scene's camera, transformed with its load transform: a built-in scene's own; for a file, the camera `manifest`
// (a MANIFEST.md path chosen by the caller; empty: none) lists for its stem. default_camera otherwise. The caller
// names the manifest: where a scene file lies says nothing about which collection, if any, describes it.
Camera camera_for_scene(const Scene& scene, const std::string& source, const SceneTransform& transform,
                        const std::string& manifest = "");

}  // namespace spacebvh::tools
