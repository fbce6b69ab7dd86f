// SPDX-License-Identifier: MIT
#include "options.hpp"

#include <tbb/info.h>

#include <variant>

#include "progress.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/settings.hpp"
#include "spacebvh/tools/make_tree.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

void SceneOptions::add_to(CLI::App& command) {
    command.add_option("--rotate", rotate, "rotate every vertex at load time, degrees: x:45,y:45,z:45 (R = Rz*Ry*Rx)");
    command.add_option("--scale", scale, "uniform scale applied after the rotation");
    command.add_option("--translate", translate, "translation applied last: X Y Z")->expected(3);
}

SceneTransform SceneOptions::transform() const {
    SceneTransform transform;
    if (!rotate.empty()) transform.rotate_degrees = SceneTransform::parse_rotation(rotate);
    transform.scale = scale;
    if (translate.size() == 3) transform.translate = {translate[0], translate[1], translate[2]};
    if (const char* reason = transform.invalid_reason()) throw Error("--" + std::string(reason));
    return transform;
}

void BuildCliOptions::add_to(CLI::App& command, bool with_builder) {
    if (with_builder) {
        CLI::Option* builder_option =
            command.add_option("--builder,-b", builder, "builder: " + builder_list())->capture_default_str();
        std::string levels;
        for (const auto& name : quality_names()) levels += (levels.empty() ? "" : ", ") + name;
        command
            .add_option("--quality", quality,
                        "a quality level in place of a builder, build time against tree quality: " + levels)
            ->check(CLI::IsMember(quality_names()))
            ->excludes(builder_option);
    }
    const std::vector<BuildSetting>& settings = build_settings();
    values.assign(settings.size(), std::string());  // sized once: the options keep pointers into it
    given.assign(settings.size(), nullptr);
    for (size_t i = 0; i < settings.size(); ++i) {
        const BuildSetting& setting = settings[i];
        std::string help = setting_help(setting, SettingSpelling::flag);
        if (setting.builder_default)
            help = help.ends_with(')') ? help.substr(0, help.size() - 1) + "; default: the builder's own)"
                                       : help + " (default: the builder's own)";
        if (setting.type == SettingType::flag) {
            // The option turns the setting from its default.
            const bool on_by_default = std::get<bool>(get_setting(TreeRecipe{}, setting));
            const std::string flag_help = (on_by_default ? "turn off: " : "turn on: ") + help;
            given[i] = command.add_flag(setting.flag, flag_help);
            continue;
        }
        CLI::Option* option = command.add_option(setting.flag, values[i], help);
        option->type_name(setting.type == SettingType::number  ? "FLOAT"
                          : setting.type == SettingType::whole ? "UINT"
                                                               : "TEXT");
        if (!setting.builder_default) option->default_str(default_text(setting));
        given[i] = option;
    }
    command.add_flag("--optimize", optimize,
                     "reinsertion optimisation after the build with the default effort (" +
                         std::to_string(kDefaultReinsertionIterations) +
                         " iterations; --optimize-iterations sets another); also as a builder name suffix: binned+opt");
}

TreeRecipe BuildCliOptions::options(const std::string& builder_name) const {
    TreeRecipe recipe =
        quality.empty() ? TreeRecipe::for_builder(builder_name) : TreeRecipe::for_quality(parse_quality(quality));
    if (optimize) recipe.reinsertion.iterations = kDefaultReinsertionIterations;
    const std::vector<BuildSetting>& settings = build_settings();
    for (size_t i = 0; i < given.size(); ++i) {
        if (!given[i] || given[i]->count() == 0) continue;
        const BuildSetting& setting = settings[i];
        if (setting.type == SettingType::flag)
            set_setting(recipe, setting, !std::get<bool>(get_setting(TreeRecipe{}, setting)));
        else
            set_setting(recipe, setting, parse_setting(setting, values[i], setting.flag));
    }
    recipe.hooks.cancel = interrupt_flag();
    recipe.validate();
    return recipe;
}

void CommonOptions::add_to(CLI::App& command) {
    command.add_option("--threads,-j", threads, "worker threads (0 = all cores)")->capture_default_str();
    command.add_flag("--quiet,-q", quiet, "no progress bar");
    command.add_flag("--progress", progress,
                     "show progress even when stderr is not a terminal (a line every few seconds)");
    command.add_option("--json", json_path, "also write the results as JSON to this file");
}

std::unique_ptr<tbb::global_control> CommonOptions::thread_limit() const {
    if (threads > 4096) throw Error("--threads must be at most 4096");
    if (threads == 0) return nullptr;
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

unsigned CommonOptions::effective_threads() const {
    return threads ? threads : unsigned(tbb::info::default_concurrency());
}

void add_manifest_option(CLI::App& command, std::string& manifest) {
    command
        .add_option("--manifest", manifest,
                    "a scene collection's MANIFEST.md: the camera its table lists for the "
                    "scene file's stem is the default camera")
        ->envname("SPACEBVH_SCENE_MANIFEST");
}

void CameraOptions::add_to(CLI::App& command) {
    command.add_option("--camera", camera,
                       "eye, target, up, fovy: ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy "
                       "(default: the --manifest camera, else the spec's default)");
    add_manifest_option(command, manifest);
    command.add_option("--width", width, "image width in pixels")->capture_default_str();
    command.add_option("--height", height, "image height in pixels")->capture_default_str();
}

Camera CameraOptions::camera_for(const Scene& scene, const std::string& source, const SceneTransform& transform) const {
    if (width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide)
        throw Error("--width and --height must be in [1, " + std::to_string(kMaxImageSide) + "]");
    if (!camera.empty()) return Camera::parse(camera);
    return camera_for_scene(scene, source, transform, manifest);
}

Bvh build_tree(const Scene& scene, const TreeRecipe& recipe) {
    const InterruptScope interrupts;  // our builders poll the flag; Embree's finish, then we stop
    Bvh bvh = tools::make_tree(scene, recipe);
    throw_if_interrupted();
    return bvh;
}

std::string builder_list() {
    std::string names;
    for (const auto& name : builder_names()) names += name + ", ";
    for (const auto& name : embree_tree_names()) names += name + ", ";
    names.resize(names.size() - 2);
    return names + " (Embree 3's own binary trees under our kernel)";
}

std::string kernel_help() {
    std::string help = "traversal kernel:";
    for (const std::string& name : kernel_names()) help += " " + name;
    return help +
           " (auto: bvh8 with the widest node test); wide kernels collapse the binary tree SAH-optimally, NAME@area as "
           "Embree does (open the largest child)";
}

}  // namespace spacebvh::cli
