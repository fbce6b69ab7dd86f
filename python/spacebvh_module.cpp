// SPDX-License-Identifier: MIT
// The Python module `spacebvh`: scenes from files or numpy arrays, the named builders, tree metrics,
// and the tracers on numpy ray arrays. A thin layer over the C++ API: every check and every answer
// is the library's (errors become spacebvh.Error, a RuntimeError, with the library's message).
// Builds and traces release the GIL and use oneTBB, `threads` at most (0 = all cores).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/render.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/embree_builder.hpp"
#include "spacebvh/tools/embree_scene.hpp"

namespace py = pybind11;
using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<int64_t, py::array::c_style | py::array::forcecast>;

// Runs `work` in an arena of `threads` oneTBB threads (0: the default, every core).
template <typename Work>
void in_arena(int threads, Work&& work) {
    if (threads < 0) throw Error("threads must be >= 0 (0 = every core), not " + std::to_string(threads));
    tbb::task_arena arena(threads == 0 ? tbb::task_arena::automatic : threads);
    arena.execute(work);
}

// An (n, 3) array as a flat span, or Error naming the argument.
template <typename T, int kFlags>
std::span<const T> rows_of_three(const py::array_t<T, kFlags>& array, const char* what) {
    if (array.ndim() != 2 || array.shape(1) != 3)
        throw Error(std::string(what) + " must have shape (n, 3), not " + std::to_string(array.ndim()) + " dimensions" +
                    (array.ndim() == 2 ? " of width " + std::to_string(array.shape(1)) : std::string()));
    return {array.data(), size_t(array.size())};
}

// One float per ray: a number (the same for every ray) or an array of n.
std::vector<float> per_ray(const py::object& value, size_t n, const char* what) {
    if (py::isinstance<py::float_>(value) || py::isinstance<py::int_>(value)) return std::vector<float>(n, value.cast<float>());
    const FloatArray array = FloatArray::ensure(value);
    if (array && array.ndim() == 0) return std::vector<float>(n, *array.data());  // a NumPy scalar
    if (!array || array.ndim() != 1 || size_t(array.shape(0)) != n)
        throw Error(std::string(what) + " must be a number or an array of " + std::to_string(n) + " (one per ray)");
    return {array.data(), array.data() + n};
}

// Rays from (n, 3) origins and directions and [tmin, tmax] (numbers or one per ray, 0 <= tmin <=
// tmax); each ray checked as ray files are (untraceable_ray_reason), naming the first bad one.
std::vector<Ray> make_rays(const FloatArray& origins, const FloatArray& directions, const py::object& tmin,
                           const py::object& tmax) {
    const std::span<const float> o = rows_of_three(origins, "origins"), d = rows_of_three(directions, "directions");
    if (o.size() != d.size())
        throw Error("origins and directions differ in length: " + std::to_string(o.size() / 3) + " and " +
                    std::to_string(d.size() / 3));
    std::vector<Ray> rays(o.size() / 3);
    const std::vector<float> low = per_ray(tmin, rays.size(), "tmin"), high = per_ray(tmax, rays.size(), "tmax");
    for (size_t i = 0; i < rays.size(); ++i) {
        Ray& ray = rays[i];
        ray.org = {o[3 * i], o[3 * i + 1], o[3 * i + 2]};
        ray.dir = {d[3 * i], d[3 * i + 1], d[3 * i + 2]};
        ray.tmin = low[i];
        ray.tmax = high[i];
        if (!(ray.tmin >= 0.0f) || !(ray.tmax >= ray.tmin))  // also refuses NaN
            throw Error("ray " + std::to_string(i) + ": need 0 <= tmin <= tmax, not tmin = " + std::to_string(ray.tmin) +
                        ", tmax = " + std::to_string(ray.tmax));
        if (const char* reason = untraceable_ray_reason(ray)) throw Error("ray " + std::to_string(i) + ": " + reason);
    }
    return rays;
}

// A tree with the scene it was built over (a tracer needs both; the scene is kept alive).
struct PyBvh {
    std::shared_ptr<Scene> scene;
    std::shared_ptr<const Bvh> bvh;
};

struct PyTracer {
    std::shared_ptr<Scene> scene;
    std::shared_ptr<const Bvh> bvh;
    std::unique_ptr<Tracer> tracer;
    int threads = 0;
};

