// The named builders: each is a preset of the generic driver (search spaces + cost model).
#include <sstream>

#include "build/binned_object_split_finder.hpp"
#include "build/object_sweep_split_finder.hpp"
#include "build/top_down_builder.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {
namespace {

struct BuilderPreset {
    const char* name;
    uint32_t search_spaces;
    const char* description;
};

constexpr BuilderPreset kPresets[] = {
    {"cbvh", uint32_t(SearchSpace::object_sweep),
     "classical BVH: exact SAH sweep over centroid-sorted references on all three axes (Popov et al.'s CBVH)"},
    {"binned", uint32_t(SearchSpace::object_binned),
     "binned object SAH (Wald 2007), --bins bins per axis; the fast classical builder"},
};

const BuilderPreset* find_preset(const std::string& name) {
    for (const BuilderPreset& preset : kPresets)
        if (name == preset.name) return &preset;
    return nullptr;
}

// One place that turns a set of search spaces into split finders, for every preset.
std::vector<std::unique_ptr<build::SplitFinder>> make_search_spaces(uint32_t spaces, const BuildOptions& options) {
    std::vector<std::unique_ptr<build::SplitFinder>> finders;
    if (spaces & uint32_t(SearchSpace::object_sweep)) finders.push_back(std::make_unique<build::ObjectSweepSplitFinder>());
    if (spaces & uint32_t(SearchSpace::object_binned))
        finders.push_back(std::make_unique<build::BinnedObjectSplitFinder>(options.object_bins));
    return finders;
}

}  // namespace

std::vector<std::string> builder_names() {
    std::vector<std::string> names;
    for (const BuilderPreset& preset : kPresets) names.emplace_back(preset.name);
    return names;
}

std::string describe_builder(const std::string& name) {
    const BuilderPreset* preset = find_preset(name);
    return preset ? preset->description : "";
}

void BuildOptions::validate() const {
    if (!find_preset(builder)) {
        std::ostringstream message;
        message << "unknown builder '" << builder << "'; known builders:";
        for (const BuilderPreset& preset : kPresets) message << ' ' << preset.name;
        throw Error(message.str());
    }
    cost.validate();
    if (max_leaf_size < 1 || max_leaf_size > (1u << 20))
        throw Error("max leaf size must be in [1, 1048576], got " + std::to_string(max_leaf_size));
    if (max_depth < 1 || max_depth > 1024)
        throw Error("max depth must be in [1, 1024], got " + std::to_string(max_depth));
    if (object_bins < 2 || object_bins > build::kMaxObjectBins)
        throw Error("object bins must be in [2, " + std::to_string(build::kMaxObjectBins) + "], got " +
                    std::to_string(object_bins));
}

Bvh build_bvh(const Scene& scene, const BuildOptions& options) {
    options.validate();
    if (scene.triangles.empty()) throw Error("scene '" + scene.name + "' has no triangles to build a BVH over");
    if (scene.triangles.size() >= (size_t(1) << 31))
        throw Error("scene '" + scene.name + "' has too many triangles (at most 2^31 - 1)");
    const BuilderPreset& preset = *find_preset(options.builder);
    build::TopDownBuilder builder(options.cost, {options.max_leaf_size, options.max_depth},
                                  make_search_spaces(preset.search_spaces, options), options.progress);
    Bvh bvh = builder.build(build::make_references(scene));
    bvh.builder = options.builder;
    return bvh;
}

}  // namespace spacebvh
