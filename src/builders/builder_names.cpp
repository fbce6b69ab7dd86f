// SPDX-License-Identifier: MIT
#include <algorithm>
#include <iterator>
#include <sstream>

#include "builders/preset_table.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh {
namespace {

struct SearchSpaceName {
    const char* name;
    SearchSpace space;
};
constexpr SearchSpaceName kSearchSpaceNames[] = {
    {"object", SearchSpace::object_sweep},
    {"binned", SearchSpace::object_binned},
    {"spatial", SearchSpace::spatial_binned},
    {"spatial-sweep", SearchSpace::spatial_sweep},
    {"grid", SearchSpace::grid},
};

const builders::BuilderPreset* find_preset(const std::string& name) {
    for (const builders::BuilderPreset& preset : builders::kPresets)
        if (name == preset.name) return &preset;
    return nullptr;
}

}  // namespace

std::vector<std::string> builder_names() {
    std::vector<std::string> names;
    for (const builders::BuilderPreset& preset : builders::kPresets) names.emplace_back(preset.name);
    return names;
}

Preset parse_preset(const std::string& name) {
    if (const builders::BuilderPreset* preset = find_preset(name)) return preset->preset;
    std::ostringstream message;
    message << "unknown builder '" << name << "'; known builders:";
    for (const builders::BuilderPreset& preset : builders::kPresets) message << ' ' << preset.name;
    throw Error(message.str());
}

BuildConfig config_for(const std::string& builder) { return BuildConfig::for_preset(parse_preset(builder)); }

std::string describe_builder(const std::string& name) {
    const builders::BuilderPreset* preset = find_preset(name);
    return preset ? preset->description : "";
}

const std::vector<std::string>& embree_tree_names() {
    static const std::vector<std::string> names{"embree-medium", "embree-high"};
    return names;
}

bool is_embree_tree(const std::string& builder) {
    const auto& names = embree_tree_names();
    return std::find(names.begin(), names.end(), builder) != names.end();
}

std::vector<std::string> quality_names() { return {"fast", "balanced", "high"}; }

const char* to_string(Quality quality) {
    switch (quality) {
        case Quality::fast:
            return "fast";
        case Quality::balanced:
            return "balanced";
        case Quality::high:
            return "high";
    }
    return "?";
}

Quality parse_quality(const std::string& name) {
    for (Quality quality : {Quality::fast, Quality::balanced, Quality::high})
        if (name == to_string(quality)) return quality;
    throw Error("unknown quality '" + name + "' (known: fast, balanced, high)");
}

uint32_t parse_search_spaces(const std::string& names) {
    uint32_t spaces = 0;
    std::string name;
    auto take = [&] {
        if (name.empty()) return;
        const auto known = std::find_if(std::begin(kSearchSpaceNames), std::end(kSearchSpaceNames),
                                        [&](const SearchSpaceName& entry) { return name == entry.name; });
        if (known == std::end(kSearchSpaceNames))
            throw Error("unknown search space '" + name + "' in '" + names +
                        "' (known: object, binned, spatial, spatial-sweep, grid)");
        spaces |= uint32_t(known->space);
        name.clear();
    };
    for (char c : names) {
        if (c == ',' || c == '+')
            take();
        else if (c != ' ')
            name += c;
    }
    take();
    if (spaces == 0)
        throw Error("empty list of search spaces '" + names +
                    "' (known: object, binned, spatial, spatial-sweep, grid)");
    return spaces;
}

std::string search_space_names(uint32_t spaces) {
    std::string names;
    for (const SearchSpaceName& entry : kSearchSpaceNames)
        if (spaces & uint32_t(entry.space)) {
            if (!names.empty()) names += '+';
            names += entry.name;
        }
    return names;
}

}  // namespace spacebvh
