// SPDX-License-Identifier: MIT
// The build settings: one table from which the command line's flags, the compare rows' keys and
// Python's build() keywords are all made, so that a setting has one name, type, range, default and
// help everywhere, and a setting added here reaches every front end. Values are read and written on
// a TreeRecipe; defaults are TreeRecipe{}'s (never restated here) and ranges those
// TreeRecipe::validate enforces (tests hold the two together).
// Implemented in src/builders/settings.cpp (the table: src/builders/settings_table.cpp).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "spacebvh/recipe.hpp"

namespace spacebvh {

enum class SettingType {
    number,         // a float; "inf" where the range allows it
    whole,          // an unsigned 32-bit integer
    flag,           // on or off; as text 1/0 or true/false
    search_spaces,  // a union of search space names (parse_search_spaces); "" = the builder's own
    bytes,          // a size in bytes; as text also with K, M, G or T (powers of 1024)
};
const char* to_string(SettingType type);  // "number"

// The three spellings of a setting: Python's keyword (and the one name), the command line's flag and
// the compare row's key.
enum class SettingSpelling { name, flag, row_key };

struct BuildSetting {
    std::string name = {};     // "overlap_penalty": Python's keyword, the settings' key everywhere
    std::string flag = {};     // "--co"; a flag setting's option turns it from its default ("--no-unsplitting")
    std::string row_key = {};  // "co" in a compare row: NAME@co=0.5
    SettingType type = SettingType::number;
    // The range validate() enforces, for numbers, whole numbers and bytes: [min, max], or (min, max] when
    // min_exclusive; max = inf is open unless allows_infinity (inf is then a value: C_o).
    double min = 0, max = 0;
    bool min_exclusive = false;
    bool allows_infinity = false;
    std::string range_note = {};   // what [min, max] leaves out: "a power of two", "0 = off, else >= 0.01"
    bool builder_default = false;  // the default is the builder's own (C_o, the spatial gate, the search spaces)
    bool ours_only = false;        // refused for Embree's trees, which cannot honour it
    std::string example = {};      // a valid value other than the default, as text (for the docs and tests)
    // One line; "{name}" names another setting, which setting_help spells as the front end does.
    std::string help = {};

    std::string range_text() const;  // "[2, 256]", "(0, 64]", "[0, inf]; a power of two"; "" for flags and lists
};

// A value as each type holds it: flag bool, whole and bytes uint64_t, number double, search spaces text.
using SettingValue = std::variant<bool, uint64_t, double, std::string>;

// In the command line's order (the order of --help).
const std::vector<BuildSetting>& build_settings();
const std::string& spelled(const BuildSetting& setting, SettingSpelling spelling);
// The setting spelled `text` that way; nullptr when none is.
const BuildSetting* find_build_setting(std::string_view text, SettingSpelling spelling);
// Every setting spelled that way, ", "-separated, for the error naming an unknown one.
std::string known_settings(SettingSpelling spelling);
// "'termination_rays' (--termination-rays, row key 'trays')": a setting in every spelling, for errors
// that any front end may show.
std::string describe_setting(const BuildSetting& setting);
// The help line with the settings it names spelled as `spelling` spells them.
std::string setting_help(const BuildSetting& setting, SettingSpelling spelling);

// Text (a flag's or a row key's value) as the setting's type reads it. Throws Error naming `as_written`
// (the setting as the user spelled it) and the text when it is not a value of that type.
SettingValue parse_setting(const BuildSetting& setting, std::string_view text, std::string_view as_written);
// Writes the value into the recipe. Throws Error naming the setting for a value of another type or
// beyond the type's bounds (a whole number over 2^32 - 1); the range is validate()'s to check.
void set_setting(TreeRecipe& recipe, const BuildSetting& setting, const SettingValue& value);
SettingValue get_setting(const TreeRecipe& recipe, const BuildSetting& setting);
// As parse_setting reads it back: "1.3", "inf", "32", "1" / "0", "object+grid", bytes as a number.
std::string format_setting(const SettingValue& value);
// TreeRecipe{}'s value as text, or "the builder's" for a builder_default setting.
std::string default_text(const BuildSetting& setting);

}  // namespace spacebvh
