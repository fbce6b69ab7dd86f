// SPDX-License-Identifier: MIT
// Building trees: a builder or quality level with the build settings (settings.cpp), Embree 3's own
// binary trees, and the trees' metrics.
#include <optional>

#include "bindings.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tree_file.hpp"
#include "spacebvh/tools/embree_builder.hpp"
#include "spacebvh/tools/make_tree.hpp"
#include "spacebvh/tools/metrics.hpp"

namespace spacebvh::python {

using namespace spacebvh::tools;

namespace {

PyBvh build(const PyScene& scene, const std::optional<std::string>& builder, const py::object& quality, int threads,
            const py::kwargs& settings) {
    auto recipe = std::make_shared<TreeRecipe>(recipe_from(builder, quality, settings));
    auto bvh = std::make_shared<Bvh>();
    without_gil(threads, [&] { *bvh = make_tree(*scene.scene, *recipe); });
    return {scene, std::move(bvh), std::move(recipe)};
}

py::dict stats_of(const PyBvh& tree, bool with_epo) {
    TreeStats stats;
    {
        py::gil_scoped_release unlocked;
        stats = compute_tree_stats(*tree.scene.scene, *tree.bvh, tree.bvh->cost, with_epo);
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

}  // namespace

void bind_build(py::module_& m) {
    m.def(
        "builders",
        [] {
            std::vector<std::string> names = builder_names();
            names.insert(names.end(), embree_tree_names().begin(),
                         embree_tree_names().end());  // Embree 3's own binary trees
            return names;
        },
        "The builder names build() accepts (ours, then Embree 3's own binary trees).");

    py::class_<PyBvh>(m, "Bvh", "A binary BVH and the scene it was built over.")
        .def_property_readonly(
            "scene", [](const PyBvh& t) { return t.scene; }, "The scene the tree was built over.")
        .def_property_readonly(
            "builder", [](const PyBvh& t) { return t.bvh->builder; },
            "The builder's name, '+opt' when reinsertion optimised it.")
        .def_property_readonly(
            "settings", [](const PyBvh& t) { return t.recipe ? py::object(settings_of(*t.recipe)) : py::none(); },
            "The build settings the tree was built with (build_settings() names), None for a loaded tree.")
        .def_property_readonly(
            "cost_model", [](const PyBvh& t) { return t.bvh->cost.describe(); },
            "The cost model the tree was built and is scored with.")
        .def_property_readonly(
            "node_count", [](const PyBvh& t) { return t.bvh->nodes.size(); }, "Nodes, inner and leaves.")
        .def_property_readonly(
            "reference_count", [](const PyBvh& t) { return t.bvh->primitives.size(); },
            "Triangle references in the leaves (spatial splits reference a triangle more than once).")
        .def_property_readonly(
            "sah", [](const PyBvh& t) { return tree_sah(*t.bvh, t.bvh->cost); },
            "The tree's SAH cost under its cost model.")
        .def("stats", &stats_of, py::arg("epo") = false,
             "Structure, memory and tree SAH (and EPO, the slow one, with epo=True) as a dict.")
        .def(
            "save",
            [](const PyBvh& t, const std::string& path) {
                py::gil_scoped_release unlocked;
                save_bvh(path, *t.bvh, t.scene.scene->triangles, "python");
            },
            py::arg("path"),
            "Writes the tree to a tree file (docs/tree-format.md); load_bvh(path, scene) reads it back without "
            "rebuilding.")
        // Pickling: the scene and the tree file's bytes, validated again (checksum, geometry hash, structure)
        // when unpickled.
        .def(py::pickle(
            [](const PyBvh& t) {
                const std::vector<std::byte> bytes = serialize_bvh(*t.bvh, t.scene.scene->triangles, "python");
                return py::make_tuple(t.scene, py::bytes(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
            },
            [](const py::tuple& state) {
                if (state.size() != 2)
                    throw Error("Bvh pickle: expected 2 fields, got " + std::to_string(state.size()));
                PyScene scene = state[0].cast<PyScene>();
                const std::string data = state[1].cast<std::string>();
                const auto* begin = reinterpret_cast<const std::byte*>(data.data());
                auto bvh = std::make_shared<Bvh>(deserialize_bvh(std::span<const std::byte>(begin, data.size()),
                                                                 scene.scene->triangles, "pickled Bvh"));
                return PyBvh{std::move(scene), std::move(bvh)};
            }));

    m.def(
        "load_bvh",
        [](const std::string& path, const PyScene& scene) {
            std::shared_ptr<Bvh> bvh;
            {
                py::gil_scoped_release unlocked;
                bvh = std::make_shared<Bvh>(load_bvh(path, scene.scene->triangles));
            }
            return PyBvh{scene, std::move(bvh)};
        },
        py::arg("path"), py::arg("scene"),
        "Reads a tree file (Bvh.save, or the CLI's build --save) built over this scene; raises spacebvh.Error naming "
        "the file when it is truncated, corrupted, of another format version or built over other geometry.");

    m.def("build", &build, py::arg("scene"), py::arg("builder") = py::none(), py::kw_only(),
          py::arg("quality") = py::none(), py::arg("threads") = 0, build_doc().c_str());
}

}  // namespace spacebvh::python
