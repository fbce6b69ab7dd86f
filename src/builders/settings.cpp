// SPDX-License-Identifier: MIT
// The build settings: looking them up by any spelling, reading their values from text, and reading and
// writing them on a recipe through the table's fields.
#include "spacebvh/settings.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "builders/settings_table.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh {
namespace {

using builders::setting_entries;
using builders::SettingEntry;

const SettingEntry& entry_of(const BuildSetting& setting) {
    for (const SettingEntry& entry : setting_entries())
        if (&entry.setting == &setting || entry.setting.name == setting.name) return entry;
    throw Error("unknown build setting '" + setting.name + "'");
}

// The field's C++ type must be the one the setting's type is stored in.
bool field_fits(const SettingEntry& entry) {
    switch (entry.setting.type) {
        case SettingType::number:
            return std::holds_alternative<builders::FloatField>(entry.field);
        case SettingType::whole:
        case SettingType::search_spaces:
            return std::holds_alternative<builders::UintField>(entry.field);
        case SettingType::flag:
            return std::holds_alternative<builders::FlagField>(entry.field);
        case SettingType::bytes:
            return std::holds_alternative<builders::BytesField>(entry.field);
    }
    return false;
}

std::string number_text(double value) {
    if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
    std::ostringstream text;
    text << value;
    return text.str();
}

float parse_number(std::string_view text, std::string_view what) {
    if (text == "inf" || text == "infinity" || text == "Inf") return kInfinity;
    const std::string copy(text);
    try {
        size_t used = 0;
        const float value = std::stof(copy, &used);
        if (used != copy.size()) throw std::invalid_argument(copy);
        return value;
    } catch (const std::exception&) {
        throw Error(std::string(what) + ": expected a number or 'inf', got '" + copy + "'");
    }
}

uint64_t parse_whole(std::string_view text, std::string_view what) {
    uint32_t value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size())
        throw Error(std::string(what) + ": expected a whole number >= 0 (at most 2^32 - 1), got '" + std::string(text) +
                    "'");
    return value;
}

bool parse_flag(std::string_view text, std::string_view what) {
    if (text == "1" || text == "true" || text == "on") return true;
    if (text == "0" || text == "false" || text == "off") return false;
    throw Error(std::string(what) + ": expected 1 or 0 (on or off), got '" + std::string(text) + "'");
}

uint64_t parse_bytes(std::string_view text, std::string_view what) {
    static constexpr std::string_view kUnits = "KMGT";
    double value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    const std::string_view unit(end, text.data() + text.size());
    const size_t power = unit.empty() ? 0 : unit.size() == 1 ? kUnits.find(char(std::toupper(unit[0]))) + 1 : 0;
    if (ec != std::errc() || !(value >= 0) || (!unit.empty() && power == 0) || !std::isfinite(value))
        throw Error(std::string(what) + ": expected a size in bytes, or with K, M, G or T, got '" + std::string(text) +
                    "'");
    const double bytes = std::ldexp(value, int(10 * power));
    if (bytes >= 0x1p64) throw Error(std::string(what) + ": '" + std::string(text) + "' is more than 2^64 bytes");
    return uint64_t(bytes);
}

}  // namespace

const char* to_string(SettingType type) {
    switch (type) {
        case SettingType::number:
            return "number";
        case SettingType::whole:
            return "whole";
        case SettingType::flag:
            return "flag";
        case SettingType::search_spaces:
            return "search_spaces";
        case SettingType::bytes:
            return "bytes";
    }
    return "?";
}

std::string BuildSetting::range_text() const {
    if (type == SettingType::flag || type == SettingType::search_spaces) return range_note;
    const bool closed_above = !std::isinf(max) || allows_infinity;
    auto bound = [&](double value) {
        return type == SettingType::number || std::isinf(value) ? number_text(value) : std::to_string(uint64_t(value));
    };
    std::string text(min_exclusive ? "(" : "[");
    text += bound(min);
    text += ", ";
    text += type == SettingType::bytes ? std::string("2^64") : bound(max);
    text += closed_above && type != SettingType::bytes ? "]" : ")";
    if (!range_note.empty()) text += "; " + range_note;
    return text;
}

const std::vector<BuildSetting>& build_settings() {
    static const std::vector<BuildSetting> settings = [] {
        std::vector<BuildSetting> list;
        for (const SettingEntry& entry : setting_entries()) {
            // A table error, caught by the first use of the table (every test of the settings).
            if (!field_fits(entry))
                throw std::logic_error("build setting '" + entry.setting.name + "': its field is not of its type");
            list.push_back(entry.setting);
        }
        return list;
    }();
    return settings;
}

const std::string& spelled(const BuildSetting& setting, SettingSpelling spelling) {
    switch (spelling) {
        case SettingSpelling::flag:
            return setting.flag;
        case SettingSpelling::row_key:
            return setting.row_key;
        case SettingSpelling::name:
            break;
    }
    return setting.name;
}