PyBvh build_tree(std::shared_ptr<Scene> scene, const std::string& builder, std::optional<float> overlap_penalty,
            float traversal_cost, float intersection_cost, uint32_t leaf_block, uint32_t max_leaf_size,
                 float reference_budget, const std::string& search, uint32_t object_bins, uint32_t spatial_bins,
            std::optional<float> spatial_gate, float lookahead_top, uint32_t optimize, int threads) {
    // Embree 3's own binary trees (as the CLI's embree-medium / embree-high): the cost model and the
    // optimiser apply to them, our search options do not.
    const bool embree_tree = is_embree_tree(builder);
    if (embree_tree && (!search.empty() || spatial_gate || lookahead_top != 0.0f))
        throw Error("search, spatial_gate and lookahead_top apply to our builders, not to Embree's tree '" + builder + "'");
    BuildConfig options = config_for(embree_tree ? "binned" : builder);
    if (!search.empty()) options.search_spaces = parse_search_spaces(search);
    options.object.bins = object_bins;
    options.spatial.bins = spatial_bins;
    if (spatial_gate) options.spatial.gate_alpha = *spatial_gate;
    if (overlap_penalty) options.cost.overlap_penalty = *overlap_penalty;
    options.cost.traversal_cost = traversal_cost;
    options.cost.intersection_cost = intersection_cost;
    options.cost.leaf_block = leaf_block;
    options.limits.max_leaf_size = max_leaf_size;
    options.limits.reference_budget = reference_budget;
    options.lookahead.top_share = lookahead_top;
    options.reinsertion.iterations = optimize;
    options.validate();
    auto bvh = std::make_shared<Bvh>();
    {
        py::gil_scoped_release unlocked;
        in_arena(threads, [&] {
            *bvh = embree_tree ? build_embree_tree(*scene, builder, options) : spacebvh::build(*scene, options);
        });
    }
    return {std::move(scene), std::move(bvh)};
}

py::dict stats_of(const PyBvh& tree, bool with_epo) {
    TreeStats stats;
    {
        py::gil_scoped_release unlocked;
        stats = compute_tree_stats(*tree.scene, *tree.bvh, tree.bvh->cost, with_epo);
    }
    py::dict result;
    result["nodes"] = stats.nodes;
    result["inner_nodes"] = stats.inner_nodes;
    result["leaves"] = stats.leaves;
    result["max_depth"] = stats.max_depth;
    result["mean_leaf_depth"] = stats.mean_leaf_depth;
    result["references"] = stats.references;
    result["distinct_primitives"] = stats.distinct_primitives;
    result["bytes"] = stats.bytes;
    result["sah"] = stats.sah;
    if (with_epo) result["epo"] = stats.epo;
    return result;
}

// Closest hits as (t, primitive, u, v) arrays; a miss has t = inf and primitive = -1.
py::tuple hits_as_arrays(const std::vector<Hit>& hits) {
    const py::ssize_t n = py::ssize_t(hits.size());
    py::array_t<float> t(n), u(n), v(n);
    py::array_t<int64_t> primitive(n);
    float* t_out = t.mutable_data();
    float* u_out = u.mutable_data();
    float* v_out = v.mutable_data();
    int64_t* primitive_out = primitive.mutable_data();
    for (size_t i = 0; i < hits.size(); ++i) {
        const Hit& hit = hits[i];
        t_out[i] = hit.t;
        primitive_out[i] = hit.is_hit() ? int64_t(hit.primitive) : -1;
        u_out[i] = hit.u;
        v_out[i] = hit.v;
    }
    return py::make_tuple(t, primitive, u, v);
}

py::array_t<bool> answers_as_array(const std::vector<uint8_t>& answers) {
    py::array_t<bool> result(py::ssize_t(answers.size()));
    bool* out = result.mutable_data();
    for (size_t i = 0; i < answers.size(); ++i) out[i] = answers[i] != 0;
    return result;
}

// Makes rays from the arrays (make_rays), then answers them with trace(rays, answers) outside the
// GIL on `threads` threads (0: all).
template <class Answer, class Trace>
std::vector<Answer> trace_arrays(int threads, const FloatArray& origins, const FloatArray& directions, const py::object& tmin,
                                 const py::object& tmax, Trace&& trace) {
    const std::vector<Ray> rays = make_rays(origins, directions, tmin, tmax);
    std::vector<Answer> answers(rays.size());
    {
        py::gil_scoped_release unlocked;
        in_arena(threads, [&] { trace(std::span<const Ray>(rays), std::span<Answer>(answers)); });
    }
    return answers;
}

