// SPDX-License-Identifier: MIT
// Recipes: a builder name, quality level or tree file to a recipe, its checks, and the recipes the
// core resolves by itself.
#include "spacebvh/recipe.hpp"

#include <string_view>

#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/settings.hpp"
#include "spacebvh/tree_file.hpp"

namespace spacebvh {
namespace {

bool is_preset_name(const std::string& name) {
    for (const std::string& known : builder_names())
        if (name == known) return true;
    return false;
}

std::string known_builders() {
    std::string names;
    for (const std::string& name : builder_names()) names += " " + name;
    for (const std::string& name : embree_tree_names()) names += " " + name;
    return names;
}

const BuildSetting& setting_named(std::string_view name) { return *find_build_setting(name, SettingSpelling::name); }

}  // namespace

TreeRecipe TreeRecipe::for_builder(const std::string& name) {
    constexpr std::string_view kOptimizeSuffix = "+opt";
    const bool optimized = name.ends_with(kOptimizeSuffix);
    const std::string base = optimized ? name.substr(0, name.size() - kOptimizeSuffix.size()) : name;
    const bool embree = spacebvh::is_embree_tree(base);
    if (!embree && !is_preset_name(base))
        throw Error("unknown builder '" + name + "'; known builders:" + known_builders() +
                    " (each also as NAME+opt, with reinsertion)");
    TreeRecipe recipe;
    // Embree's trees read the limits, costs and reinsertion of the binned preset's configuration.
    static_cast<BuildConfig&>(recipe) = BuildConfig::for_preset(embree ? Preset::binned : parse_preset(base));
    recipe.builder = base;
    if (optimized) recipe.reinsertion.iterations = kDefaultReinsertionIterations;
    return recipe;
}

TreeRecipe TreeRecipe::for_quality(Quality quality) {
    TreeRecipe recipe;
    static_cast<BuildConfig&>(recipe) = BuildConfig::for_quality(quality);
    recipe.builder = to_string(recipe.preset);
    return recipe;
}

TreeRecipe TreeRecipe::from_file(const std::string& path) {
    if (path.empty()) throw Error("a tree file recipe needs the file's path");
    TreeRecipe recipe;
    recipe.tree_file = path;
    return recipe;
}

bool TreeRecipe::is_embree_tree() const { return spacebvh::is_embree_tree(builder); }

void TreeRecipe::validate() const {
    if (!tree_file.empty()) return;  // loaded, not built: the settings are not used
    if (!is_embree_tree() && !is_preset_name(builder))
        throw Error("unknown builder '" + builder + "'; known builders:" + known_builders());
    if (!is_embree_tree() && parse_preset(builder) != preset)
        throw Error("recipe of builder '" + builder + "' holds the configuration of preset '" + to_string(preset) +
                    "' (start from TreeRecipe::for_builder)");
    BuildConfig::validate();
    if (termination.reinsertion_iterations > 0 && termination_rays == 0 && termination.segments.empty())
        throw Error("setting " + describe_setting(setting_named("termination_optimize")) + " needs " +
                    describe_setting(setting_named("termination_rays")) + " (the segments it prices nodes by)");
    if (!is_embree_tree()) return;
    const TreeRecipe embree_default = for_builder(builder);
    for (const BuildSetting& setting : build_settings())
        if (setting.ours_only && get_setting(*this, setting) != get_setting(embree_default, setting))
            throw Error("setting " + describe_setting(setting) + " applies to our builders, not to Embree's tree '" +
                        builder + "'");
}

Bvh build(const MeshView& mesh, const TreeRecipe& recipe) {
    recipe.validate();
    if (!recipe.tree_file.empty()) {
        const TriangleStore store(mesh);
        return load_bvh(recipe.tree_file, store.triangles());
    }
    if (recipe.is_embree_tree())
        throw Error("'" + recipe.builder +
                    "' is Embree's own tree: spacebvh::tools::make_tree builds it (the tools library links Embree)");
    if (recipe.termination_rays > 0)
        throw Error("setting " + describe_setting(setting_named("termination_rays")) +
                    " traces sample rays: spacebvh::tools::make_tree builds such a recipe (or give "
                    "termination.segments yourself)");
    return build(mesh, static_cast<const BuildConfig&>(recipe));
}

}  // namespace spacebvh
