// SPDX-License-Identifier: MIT
// Tracer64: float64 rays against float64 triangles through a tree built over their float32 stand-ins
// in a local frame. The boxes are widened so that each contains the float64 triangles (not just the
// stand-ins), the slab test is conservative in double, and every leaf decision is the exact predicate
// of core/exact_float64 on the triangles as given (docs/float64.md).
#include "spacebvh/float64.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "core/exact_float64.hpp"
#include "spacebvh/error.hpp"
#include "trace/traversal/walk.hpp"

namespace spacebvh {

namespace {

constexpr double kEps = 0x1p-53;
constexpr double kInf = std::numeric_limits<double>::infinity();
// Inputs are 0 or of magnitude at least 2^-200 (multiples of 2^-252): exact_float64.cpp's underflow rule.
constexpr double kSmallestInput = 0x1p-200;
// Deepest tree traversed (the builders stop at LimitConfig::max_depth <= 1024).
constexpr size_t kMaxDepth = 2048;

bool in_range(double x, double largest) {
    const double a = std::fabs(x);
    return a == 0.0 || (a >= kSmallestInput && a <= largest);
}

std::string ray_name(size_t index) { return index == size_t(-1) ? "ray" : "ray " + std::to_string(index); }

void check_ray(const Ray64& ray, size_t index) {
    for (int i = 0; i < 3; ++i) {
        if (!in_range(ray.org[i], 0x1p128))
            throw Error(ray_name(index) + ": origin coordinate " + std::to_string(ray.org[i]) +
                        " outside the exact float64 range (0 or magnitude in [2^-200, 2^128])");
        if (!in_range(ray.dir[i], 0x1p200))
            throw Error(ray_name(index) + ": direction component " + std::to_string(ray.dir[i]) +
                        " outside the exact float64 range (0 or magnitude in [2^-200, 2^200])");
    }
    if (ray.dir[0] == 0.0 && ray.dir[1] == 0.0 && ray.dir[2] == 0.0)
        throw Error(ray_name(index) + ": direction is zero");
    for (double t : {ray.tmin, ray.tmax})
        if (std::isnan(t) || (std::isfinite(t) && !in_range(t, 0x1p500)))
            throw Error(ray_name(index) + ": tmin/tmax " + std::to_string(t) +
                        " outside the exact float64 range (0, +-inf or magnitude in [2^-200, 2^500])");
}

// The float32 stand-ins and, per triangle, a bound on how far the float64 triangle (shifted by the
// origin, exactly) lies from its stand-in along any axis.
struct Frame {
    LocalFrameMesh mesh;
    std::vector<double> deviation;
};

Frame make_frame(const MeshView& view, const std::vector<Triangle64>& triangles) {
    Vec3d lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
    for (size_t t = 0; t < triangles.size(); ++t)
        for (const Vec3d* v : {&triangles[t].v0, &triangles[t].v1, &triangles[t].v2})
            for (int i = 0; i < 3; ++i) {
                if (!in_range((*v)[i], 0x1p128))
                    throw Error("mesh '" + view.name() + "': triangle " + std::to_string(t) + " has the coordinate " +
                                std::to_string((*v)[i]) +
                                ", neither 0 nor of magnitude >= 2^-200 (the exact float64 range)");
                lo[i] = std::min(lo[i], (*v)[i]);
                hi[i] = std::max(hi[i], (*v)[i]);
            }
    Frame frame;
    if (!triangles.empty())
        for (int i = 0; i < 3; ++i) frame.mesh.origin[i] = double(float(0.5 * lo[i] + 0.5 * hi[i]));
    frame.mesh.triangles.resize(triangles.size());
    frame.deviation.resize(triangles.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, triangles.size(), 4096), [&](const auto& range) {
        for (size_t t = range.begin(); t != range.end(); ++t) {
            double deviation = 0.0;
            auto local = [&](const Vec3d& v) {
                Vec3 out;
                for (int i = 0; i < 3; ++i) {
                    const double shifted = v[i] - frame.mesh.origin[i];  // within eps |shifted| of exact
                    out[i] = float(shifted);
                    // double - its float rounding is exact (Sterbenz); 2^-52 |shifted| covers the shift.
                    deviation = std::max(deviation, std::fabs(double(out[i]) - shifted) + 0x1p-52 * std::fabs(shifted));
                }
                return out;
            };
            frame.mesh.triangles[t] = {local(triangles[t].v0), local(triangles[t].v1), local(triangles[t].v2)};
            frame.deviation[t] = deviation * (1.0 + 0x1p-40);  // the sums above rounded at most twice
        }
    });
    return frame;
}

// Floats below and above x; x is a rounded double, so it is first moved one double ulp outward
// (the exact value it stands for lies within half of one).
float round_down(double x) {
    x = std::nextafter(x, -kInf);
    float f = float(x);
    return double(f) > x ? std::nextafter(f, -kInfinity) : f;
}
float round_up(double x) {
    x = std::nextafter(x, kInf);
    float f = float(x);
    return double(f) < x ? std::nextafter(f, kInfinity) : f;
}

// The ray in the local frame with what the conservative slab test needs.
struct LocalRay {
    Vec3d org, inv, pad;   // pad: slab widening along t for the origin's rounding, per axis
    double org_error = 0;  // bound on |org - exact (ray.org - origin)| per axis, doubled
    bool parallel[3];
};

LocalRay make_local_ray(const Ray64& ray, const Vec3d& origin) {
    LocalRay local;
    double largest = 0.0;
    for (int i = 0; i < 3; ++i) {
        local.org[i] = ray.org[i] - origin[i];
        largest = std::max(largest, std::fabs(local.org[i]));
    }
    // Each shifted coordinate is within eps |org| of exact; twice that also absorbs the roundings of
    // the widened slab bounds below.
    local.org_error = 4.0 * kEps * largest;
    for (int i = 0; i < 3; ++i) {
        local.parallel[i] = ray.dir[i] == 0.0;
        local.inv[i] = local.parallel[i] ? 0.0 : 1.0 / ray.dir[i];
        local.pad[i] = local.org_error * std::fabs(local.inv[i]);
    }
    return local;
}

// Conservative slab test: the interval computed contains the exact ray's parameter interval in the
// box. Each slab parameter (b - o) * inv is within gamma_3 |t| of its exact value for the rounded
// origin; 16 eps |t| and the origin pad cover that and the roundings of the widening itself.
bool box_interval(const AABB& box, const LocalRay& ray, double tmin, double tmax, double& near) {
    constexpr double kSlack = 16.0 * kEps;
    for (int i = 0; i < 3; ++i) {
        const double lo = box.lo[i], hi = box.hi[i];
        if (ray.parallel[i]) {
            if (ray.org[i] + ray.org_error < lo || ray.org[i] - ray.org_error > hi) return false;
            continue;
        }
        double t0 = (lo - ray.org[i]) * ray.inv[i];
        double t1 = (hi - ray.org[i]) * ray.inv[i];
        if (ray.inv[i] < 0.0) std::swap(t0, t1);
        tmin = std::max(tmin, t0 - (ray.pad[i] + kSlack * std::fabs(t0)));
        tmax = std::min(tmax, t1 + (ray.pad[i] + kSlack * std::fabs(t1)));
    }
    near = tmin;
    return tmin <= tmax;
}

}  // namespace