py::tuple closest_hits(const PyTracer& self, const FloatArray& origins, const FloatArray& directions, const py::object& tmin,
                       const py::object& tmax) {
    return hits_as_arrays(trace_arrays<Hit>(self.threads, origins, directions, tmin, tmax,
                                            [&](auto rays, auto hits) { self.tracer->intersect(rays, hits); }));
}

py::array_t<bool> any_hits(const PyTracer& self, const FloatArray& origins, const FloatArray& directions,
                           const py::object& tmin, const py::object& tmax) {
    return answers_as_array(trace_arrays<uint8_t>(self.threads, origins, directions, tmin, tmax,
                                                  [&](auto rays, auto answers) { self.tracer->occluded(rays, answers); }));
}

// An Image as a (height, width, 3) uint8 array (row 0 at the top).
py::array_t<uint8_t> image_as_array(const Image& image) {
    py::array_t<uint8_t> out({py::ssize_t(image.height), py::ssize_t(image.width), py::ssize_t(3)});
    std::copy(image.rgb.begin(), image.rgb.end(), out.mutable_data());
    return out;
}

// The shaded view (heatmap=False) or the traversal-cost heat map of the primary rays, as the CLI's
// `render`; the heat map also returns its scale and totals.
py::object render(const PyTracer& self, uint32_t width, uint32_t height, const std::string& camera, bool heatmap,
                  const std::string& quantity, double percentile, double scale_max, bool legend) {
    const Camera view = camera.empty() ? default_camera(*self.scene) : Camera::parse(camera);
    HeatmapOptions options;
    options.quantity = parse_heatmap_quantity(quantity);
    options.percentile = percentile;
    options.scale_max = scale_max;
    options.legend = legend;
    validate(options);  // also for a shaded view: bad heat-map options are refused whatever is drawn
    Image image;
    HeatmapInfo info;
    {
        py::gil_scoped_release unlocked;
        in_arena(self.threads, [&] {
            image = heatmap ? render_heatmap(*self.scene, *self.tracer, view, width, height, &info, options)
                            : render_shaded(*self.scene, *self.tracer, view, width, height);
        });
    }
    if (!heatmap) return image_as_array(image);
    py::dict details;
    details["scale_max"] = info.scale_max;
    details["max_value"] = info.max_value;
    details["mean_value"] = info.mean_value;
    details["nodes_visited"] = info.totals.nodes_visited;
    details["triangles_tested"] = info.totals.triangles_tested;
    details["legend_height"] = info.legend_height;
    return py::make_tuple(image_as_array(image), details);
}

// Embree 3's own scene and kernel on the same rays: the yardstick of every benchmark. Single rays
// (rtcIntersect1 / rtcOccluded1) or 16-wide packets (rtcIntersect16 / rtcOccluded16). Embree is not
// watertight: near edges and vertices its answers may differ from ours (the arbiter of rays.md
// settles such cases in our favour).
struct PyEmbreeTracer {
    std::shared_ptr<Scene> scene;
    std::unique_ptr<EmbreeScene> embree;
    bool packets = false;
    int threads = 0;
};

py::tuple embree_closest_hits(const PyEmbreeTracer& self, const FloatArray& origins, const FloatArray& directions,
                              const py::object& tmin, const py::object& tmax) {
    return hits_as_arrays(trace_arrays<Hit>(self.threads, origins, directions, tmin, tmax, [&](auto rays, auto hits) {
        self.packets ? self.embree->intersect16(rays, hits) : self.embree->intersect(rays, hits);
    }));
}

py::array_t<bool> embree_any_hits(const PyEmbreeTracer& self, const FloatArray& origins, const FloatArray& directions,
                                  const py::object& tmin, const py::object& tmax) {
    return answers_as_array(trace_arrays<uint8_t>(self.threads, origins, directions, tmin, tmax, [&](auto rays, auto answers) {
        self.packets ? self.embree->occluded16(rays, answers) : self.embree->occluded(rays, answers);
    }));
}

