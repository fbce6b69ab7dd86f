// SPDX-License-Identifier: MIT
// The walks of RayQueries and their leaf visitors, without an include guard: query_walks.cpp includes
// them once per instruction set, into a namespace of its own (the baseline's, over the binary layout
// only; AVX2's under that target, with SPACEBVH_QUERY_WALKS_WIDE defined, over the eight-wide layout
// too). Expects `Layout`, the leaf tests, query_node_tests.hpp and the walk skeleton in scope.

// The per-ray constants of the triangle test, made when the ray reaches its first leaf (three
// divisions that many rays, random rays around a small object, never need).
struct RayContext {
    const Ray& ray;
    WatertightRay shear{};
    PackRay pack_ray{};
    bool sheared = false;
    explicit RayContext(const Ray& r) : ray(r) {}
    const PackRay& leaf_ray() {
        if (!sheared) {
            shear = WatertightRay(ray);
            pack_ray = PackRay(shear);
            sheared = true;
        }
        return pack_ray;
    }
};

// The leaf test: calls on_crossing(id, v0, v1, v2) for each triangle of the leaf's lanes that the
// perturbed ray crosses transversally (the distance is left to the caller). Returns true when
// on_crossing asks to stop. Never inlined: inlined into the nearest-first walk, its registers crowd
// the node loop's, which then keeps the node it is at in memory (measured: 2-4 % slower).
template <class OnCrossing>
[[gnu::noinline]] bool visit_leaf(const TrianglePack* packs, RayContext& r, uint32_t first, uint32_t count,
                                  OnCrossing&& on_crossing) {
    for (uint32_t p = 0; p * 4 < count; ++p) {
        const TrianglePack& pack = packs[first + p];
        const uint32_t lanes = count - p * 4 < 4 ? count - p * 4 : 4;
        PackEdges edges;
        pack_edges(pack, r.leaf_ray(), edges);
        unsigned candidates = unsigned(~edges.outside) & ((1u << lanes) - 1);
        while (candidates) {
            const int lane = __builtin_ctz(candidates);
            candidates &= candidates - 1;
            Vec3 v[3];
            pack_triangle(pack, lane, v);
            if (!((edges.inside >> lane) & 1) && !perturbed::crosses_perturbed(r.ray, v[0], v[1], v[2])) continue;
            if (on_crossing(pack.primitive[lane], v[0], v[1], v[2])) return true;
        }
    }
    return false;
}

// Visits every leaf the ray may cross within [tmin, tmax] (over the wide nodes, a node's leaves after
// the next node's test: walk_wide_leaves; over the binary ones, in slot order, leaves first);
// on_crossing as visit_leaf's. A leaf may hold triangles of its neighbours too (LeafPacker): they are real
// triangles, tested like the others, and the callers drop the repeats.
template <class OnCrossing>
inline void visit_crossings(const Layout& layout, RayContext& r, OnCrossing&& on_crossing) {
#ifdef SPACEBVH_QUERY_WALKS_WIDE
    if (layout.has_wide && wide_slabs_apply(r.ray)) {
        walk_wide_leaves(layout.wide, r.ray, [&](const SlotEntry& leaf) {
            return visit_leaf(layout.wide.packs.data(), r, leaf.child, leaf.count, on_crossing);
        });
        return;
    }
#endif
    if (layout.nodes.empty()) return;
    double tmax = r.ray.tmax;
    walk(BinarySlabQuery<ChildOrder::leaves_first>(layout, r.ray), tmax,
         [&](const auto& leaf) { return visit_leaf(layout.packs.data(), r, leaf.child, leaf.count, on_crossing); });
}

// The nearest crossing found so far. Before the first, the bound is the ray's own tmax (decided
// exactly); after it, the best t (compared in double: the t of every crossing is computed alike).
struct Nearest {
    const Ray& ray;
    double t;
    bool found = false;
    uint32_t id = kInvalidIndex;
    Vec3 vertex[3];

