// SPDX-License-Identifier: MIT
// The build settings in Python: build()'s keywords are exactly the settings table's names
// (spacebvh/settings.hpp), read into the same recipe the command line makes; spacebvh.Quality;
// build_settings() for discovery.
#include <Python.h>

#include "bindings.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/settings.hpp"

namespace spacebvh::python {
namespace {

[[noreturn]] void wrong_type(const BuildSetting& setting, const char* expected, const py::handle& value) {
    throw py::type_error("build(): " + setting.name + " takes " + expected + ", not " +
                         std::string(py::str(py::type::of(value).attr("__name__"))));
}

// A Python value as the setting's type holds it: the same checks as the text of a flag or row key,
// without going through text (a float keeps every bit a float can hold).
SettingValue from_python(const BuildSetting& setting, const py::handle& value) {
    const bool is_bool = PyBool_Check(value.ptr());
    const bool is_index = !is_bool && PyIndex_Check(value.ptr());  // int, NumPy integers
    switch (setting.type) {
        case SettingType::number:
            if (py::isinstance<py::str>(value) || !PyNumber_Check(value.ptr())) wrong_type(setting, "a number", value);
            return value.cast<double>();
        case SettingType::flag:
            if (!is_bool) wrong_type(setting, "a bool", value);
            return value.cast<bool>();
        case SettingType::search_spaces:
            if (!py::isinstance<py::str>(value)) wrong_type(setting, "search space names (a str)", value);
            return value.cast<std::string>();
        case SettingType::bytes:
            if (py::isinstance<py::str>(value))
                return parse_setting(setting, value.cast<std::string>(), setting.name);  // "8G"
            [[fallthrough]];
        case SettingType::whole:
            break;
    }
    if (!is_index) wrong_type(setting, setting.type == SettingType::bytes ? "an int or a str" : "an int", value);
    const py::int_ number = py::reinterpret_steal<py::int_>(PyNumber_Index(value.ptr()));
    if (number < py::int_(0)) throw Error(setting.name + " must be >= 0, got " + std::string(py::str(number)));
    try {
        return number.cast<uint64_t>();
    } catch (const py::cast_error&) {
        throw Error(setting.name + " is more than 2^64 - 1: " + std::string(py::str(number)));
    }
}

std::string settings_list() {
    std::string list;
    for (const BuildSetting& setting : build_settings()) {
        list += "\n    " + setting.name + " (" + to_string(setting.type) + ", default " + default_text(setting);
        const std::string range = setting.range_text();
        list += (range.empty() ? "" : "; " + range) + "): " + setting_help(setting, SettingSpelling::name);
    }
    return list;
}

}  // namespace

TreeRecipe recipe_from(const std::optional<std::string>& builder, const py::object& quality,
                       const py::kwargs& settings) {
    if (builder && !quality.is_none()) throw Error("build(): give a builder or a quality, not both");
    TreeRecipe recipe;
    if (quality.is_none())
        recipe = TreeRecipe::for_builder(builder.value_or("binned"));
    else if (py::isinstance<py::str>(quality))
        recipe = TreeRecipe::for_quality(parse_quality(quality.cast<std::string>()));
    else
        recipe = TreeRecipe::for_quality(quality.cast<Quality>());
    for (const auto& [key, value] : settings) {
        const std::string name = py::str(key);
        const BuildSetting* setting = find_build_setting(name, SettingSpelling::name);
        if (!setting)
            throw py::type_error("build() got an unexpected keyword argument '" + name + "'; the build settings are: " +
                                 known_settings(SettingSpelling::name) + " (spacebvh.build_settings())");
        if (value.is_none()) continue;  // None: the default
        set_setting(recipe, *setting, from_python(*setting, value));
    }
    recipe.validate();
    return recipe;
}

py::dict settings_of(const TreeRecipe& recipe) {
    py::dict values;
    for (const BuildSetting& setting : build_settings()) values[py::str(setting.name)] = get_setting(recipe, setting);
    return values;
}

const std::string& build_doc() {
    static const std::string doc =
        "build(scene, builder=None, *, quality=None, threads=0, **settings) -> Bvh\n\n"
        "Builds a tree over the scene: with a builder of builders() (default 'binned'; 'NAME+opt' adds the "
        "reinsertion optimisation) or a quality level (Quality or 'fast', 'balanced', 'high'), and any of the build "
        "settings as keywords (build_settings(); each as the command line's flag of docs/cli.md; None = the "
        "default). Releases the GIL and uses `threads` threads (0 = every core); the tree is the same whatever "
        "`threads`. The settings:" +
        settings_list();
    return doc;
}

void bind_settings(py::module_& m) {
    py::enum_<Quality>(
        m, "Quality",
        "What most users pick: fast (binned object SAH, the quickest build), balanced (space subdivision "
        "at close to a classical build's time), high (the lowest-cost trees, then reinsertion).")
        .value("fast", Quality::fast)
        .value("balanced", Quality::balanced)
        .value("high", Quality::high)
        // pybind11's own name and value say nothing of what they hold.
        .def_property_readonly(
            "name", [](Quality quality) { return to_string(quality); },
            "The level's name: 'fast', 'balanced' or 'high'.")
        .def_property_readonly(
            "value", [](Quality quality) { return int(quality); }, "The level's number: 0 fast, 1 balanced, 2 high.");

    m.def(
        "build_settings",
        [] {
            py::list list;
            for (const BuildSetting& setting : build_settings()) {
                py::dict entry;
                entry["name"] = setting.name;
                entry["type"] = to_string(setting.type);
                entry["default"] =
                    setting.builder_default ? py::object(py::none()) : py::cast(get_setting(TreeRecipe{}, setting));
                entry["range"] = setting.range_text();
                entry["help"] = setting_help(setting, SettingSpelling::name);
                entry["flag"] = setting.flag;
                entry["row_key"] = setting.row_key;
                entry["example"] = setting.example;
                list.append(entry);
            }
            return list;
        },
        "The keywords build() takes, each a dict: name, type (number, whole, flag, search_spaces, bytes), default "
        "(None: the builder's own), range, help, and its command-line flag, compare row key and an example value.");
}

}  // namespace spacebvh::python
