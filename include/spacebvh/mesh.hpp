// SPDX-License-Identifier: MIT
// The triangles a BVH is built over, as the caller holds them: a view, no copy is made until a
// builder or a tracer needs one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/geometry.hpp"

namespace spacebvh {

struct Triangle64;  // spacebvh/float64.hpp

// A triangle mesh in one of the forms renderers keep: a soup of triangles, or vertex coordinates
// (x, y, z per vertex, float or double) with three vertex indices per triangle (uint32_t or int64_t,
// 0-based). Triangles are numbered in index order; hits report these numbers. Double coordinates are
// rounded to the nearest float. The viewed arrays must outlive the view.
class MeshView {
public:
    MeshView(std::span<const Triangle> soup) : soup_(soup) {}
    MeshView(const std::vector<Triangle>& soup) : soup_(soup) {}
    MeshView(std::span<const float> xyz, std::span<const uint32_t> indices)
        : float_xyz_(xyz), u32_indices_(indices), indexed_(true) {}
    MeshView(std::span<const float> xyz, std::span<const int64_t> indices)
        : float_xyz_(xyz), i64_indices_(indices), indexed_(true) {}
    MeshView(std::span<const double> xyz, std::span<const uint32_t> indices)
        : double_xyz_(xyz), u32_indices_(indices), indexed_(true) {}
    MeshView(std::span<const double> xyz, std::span<const int64_t> indices)
        : double_xyz_(xyz), i64_indices_(indices), indexed_(true) {}

    // Names the mesh in error messages ("mesh 'bunny': triangle 7 uses vertex 90, outside 0..89").
    MeshView& named(std::string name) {
        name_ = std::move(name);
        return *this;
    }
    const std::string& name() const { return name_; }

    bool is_soup() const { return !indexed_; }
    // A soup's triangles as given, without a copy (empty for an indexed mesh).
    std::span<const Triangle> soup() const { return is_soup() ? soup_ : std::span<const Triangle>{}; }
    size_t triangle_count() const;

    // The triangles, checked: throws Error naming the mesh and the vertex or triangle for a length
    // that is not a multiple of 3, a NaN/inf coordinate or an index out of range.
    std::vector<Triangle> triangles() const;
    // The triangles with the coordinates as given (double coordinates kept, float ones widened),
    // checked as triangles() is.
    std::vector<Triangle64> triangles64() const;

private:
    std::span<const Triangle> soup_;
    std::span<const float> float_xyz_;
    std::span<const double> double_xyz_;
    std::span<const uint32_t> u32_indices_;
    std::span<const int64_t> i64_indices_;
    bool indexed_ = false;
    std::string name_ = "mesh";
};

// The triangles of a mesh for as long as a build or a layout needs them: a soup is borrowed, an
// indexed mesh is expanded once. Checked as MeshView::triangles() is; an empty mesh is legal here
// (the callers decide whether it is an error).
class TriangleStore {
public:
    explicit TriangleStore(const MeshView& mesh);
    std::span<const Triangle> triangles() const { return triangles_; }

private:
    std::vector<Triangle> owned_;
    std::span<const Triangle> triangles_;
};

}  // namespace spacebvh