LocalFrameMesh local_frame_mesh(const MeshView& mesh) { return make_frame(mesh, mesh.triangles64()).mesh; }

Hit64 intersect_exact(const Ray64& ray, const Triangle64& triangle, uint32_t primitive) {
    const auto hit = exact::intersect(ray, triangle, exact::is_degenerate(triangle));
    if (!hit) return {};
    return {hit->t, primitive, hit->u, hit->v};
}

struct Tracer64::Impl {
    std::vector<Triangle64> triangles;
    std::vector<uint8_t> degenerate;
    std::vector<uint32_t> unindexed;
    Bvh bvh;
    Vec3d origin{};

    void init(const MeshView& mesh, const std::vector<Triangle64>& mesh_triangles, const Frame& frame,
              const Bvh& local_bvh);
    // Updates `best` with the triangle's hit when closer (equal t: the lower id, as the arbiter).
    bool test(const Ray64& ray, uint32_t id, Hit64& best) const {
        if (degenerate[id]) return false;
        const auto hit = exact::intersect(ray, triangles[id], false);
        if (!hit) return false;
        if (hit->t < best.t || (hit->t == best.t && id < best.primitive)) best = {hit->t, id, hit->u, hit->v};
        return true;
    }
    template <bool AnyHit>
    Hit64 trace(const Ray64& ray) const;
};