    explicit Nearest(const Ray& r) : ray(r), t(r.tmax) {}
    // Returns true when the triangle's crossing is the new nearest.
    bool offer(uint32_t candidate, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
        double candidate_t;
        if (!perturbed::crossing_in_range(ray, v0, v1, v2, found ? t : double(ray.tmax), candidate_t)) return false;
        if (found && (candidate_t > t || (candidate_t == t && candidate >= id))) return false;
        found = true;
        t = candidate_t;
        id = candidate;
        vertex[0] = v0, vertex[1] = v1, vertex[2] = v2;
        return true;
    }
    // The nearest crossing into `out`; QueryHit{} when there is none.
    void hit(QueryHit& out) const {
        if (found)
            out = perturbed::make_hit(ray, vertex[0], vertex[1], vertex[2], id, t);
        else
            out = QueryHit{};
    }
};

// Finds the nearest crossing into `nearest`, nearest child first; each new nearest lowers the bound
// the boxes are entered up to (its id stays kInvalidIndex when there is none).
void find_nearest(const Layout& layout, const Ray& ray, Nearest& nearest) {
    if (layout.nodes.empty()) return;
    RayContext r(ray);
#ifdef SPACEBVH_QUERY_WALKS_WIDE
    if (layout.has_wide && wide_slabs_apply(ray)) {
        float tmax = ray.tmax;  // a float at or above the best t: boxes are entered conservatively up to it
        walk(WideSlabQuery(layout.wide, ray), tmax, [&](const auto& leaf) {
            visit_leaf(layout.wide.packs.data(), r, leaf.child, leaf.count,
                       [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
                           if (nearest.offer(id, v0, v1, v2)) tmax = std::nextafter(float(nearest.t), kInfinity);
                           return false;
                       });
            return false;
        });
        return;
    }
#endif
    double tmax = nearest.t;
    walk(BinarySlabQuery<ChildOrder::nearest_first>(layout, ray), tmax, [&](const auto& leaf) {
        visit_leaf(layout.packs.data(), r, leaf.child, leaf.count,
                   [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
                       if (nearest.offer(id, v0, v1, v2)) tmax = nearest.t;
                       return false;
                   });
        return false;
    });
}

void nearest_crossing(const Layout& layout, const Ray& ray, QueryHit& out) {
    Nearest nearest(ray);
    find_nearest(layout, ray, nearest);
    nearest.hit(out);
}

uint32_t nearest_crossing_id(const Layout& layout, const Ray& ray) {
    Nearest nearest(ray);
    find_nearest(layout, ray, nearest);
    return nearest.id;
}

bool any_crossing(const Layout& layout, const Ray& ray) {
    RayContext r(ray);
    bool found = false;
    const double tmax = ray.tmax;
    visit_crossings(layout, r, [&](uint32_t, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
        double t;
        found = perturbed::crossing_in_range(ray, v0, v1, v2, tmax, t);
        return found;
    });
    return found;
}

// Deduplicated: spatial splits put a triangle in several leaves.
void collect_hits(const Layout& layout, const Ray& ray, std::vector<QueryHit>& out, size_t max_hits) {
    out.clear();
    if (max_hits == 0) return;
    RayContext r(ray);
    const double tmax = ray.tmax;
    visit_crossings(layout, r, [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
        double t;
        if (perturbed::crossing_in_range(ray, v0, v1, v2, tmax, t))
            out.push_back(perturbed::make_hit(ray, v0, v1, v2, id, t));
        return false;
    });
    std::sort(out.begin(), out.end(), [](const QueryHit& a, const QueryHit& b) {
        return a.t < b.t || (a.t == b.t && a.primitive < b.primitive);
    });
    out.erase(std::unique(out.begin(), out.end(),
                          [](const QueryHit& a, const QueryHit& b) { return a.primitive == b.primitive; }),
              out.end());
    if (out.size() > max_hits) out.resize(max_hits);
}

uint32_t count_crossings(const Layout& layout, const Ray& ray, std::vector<uint32_t>& scratch) {
    scratch.clear();
    RayContext r(ray);
    const double tmax = ray.tmax;
    visit_crossings(layout, r, [&](uint32_t id, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
        double t;
        if (perturbed::crossing_in_range(ray, v0, v1, v2, tmax, t)) scratch.push_back(id);
        return false;
    });
    if (scratch.size() > 1) {
        std::sort(scratch.begin(), scratch.end());
        scratch.erase(std::unique(scratch.begin(), scratch.end()), scratch.end());
    }
    return uint32_t(scratch.size());
}