// (origins, directions) of generated rays (tmin = 0, tmax = inf by the spec), or with their
// (tmin, tmax) arrays too, as ray files carry them.
py::tuple rays_as_arrays(const std::vector<Ray>& rays, bool with_range = false) {
    const py::ssize_t n = py::ssize_t(rays.size());
    py::array_t<float> origins({n, py::ssize_t(3)}), directions({n, py::ssize_t(3)}), tmin(n), tmax(n);
    auto o = origins.mutable_unchecked<2>(), d = directions.mutable_unchecked<2>();
    float* low = tmin.mutable_data();
    float* high = tmax.mutable_data();
    for (py::ssize_t i = 0; i < n; ++i) {
        const Ray& ray = rays[size_t(i)];
        for (int axis = 0; axis < 3; ++axis) {
            o(i, axis) = ray.org[axis];
            d(i, axis) = ray.dir[axis];
        }
        low[i] = ray.tmin;
        high[i] = ray.tmax;
    }
    return with_range ? py::make_tuple(origins, directions, tmin, tmax) : py::make_tuple(origins, directions);
}

// Hit records (docs/rays.md) from t and primitive arrays (-1 = a miss, t = inf).
std::vector<HitRecord> make_hit_records(const FloatArray& t, const IndexArray& primitive) {
    if (t.ndim() != 1 || primitive.ndim() != 1 || t.shape(0) != primitive.shape(0))
        throw Error("t and primitive must be arrays of one length");
    std::vector<HitRecord> records(size_t(t.shape(0)));
    for (size_t i = 0; i < records.size(); ++i) {
        const float distance = t.data()[i];
        const int64_t id = primitive.data()[i];
        if (std::isnan(distance)) throw Error("hit " + std::to_string(i) + ": t is NaN");
        if (id < -1 || id >= int64_t(kInvalidIndex))
            throw Error("hit " + std::to_string(i) + ": primitive " + std::to_string(id) + " out of range (-1 = a miss)");
        records[i] = {distance, id < 0 ? kInvalidIndex : uint32_t(id)};
    }
    return records;
}

py::tuple hit_records_as_arrays(const std::vector<HitRecord>& records) {
    const py::ssize_t n = py::ssize_t(records.size());
    py::array_t<float> t(n);
    py::array_t<int64_t> primitive(n);
    float* t_out = t.mutable_data();
    int64_t* primitive_out = primitive.mutable_data();
    for (size_t i = 0; i < records.size(); ++i) {
        t_out[i] = records[i].t;
        primitive_out[i] = records[i].primitive == kInvalidIndex ? -1 : int64_t(records[i].primitive);
    }
    return py::make_tuple(t, primitive);
}

SceneTransform make_transform(const std::string& rotate, float scale, const std::vector<float>& translate) {
    SceneTransform transform;
    if (!rotate.empty()) transform.rotate_degrees = SceneTransform::parse_rotation(rotate);
    transform.scale = scale;
    if (translate.size() != 3) throw Error("translate must be three numbers (x, y, z)");
    transform.translate = {translate[0], translate[1], translate[2]};
    if (const char* reason = transform.invalid_reason()) throw Error(reason);
    return transform;
}

}  // namespace