void Tracer64::Impl::init(const MeshView& mesh, const std::vector<Triangle64>& mesh_triangles, const Frame& frame,
                          const Bvh& local_bvh) {
    const std::string what = "Tracer64 (mesh '" + mesh.name() + "')";
    if (local_bvh.empty()) throw Error(what + ": the tree is empty");
    triangles = mesh_triangles;
    origin = frame.mesh.origin;
    bvh = local_bvh;
    const size_t count = triangles.size();
    std::vector<uint8_t> in_tree(count, 0);
    for (uint32_t id : bvh.primitives) {
        if (id >= count)
            throw Error(what + ": the tree holds triangle " + std::to_string(id) + ", the mesh has " +
                        std::to_string(count));
        in_tree[id] = 1;
    }
    for (size_t n = 0; n < bvh.nodes.size(); ++n) {
        const BvhNode& node = bvh.nodes[n];
        const bool ok = node.is_leaf() ? uint64_t(node.first) + node.reference_count <= bvh.primitives.size()
                                       : node.first > n && uint64_t(node.first) + 1 < bvh.nodes.size();
        if (!ok) throw Error(what + ": node " + std::to_string(n) + " points outside the tree");
    }
    std::vector<uint32_t> depth(bvh.nodes.size(), 0);
    for (size_t n = 0; n < bvh.nodes.size(); ++n) {
        if (depth[n] > kMaxDepth)
            throw Error(what + ": the tree is deeper than " + std::to_string(kMaxDepth) + " levels");
        if (!bvh.nodes[n].is_leaf()) depth[bvh.nodes[n].first] = depth[bvh.nodes[n].first + 1] = depth[n] + 1;
    }
    // A tree over other triangles (not the local-frame stand-ins) would silently lose hits: each leaf
    // box must meet the stand-in of every triangle it holds (a split reference holds a part).
    for (size_t n = 0; n < bvh.nodes.size(); ++n) {
        const BvhNode& node = bvh.nodes[n];
        for (uint32_t k = 0; node.is_leaf() && k < node.reference_count; ++k) {
            const Triangle& stand_in = frame.mesh.triangles[bvh.primitives[node.first + k]];
            if (!stand_in.is_degenerate() && spacebvh::intersect(node.bounds, stand_in.bounds()).is_empty())
                throw Error(what + ": leaf " + std::to_string(n) + " does not hold triangle " +
                            std::to_string(bvh.primitives[node.first + k]) +
                            " of local_frame_mesh(mesh): the tree was built over other triangles");
        }
    }
    degenerate.assign(count, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 1024), [&](const auto& range) {
        for (size_t t = range.begin(); t != range.end(); ++t) degenerate[t] = exact::is_degenerate(triangles[t]);
    });
    // A stand-in of zero area may be dropped or clipped away by a builder: such triangles (and any the
    // tree lacks) are tested for every ray instead.
    for (size_t t = 0; t < count; ++t)
        if (!degenerate[t] && (!in_tree[t] || frame.mesh.triangles[t].is_degenerate()))
            unindexed.push_back(uint32_t(t));

    // Every point of a float64 triangle is the same barycentric combination of its corners as a point
    // of the stand-in, so lies within the corners' largest deviation of it: widening each leaf box by
    // its triangles' deviation (rounded outward) covers the float64 triangles' parts in the leaf, and
    // re-uniting the parents (children follow parents in depth-first order) keeps the tree conservative.
    for (size_t n = bvh.nodes.size(); n-- > 0;) {
        BvhNode& node = bvh.nodes[n];
        if (node.is_leaf()) {
            double deviation = 0.0;
            for (uint32_t k = 0; k < node.reference_count; ++k)
                deviation = std::max(deviation, frame.deviation[bvh.primitives[node.first + k]]);
            if (node.bounds.is_empty()) continue;
            for (int i = 0; i < 3; ++i) {
                node.bounds.lo[i] = round_down(double(node.bounds.lo[i]) - deviation);
                node.bounds.hi[i] = round_up(double(node.bounds.hi[i]) + deviation);
            }
        } else {
            node.bounds = merge(bvh.nodes[node.first].bounds, bvh.nodes[node.first + 1].bounds);
        }
    }
}

namespace {

// The node test of the float64 walk (walk.hpp): both children's widened boxes by the conservative
// double slab test, nearest first; children entered beyond the best hit so far are skipped.
class WidenedBoxQuery {
public:
    struct Entry {
        uint32_t node;
        double key;  // the (widened) distance the box is entered at
    };
    using Bound = double;  // min(tmax, the best t so far)
    // One pending child per level (init refuses deeper trees), plus a node's two children.
    static constexpr size_t kStackCapacity = kMaxDepth + 2;

    WidenedBoxQuery(const Bvh& bvh, const LocalRay& ray, double tmin, Entry root)
        : nodes_(bvh.nodes.data()), ray_(ray), tmin_(tmin), root_(root) {}

