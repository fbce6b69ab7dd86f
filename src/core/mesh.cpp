// SPDX-License-Identifier: MIT
#include "spacebvh/mesh.hpp"

#include <bit>
#include <cmath>
#include <type_traits>

#include "spacebvh/error.hpp"
#include "spacebvh/float64.hpp"

namespace spacebvh {
namespace {

template <typename Coordinate, typename Index, typename Out = Triangle>
std::vector<Out> expand(std::span<const Coordinate> xyz, std::span<const Index> indices, const std::string& name) {
    const std::string what = "mesh '" + name + "'";
    if (xyz.size() % 3 != 0)
        throw Error(what + ": " + std::to_string(xyz.size()) + " vertex coordinates, not a multiple of 3");
    if (indices.size() % 3 != 0)
        throw Error(what + ": " + std::to_string(indices.size()) + " indices, not a multiple of 3");
    const size_t vertex_count = xyz.size() / 3;
    for (size_t i = 0; i < xyz.size(); ++i)
        if (!std::isfinite(xyz[i]) || !std::isfinite(float(xyz[i])))
            throw Error(what + ": vertex " + std::to_string(i / 3) + " has a coordinate that is not finite in float");
    auto vertex = [&](size_t triangle, int corner) {
        const Index index = indices[3 * triangle + corner];
        if (index < 0 || uint64_t(index) >= vertex_count)
            throw Error(what + ": triangle " + std::to_string(triangle) + " uses vertex " + std::to_string(index) +
                        ", outside 0.." + std::to_string(int64_t(vertex_count) - 1));
        if constexpr (std::is_same_v<Out, Triangle64>)
            return Vec3d{double(xyz[3 * index]), double(xyz[3 * index + 1]), double(xyz[3 * index + 2])};
        else
            return Vec3{float(xyz[3 * index]), float(xyz[3 * index + 1]), float(xyz[3 * index + 2])};
    };
    std::vector<Out> triangles;
    triangles.reserve(indices.size() / 3);
    for (size_t t = 0; t < indices.size() / 3; ++t) triangles.push_back({vertex(t, 0), vertex(t, 1), vertex(t, 2)});
    return triangles;
}

// Whether a coordinate is NaN or infinite: its exponent bits all set. Branch-free, so that the pass
// over a whole soup below runs without a branch per coordinate.
inline uint32_t not_finite(float x) { return (std::bit_cast<uint32_t>(x) & 0x7F800000u) == 0x7F800000u; }

void check_soup(std::span<const Triangle> soup, const std::string& name) {
    uint32_t any = 0;
    for (const Triangle& t : soup)
        any |= not_finite(t.v0.x) | not_finite(t.v0.y) | not_finite(t.v0.z) | not_finite(t.v1.x) | not_finite(t.v1.y) |
               not_finite(t.v1.z) | not_finite(t.v2.x) | not_finite(t.v2.y) | not_finite(t.v2.z);
    if (any == 0) return;
    for (size_t t = 0; t < soup.size(); ++t)
        if (!is_finite(soup[t].v0) || !is_finite(soup[t].v1) || !is_finite(soup[t].v2))
            throw Error("mesh '" + name + "': triangle " + std::to_string(t) + " has a coordinate that is not finite");
}

}  // namespace

size_t MeshView::triangle_count() const {
    if (is_soup()) return soup_.size();
    return (u32_indices_.empty() ? i64_indices_.size() : u32_indices_.size()) / 3;
}

std::vector<Triangle> MeshView::triangles() const {
    if (is_soup()) {
        check_soup(soup_, name_);
        return {soup_.begin(), soup_.end()};
    }
    if (double_xyz_.empty())
        return u32_indices_.empty() ? expand(float_xyz_, i64_indices_, name_) : expand(float_xyz_, u32_indices_, name_);
    return u32_indices_.empty() ? expand(double_xyz_, i64_indices_, name_) : expand(double_xyz_, u32_indices_, name_);
}

std::vector<Triangle64> MeshView::triangles64() const {
    if (is_soup()) {
        check_soup(soup_, name_);
        std::vector<Triangle64> out;
        out.reserve(soup_.size());
        auto widen = [](Vec3 p) { return Vec3d{p.x, p.y, p.z}; };
        for (const Triangle& t : soup_) out.push_back({widen(t.v0), widen(t.v1), widen(t.v2)});
        return out;
    }
    if (double_xyz_.empty())
        return u32_indices_.empty() ? expand<float, int64_t, Triangle64>(float_xyz_, i64_indices_, name_)
                                    : expand<float, uint32_t, Triangle64>(float_xyz_, u32_indices_, name_);
    return u32_indices_.empty() ? expand<double, int64_t, Triangle64>(double_xyz_, i64_indices_, name_)
                                : expand<double, uint32_t, Triangle64>(double_xyz_, u32_indices_, name_);
}

TriangleStore::TriangleStore(const MeshView& mesh) {
    if (mesh.is_soup()) {
        check_soup(mesh.soup(), mesh.name());
        triangles_ = mesh.soup();
    } else {
        owned_ = mesh.triangles();
        triangles_ = owned_;
    }
}

}  // namespace spacebvh
