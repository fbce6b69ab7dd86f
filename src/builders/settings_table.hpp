// SPDX-License-Identifier: MIT
// The table of build settings (spacebvh/settings.hpp) with the recipe field each one reads and writes.
#pragma once

#include <cstdint>
#include <variant>
#include <vector>

#include "spacebvh/settings.hpp"

namespace spacebvh::builders {

// The field of a recipe a setting lives in, by its C++ type: number -> float, whole and search spaces
// -> uint32_t, flag -> bool, bytes -> uint64_t (settings.cpp checks each entry's type against it).
using FloatField = float& (*)(TreeRecipe&);
using UintField = uint32_t& (*)(TreeRecipe&);
using FlagField = bool& (*)(TreeRecipe&);
using BytesField = uint64_t& (*)(TreeRecipe&);
using SettingField = std::variant<FloatField, UintField, FlagField, BytesField>;

struct SettingEntry {
    BuildSetting setting;
    SettingField field;
};

// In the command line's order.
const std::vector<SettingEntry>& setting_entries();

}  // namespace spacebvh::builders