    Entry root() const { return root_; }
    bool is_leaf(const Entry& entry) const { return nodes_[entry.node].is_leaf(); }
    bool beyond(const Entry& entry, Bound bound) const { return entry.key > bound; }
    int enter(Entry& entry, Bound bound, Entry* out) const {
        const uint32_t first = nodes_[entry.node].first;
        double near[2] = {0.0, 0.0};
        unsigned entered = 0;
        for (uint32_t slot = 0; slot < 2; ++slot)
            if (box_interval(nodes_[first + slot].bounds, ray_, tmin_, bound, near[slot])) entered |= 1u << slot;
        if (entered == 0) return 0;
        return trace::nearest_first(entered, near, entry, out, [&](int slot) {
            return Entry{first + uint32_t(slot), near[slot]};
        });
    }

private:
    const BvhNode* nodes_;
    const LocalRay& ray_;
    double tmin_;
    Entry root_;
};

}  // namespace

template <bool AnyHit>
Hit64 Tracer64::Impl::trace(const Ray64& ray) const {
    Hit64 best;
    for (uint32_t id : unindexed)
        if (test(ray, id, best) && AnyHit) return best;
    const LocalRay local = make_local_ray(ray, origin);
    // Box intervals are clipped to [tmin, tmax] widened by the slab slack (the exact range test is the
    // triangles'); closest hit: boxes entered after the best hit so far are skipped.
    double far = std::min(ray.tmax, best.t);
    double near = 0.0;
    if (!box_interval(bvh.nodes[0].bounds, local, ray.tmin, far, near)) return best;
    trace::walk(WidenedBoxQuery(bvh, local, ray.tmin, {0, near}), far, [&](const WidenedBoxQuery::Entry& leaf) {
        const BvhNode& node = bvh.nodes[leaf.node];
        for (uint32_t k = 0; k < node.reference_count; ++k) {
            if (!test(ray, bvh.primitives[node.first + k], best)) continue;
            if (AnyHit) return true;
            far = std::min(ray.tmax, best.t);
        }
        return false;
    });
    return best;
}

Tracer64::Tracer64(const MeshView& mesh, const BuildConfig& config) : impl_(std::make_unique<Impl>()) {
    const std::vector<Triangle64> triangles = mesh.triangles64();
    const Frame frame = make_frame(mesh, triangles);
    const Bvh local_bvh = build(MeshView(frame.mesh.triangles).named(mesh.name()), config);
    impl_->init(mesh, triangles, frame, local_bvh);
}

Tracer64::Tracer64(const MeshView& mesh, const Bvh& local_frame_bvh) : impl_(std::make_unique<Impl>()) {
    const std::vector<Triangle64> triangles = mesh.triangles64();
    impl_->init(mesh, triangles, make_frame(mesh, triangles), local_frame_bvh);
}

Tracer64::~Tracer64() = default;
Tracer64::Tracer64(Tracer64&&) noexcept = default;
Tracer64& Tracer64::operator=(Tracer64&&) noexcept = default;

Hit64 Tracer64::intersect(const Ray64& ray) const {
    check_ray(ray, size_t(-1));
    return impl_->trace<false>(ray);
}

bool Tracer64::occluded(const Ray64& ray) const {
    check_ray(ray, size_t(-1));
    return impl_->trace<true>(ray).is_hit();
}

void Tracer64::intersect(std::span<const Ray64> rays, std::span<Hit64> hits) const {
    if (hits.size() != rays.size())
        throw Error("Tracer64::intersect: " + std::to_string(rays.size()) + " rays but room for " +
                    std::to_string(hits.size()) + " hits");
    for (size_t i = 0; i < rays.size(); ++i) check_ray(rays[i], i);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 256), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) hits[i] = impl_->trace<false>(rays[i]);
    });
}

void Tracer64::occluded(std::span<const Ray64> rays, std::span<uint8_t> occluded) const {
    if (occluded.size() != rays.size())
        throw Error("Tracer64::occluded: " + std::to_string(rays.size()) + " rays but room for " +
                    std::to_string(occluded.size()) + " answers");
    for (size_t i = 0; i < rays.size(); ++i) check_ray(rays[i], i);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 256), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i)
            occluded[i] = impl_->trace<true>(rays[i]).is_hit() ? 1 : 0;
    });
}

const Bvh& Tracer64::bvh() const { return impl_->bvh; }
const Vec3d& Tracer64::frame_origin() const { return impl_->origin; }
size_t Tracer64::unindexed_count() const { return impl_->unindexed.size(); }

}  // namespace spacebvh