const BuildSetting* find_build_setting(std::string_view text, SettingSpelling spelling) {
    for (const BuildSetting& setting : build_settings())
        if (spelled(setting, spelling) == text) return &setting;
    return nullptr;
}

std::string known_settings(SettingSpelling spelling) {
    std::string list;
    for (const BuildSetting& setting : build_settings())
        list += (list.empty() ? "" : ", ") + spelled(setting, spelling);
    return list;
}

std::string describe_setting(const BuildSetting& setting) {
    return "'" + setting.name + "' (" + setting.flag + ", row key '" + setting.row_key + "')";
}

std::string setting_help(const BuildSetting& setting, SettingSpelling spelling) {
    std::string help;
    size_t at = 0;
    for (size_t open; (open = setting.help.find('{', at)) != std::string::npos;) {
        const size_t close = setting.help.find('}', open);
        if (close == std::string::npos) break;
        const std::string name = setting.help.substr(open + 1, close - open - 1);
        const BuildSetting* named = find_build_setting(name, SettingSpelling::name);
        help += setting.help.substr(at, open - at) + (named ? spelled(*named, spelling) : "{" + name + "}");
        at = close + 1;
    }
    return help + setting.help.substr(at);
}

SettingValue parse_setting(const BuildSetting& setting, std::string_view text, std::string_view as_written) {
    switch (setting.type) {
        case SettingType::number:
            return double(parse_number(text, as_written));
        case SettingType::whole:
            return parse_whole(text, as_written);
        case SettingType::flag:
            return parse_flag(text, as_written);
        case SettingType::bytes:
            return parse_bytes(text, as_written);
        case SettingType::search_spaces:
            break;
    }
    return std::string(text);
}

void set_setting(TreeRecipe& recipe, const BuildSetting& setting, const SettingValue& value) {
    const SettingEntry& entry = entry_of(setting);
    auto wrong_type = [&](const char* expected) {
        return Error("setting " + describe_setting(setting) + ": expected " + expected);
    };
    switch (setting.type) {
        case SettingType::number:
            if (const double* number = std::get_if<double>(&value)) {
                std::get<builders::FloatField>(entry.field)(recipe) = float(*number);
                return;
            }
            throw wrong_type("a number");
        case SettingType::whole:
            if (const uint64_t* whole = std::get_if<uint64_t>(&value)) {
                if (*whole > std::numeric_limits<uint32_t>::max()) throw wrong_type("a whole number below 2^32");
                std::get<builders::UintField>(entry.field)(recipe) = uint32_t(*whole);
                return;
            }
            throw wrong_type("a whole number >= 0");
        case SettingType::flag:
            if (const bool* flag = std::get_if<bool>(&value)) {
                std::get<builders::FlagField>(entry.field)(recipe) = *flag;
                return;
            }
            throw wrong_type("on or off (a bool)");
        case SettingType::bytes:
            if (const uint64_t* bytes = std::get_if<uint64_t>(&value)) {
                std::get<builders::BytesField>(entry.field)(recipe) = *bytes;
                return;
            }
            throw wrong_type("a size in bytes");
        case SettingType::search_spaces:
            if (const std::string* names = std::get_if<std::string>(&value)) {
                std::get<builders::UintField>(entry.field)(recipe) = names->empty() ? 0 : parse_search_spaces(*names);
                return;
            }
            throw wrong_type("search space names (text)");
    }
}

SettingValue get_setting(const TreeRecipe& recipe, const BuildSetting& setting) {
    const SettingEntry& entry = entry_of(setting);
    // The fields are reached through a mutable recipe; reading through them leaves it as it is.
    TreeRecipe& fields = const_cast<TreeRecipe&>(recipe);
    switch (setting.type) {
        case SettingType::number:
            return double(std::get<builders::FloatField>(entry.field)(fields));
        case SettingType::whole:
            return uint64_t(std::get<builders::UintField>(entry.field)(fields));
        case SettingType::flag:
            return std::get<builders::FlagField>(entry.field)(fields);
        case SettingType::bytes:
            return std::get<builders::BytesField>(entry.field)(fields);
        case SettingType::search_spaces:
            break;
    }
    const uint32_t spaces = std::get<builders::UintField>(entry.field)(fields);
    return spaces ? search_space_names(spaces) : std::string();
}

std::string format_setting(const SettingValue& value) {
    if (const bool* flag = std::get_if<bool>(&value)) return *flag ? "1" : "0";
    if (const uint64_t* whole = std::get_if<uint64_t>(&value)) return std::to_string(*whole);
    if (const double* number = std::get_if<double>(&value)) return number_text(*number);
    return std::get<std::string>(value);
}

std::string default_text(const BuildSetting& setting) {
    if (setting.builder_default) return "the builder's";
    return format_setting(get_setting(TreeRecipe{}, setting));
}

}  // namespace spacebvh
