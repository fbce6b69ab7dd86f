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