PYBIND11_MODULE(spacebvh, m) {
    m.doc() = "spacebvh: BVHs built by space subdivision (Popov et al. 2009), their metrics and exact tracers";
#if PYBIND11_VERSION_MAJOR == 2 && PYBIND11_VERSION_MINOR < 12
    // pybind11 before 2.12 reads NumPy 1's array structures: under NumPy 2 its arrays come back with
    // wrong contents (every answer a miss), so refuse to load rather than answer wrongly.
    const std::string numpy_version = py::module_::import("numpy").attr("__version__").cast<std::string>();
    if (numpy_version.empty() || numpy_version[0] != '1')
        throw py::import_error("spacebvh was built with pybind11 " + std::to_string(PYBIND11_VERSION_MAJOR) + "." +
                               std::to_string(PYBIND11_VERSION_MINOR) + ", which does not support NumPy " + numpy_version +
                               ": install numpy<2 (scripts/install-deps.sh does) or build with pybind11 >= 2.12");
#endif
    static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
    py::register_exception_translator([](std::exception_ptr pointer) {
        try {
            if (pointer) std::rethrow_exception(pointer);
        } catch (const Error& e) {
            error(e.what());
        }
    });

    py::class_<Scene, std::shared_ptr<Scene>>(m, "Scene", "Triangles in file (or index) order; degenerate ones are kept and never hit.")
        .def_property_readonly("name", [](const Scene& s) { return s.name; })
        .def_property_readonly("triangle_count", [](const Scene& s) { return s.triangles.size(); })
        .def_property_readonly("degenerate_count", [](const Scene& s) { return s.degenerate_count; })
        .def_property_readonly("bounds",
                               [](const Scene& s) {
                                   const AABB box = s.bounds();
                                   return py::make_tuple(py::make_tuple(box.lo.x, box.lo.y, box.lo.z),
                                                         py::make_tuple(box.hi.x, box.hi.y, box.hi.z));
                               })
        .def("__repr__", [](const Scene& s) {
            return "<spacebvh.Scene '" + s.name + "', " + std::to_string(s.triangles.size()) + " triangles>";
        });

    m.def(
        "load_scene",
        [](const std::string& source, const std::string& rotate, float scale, const std::vector<float>& translate) {
            return std::make_shared<Scene>(load_scene(source, make_transform(rotate, scale, translate)));
        },
        py::arg("source"), py::kw_only(), py::arg("rotate") = "", py::arg("scale") = 1.0f,
        py::arg("translate") = std::vector<float>{0.0f, 0.0f, 0.0f},
        "Loads .obj, .ply, .gltf or .glb, or builtin:NAME (see builtin_scenes()), with the CLI's load-time transform: "
        "rotate='x:45,y:45,z:45' (degrees, R = Rz*Ry*Rx), then scale, then translate.");
    m.def(
        "mesh",
        [](const FloatArray& vertices, const IndexArray& indices, const std::string& name) {
            return std::make_shared<Scene>(
                make_indexed_scene(rows_of_three(vertices, "vertices"), rows_of_three(indices, "indices"), name));
        },
        py::arg("vertices"), py::arg("indices"), py::arg("name") = "mesh",
        "A scene from an indexed mesh: vertices (n, 3) floats, indices (m, 3) 0-based vertex indices.");
    m.def("builtin_scenes", &builtin_scene_names);
    m.def("builders", [] {
        std::vector<std::string> names = builder_names();
        names.insert(names.end(), embree_tree_names().begin(), embree_tree_names().end());  // Embree 3's own binary trees
        return names;
    });
    m.def("kernels", &kernel_names);

    py::class_<PyBvh>(m, "Bvh", "A binary BVH and the scene it was built over.")
        .def_property_readonly("builder", [](const PyBvh& t) { return t.bvh->builder; })
        .def_property_readonly("cost_model", [](const PyBvh& t) { return t.bvh->cost.describe(); })
        .def_property_readonly("node_count", [](const PyBvh& t) { return t.bvh->nodes.size(); })
        .def_property_readonly("reference_count", [](const PyBvh& t) { return t.bvh->primitives.size(); })
        .def_property_readonly("sah", [](const PyBvh& t) { return tree_sah(*t.bvh, t.bvh->cost); })
        .def("stats", &stats_of, py::arg("epo") = false,
             "Structure, memory and tree SAH (and EPO, the slow one, with epo=True) as a dict.");

    m.def("build", &build_tree, py::arg("scene"), py::arg("builder") = "binned", py::kw_only(),
          py::arg("overlap_penalty") = py::none(), py::arg("traversal_cost") = 1.0f, py::arg("intersection_cost") = 1.0f,
          py::arg("leaf_block") = 1u, py::arg("max_leaf_size") = 8u, py::arg("reference_budget") = 1.3f,
          py::arg("search") = "", py::arg("object_bins") = 32u, py::arg("spatial_bins") = 32u,
          py::arg("spatial_gate") = py::none(), py::arg("lookahead_top") = 0.0f,
          py::arg("optimize") = 0u, py::arg("threads") = 0,
          "Builds a BVH with a named builder (builders()); overlap_penalty defaults to the builder's own C_o "
          "(float('inf'): disjoint children only); search = the CLI's --search ('binned,spatial': the fast spatial "
          "variant; '' = the builder's own); object_bins, spatial_bins = --bins, --spatial-bins; spatial_gate = "
          "--spatial-gate (None = the builder's own alpha); lookahead_top = --lookahead-top (nodes with at least "
          "this share of the references choose their split by building each search space's best out to the leaves; "
          "0 = off); "
          "optimize = reinsertion iterations (0 = off, 16 = the CLI's --optimize). Deterministic whatever `threads`.");

    py::class_<PyTracer>(m, "Tracer", "A traversal kernel over a tree; answers equal the exact arbiter of rays.md.")
        .def(py::init([](const PyBvh& tree, const std::string& kernel, int threads) {
                 auto tracer = make_tracer(kernel, *tree.scene, *tree.bvh);
                 return PyTracer{tree.scene, tree.bvh, std::move(tracer), threads};
             }),
             py::arg("bvh"), py::arg("kernel") = "auto", py::arg("threads") = 0)
        .def_property_readonly("kernel", [](const PyTracer& self) { return self.tracer->name(); })
        .def_property_readonly("memory_bytes", [](const PyTracer& self) { return self.tracer->memory_bytes(); })
        .def("intersect", &closest_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0f,
             py::arg("tmax") = kInfinity,
             "Closest hits within [tmin, tmax] (numbers, or arrays of one per ray): arrays t, primitive (-1 on a miss), u, v.")
        .def("occluded", &any_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0f,
             py::arg("tmax") = kInfinity, "Any hit within [tmin, tmax] (numbers, or arrays of one per ray): a bool array.")
        .def("render", &render, py::arg("width") = 512u, py::arg("height") = 512u, py::arg("camera") = "", py::kw_only(),
             py::arg("heatmap") = false, py::arg("quantity") = "work", py::arg("percentile") = 0.99, py::arg("scale_max") = 0.0,
             py::arg("legend") = true,
             "The CLI's render through this tracer, with primary_rays()'s camera: a (height, width, 3) uint8 shaded "
             "image; with heatmap=True the per-pixel traversal cost (quantity: work, nodes or triangles; the ramp's top "
             "at the percentile, or at scale_max > 0 to share a scale; legend rows appended below) and a dict of its "
             "scale and totals.");
    m.def(
        "write_png",
        [](const std::string& path, const py::array_t<uint8_t, py::array::c_style | py::array::forcecast>& pixels) {
            if (pixels.ndim() != 3 || pixels.shape(2) != 3 || pixels.shape(0) == 0 || pixels.shape(1) == 0)
                throw Error("write_png needs a (height, width, 3) uint8 array");
            Image image(uint32_t(pixels.shape(1)), uint32_t(pixels.shape(0)));
            std::copy(pixels.data(), pixels.data() + image.rgb.size(), image.rgb.begin());
            write_png(path, image);
        },
        py::arg("path"), py::arg("pixels"), "Writes a (height, width, 3) uint8 array, e.g. render()'s, as a PNG file.");

    py::class_<PyEmbreeTracer>(m, "EmbreeTracer",
                               "Embree 3's own BVH and kernel over a scene, on the same numpy rays (not watertight).")
        .def(py::init([](std::shared_ptr<Scene> scene, const std::string& quality, bool packets, int threads) {
                 const EmbreeQuality level = parse_embree_quality(quality);
                 std::unique_ptr<EmbreeScene> embree;
                 {
                     py::gil_scoped_release unlocked;
                     in_arena(threads, [&] { embree = std::make_unique<EmbreeScene>(*scene, level); });
                 }
                 return PyEmbreeTracer{std::move(scene), std::move(embree), packets, threads};
             }),
             py::arg("scene"), py::arg("quality") = "high", py::arg("packets") = false, py::arg("threads") = 0,
             "quality: 'low', 'medium' or 'high' (RTC_BUILD_QUALITY_*); packets: rtcIntersect16/rtcOccluded16 over "
             "groups of 16 consecutive rays instead of single rays.")
        .def_property_readonly("kernel",
                               [](const PyEmbreeTracer& self) {
                                   return std::string("embree-") + to_string(self.embree->quality()) +
                                          (self.packets ? " rtcIntersect16" : " rtcIntersect1");
                               })
        .def_property_readonly("build_ms", [](const PyEmbreeTracer& self) { return self.embree->build_milliseconds(); })
        .def_property_readonly("memory_bytes", [](const PyEmbreeTracer& self) { return self.embree->memory_bytes(); })
        .def("intersect", &embree_closest_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0f,
             py::arg("tmax") = kInfinity, "As Tracer.intersect: arrays t, primitive (-1 on a miss), u, v.")
        .def("occluded", &embree_any_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0f,
             py::arg("tmax") = kInfinity, "As Tracer.occluded: a bool array.");

    m.def(
        "random_rays",
        [](const Scene& scene, size_t count, uint64_t seed) { return rays_as_arrays(generate_random_rays(scene.bounds(), count, seed)); },
        py::arg("scene"), py::arg("count"), py::arg("seed") = 1,
        "The random rays of docs/rays.md: (origins, directions) arrays.");
    m.def(
        "primary_rays",
        [](const Scene& scene, uint32_t width, uint32_t height, const std::string& camera) {
            return rays_as_arrays(generate_primary_rays(camera.empty() ? default_camera(scene) : Camera::parse(camera), width, height));
        },
        py::arg("scene"), py::arg("width") = 1024u, py::arg("height") = 1024u, py::arg("camera") = "",
        "The primary rays of docs/rays.md, row by row from the top: (origins, directions) arrays. camera: "
        "'ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy' (the MANIFEST's values), default the spec's camera for the scene.");
    m.def(
        "diffuse_rays",
        [](const Scene& scene, const FloatArray& origins, const FloatArray& directions, const FloatArray& t,
           const IndexArray& primitive, uint64_t seed, float epsilon) {
            if (!(std::isfinite(epsilon) && epsilon >= 0.0f))
                throw Error("epsilon must be finite and >= 0 (0: the spec's default, 1e-4 x |scene diagonal|), not " +
                            std::to_string(epsilon));
            const std::vector<Ray> primary = make_rays(origins, directions, py::float_(0.0), py::float_(kInfinity));
            const std::vector<HitRecord> records = make_hit_records(t, primitive);
            std::vector<Hit> hits(records.size());
            for (size_t i = 0; i < records.size(); ++i) {
                if (records[i].primitive == kInvalidIndex) continue;
                if (!std::isfinite(records[i].t) || records[i].t < 0.0f)
                    throw Error("hit " + std::to_string(i) + ": a hit needs a finite t >= 0, not " + std::to_string(records[i].t));
                hits[i].t = records[i].t;
                hits[i].primitive = records[i].primitive;
            }
            return rays_as_arrays(generate_diffuse_rays(scene, primary, hits, seed, epsilon));
        },
        py::arg("scene"), py::arg("origins"), py::arg("directions"), py::arg("t"), py::arg("primitive"),
        py::arg("seed") = 1, py::arg("epsilon") = 0.0f,
        "The diffuse rays of docs/rays.md: one cosine-distributed bounce per primary ray that hits (t, "
        "primitive: intersect()'s answers for those rays, primitive -1 = a miss), in primary order, leaving the "
        "surface at epsilon along its normal (0: the spec's default). Returns (origins, directions) arrays.");
    m.def(
        "read_rays", [](const std::string& path) { return rays_as_arrays(read_ray_file(path), true); }, py::arg("path"),
        "A ray file of docs/rays.md: (origins, directions, tmin, tmax) arrays.");
    m.def(
        "write_rays",
        [](const std::string& path, const FloatArray& origins, const FloatArray& directions, const py::object& tmin,
           const py::object& tmax) { write_ray_file(path, make_rays(origins, directions, tmin, tmax)); },
        py::arg("path"), py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0f, py::arg("tmax") = kInfinity,
        "Writes a ray file of docs/rays.md (tmin, tmax: numbers or one per ray).");
    m.def(
        "read_hits", [](const std::string& path) { return hit_records_as_arrays(read_hit_file(path)); }, py::arg("path"),
        "A hit file of docs/rays.md: (t, primitive) arrays, primitive -1 for a miss (occlusion files: t = 0 "
        "occluded, inf free).");
    m.def(
        "write_hits",
        [](const std::string& path, const FloatArray& t, const IndexArray& primitive) {
            write_hit_file(path, make_hit_records(t, primitive));
        },
        py::arg("path"), py::arg("t"), py::arg("primitive"),
        "Writes a hit file of docs/rays.md from t and primitive arrays (-1 = a miss), e.g. intersect()'s.");
}
