// SPDX-License-Identifier: MIT
// The build settings table (spacebvh/settings.hpp) and recipes (spacebvh/recipe.hpp): every setting
// reaches the command line's flags, the compare rows' keys and the docs of every front end (Python's
// keywords: python/tests/test_settings.py); each writes a field of its own; the ranges in the table
// are the ones validate() enforces; and every recipe resolves to the tree its builder makes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <sstream>

#include "builder_spec.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/settings.hpp"
#include "spacebvh/tools/make_tree.hpp"
#include "spacebvh/tools/sample_rays.hpp"
#include "spacebvh/tree_file.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using namespace spacebvh::testing_support;

namespace {

// Every recipe of these tests starts from here: termination rays on, so that the settings that need
// them (termination_optimize) are valid alone.
TreeRecipe base_recipe() {
    TreeRecipe recipe = TreeRecipe::for_builder("spatial");
    recipe.termination_rays = 100;
    return recipe;
}

TreeRecipe with_example(const BuildSetting& setting) {
    TreeRecipe recipe = base_recipe();
    set_setting(recipe, setting, parse_setting(setting, setting.example, setting.name));
    return recipe;
}

// The settings whose values differ between two recipes.
std::vector<std::string> differing(const TreeRecipe& a, const TreeRecipe& b) {
    std::vector<std::string> names;
    for (const BuildSetting& setting : build_settings())
        if (get_setting(a, setting) != get_setting(b, setting)) names.push_back(setting.name);
    return names;
}

bool valid(const TreeRecipe& recipe) {
    try {
        recipe.validate();
        return true;
    } catch (const Error&) {
        return false;
    }
}

std::string read_doc(const std::string& name) {
    std::ifstream file(std::filesystem::path(SPACEBVH_TEST_DATA_DIR) / ".." / ".." / "docs" / name);
    return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

}  // namespace

TEST(Settings, SpellingsAreUniqueAndWellFormed) {
    for (SettingSpelling spelling : {SettingSpelling::name, SettingSpelling::flag, SettingSpelling::row_key}) {
        std::set<std::string> seen;
        for (const BuildSetting& setting : build_settings())
            EXPECT_TRUE(seen.insert(spelled(setting, spelling)).second) << spelled(setting, spelling);
    }
    for (const BuildSetting& setting : build_settings()) {
        EXPECT_TRUE(std::regex_match(setting.name, std::regex("[a-z][a-z_]*[a-z]"))) << setting.name;
        EXPECT_TRUE(std::regex_match(setting.flag, std::regex("--[a-z][a-z-]*[a-z]"))) << setting.flag;
        EXPECT_TRUE(std::regex_match(setting.row_key, std::regex("[a-z][a-z0-9]*"))) << setting.row_key;
        EXPECT_FALSE(setting.help.empty()) << setting.name;
        // Every setting the help names is one of the table's.
        EXPECT_EQ(setting_help(setting, SettingSpelling::name).find('{'), std::string::npos) << setting.help;
        EXPECT_EQ(find_build_setting(setting.row_key, SettingSpelling::row_key), &setting);
    }
    EXPECT_EQ(find_build_setting("no_such_setting", SettingSpelling::name), nullptr);
}

// Each setting's example is valid, differs from the default, and changes that setting alone: no two
// settings share a field, and none is written where another is read.
TEST(Settings, EachSettingWritesAFieldOfItsOwn) {
    const TreeRecipe base = base_recipe();
    ASSERT_TRUE(valid(base));
    for (const BuildSetting& setting : build_settings()) {
        const TreeRecipe changed = with_example(setting);
        EXPECT_EQ(differing(changed, base), std::vector<std::string>{setting.name}) << setting.name;
        EXPECT_TRUE(valid(changed)) << setting.name << " = " << setting.example;
        EXPECT_EQ(format_setting(get_setting(changed, setting)),
                  format_setting(parse_setting(setting, setting.example, setting.name)))
            << setting.name;
    }
}

// The table's ranges, tried at and beyond their ends, are the ones validate() enforces.
TEST(Settings, RangesAreTheOnesValidateEnforces) {
    for (const BuildSetting& setting : build_settings()) {
        if (setting.type == SettingType::flag || setting.type == SettingType::search_spaces) continue;
        auto valid_at = [&](double value) {
            TreeRecipe recipe = base_recipe();
            SettingValue typed = value;
            if (setting.type != SettingType::number) typed = uint64_t(value);
            set_setting(recipe, setting, typed);
            return valid(recipe);
        };
        const bool numbers = setting.type == SettingType::number;
        if (setting.min_exclusive) {
            EXPECT_FALSE(valid_at(setting.min)) << setting.name;
            EXPECT_TRUE(valid_at(setting.min + 0.01)) << setting.name;
        } else {
            EXPECT_TRUE(valid_at(setting.min)) << setting.name;
            if (setting.range_note.empty() && (numbers || setting.min > 0)) {
                EXPECT_FALSE(valid_at(numbers ? setting.min - 0.5 : setting.min - 1)) << setting.name;
            }
        }
        if (setting.type == SettingType::bytes || setting.max == double(UINT32_MAX)) continue;  // the type's own end
        if (std::isinf(setting.max)) {
            EXPECT_EQ(valid_at(setting.max), setting.allows_infinity) << setting.name;
        } else {
            EXPECT_TRUE(valid_at(setting.max)) << setting.name;
            EXPECT_FALSE(valid_at(numbers ? setting.max + 0.5 : setting.max + 1)) << setting.name;
        }
        if (numbers) {
            EXPECT_FALSE(valid_at(std::nan(""))) << setting.name;
        }
    }
}

// The option groups of build, trace, render, compare and optimum: one option per setting, and no
// option that is not a setting (besides the builder, the quality level in its place and --optimize,
// NAME+opt's flag).
TEST(Settings, CliOptionsAreExactlyTheSettings) {
    CLI::App app;
    cli::BuildCliOptions options;
    options.add_to(app);
    for (const BuildSetting& setting : build_settings())
        EXPECT_NE(app.get_option_no_throw(setting.flag), nullptr) << setting.flag;
    for (const CLI::Option* option : app.get_options()) {
        const std::string name = "--" + option->get_lnames().front();
        if (name == "--help" || name == "--builder" || name == "--quality" || name == "--optimize") continue;
        EXPECT_NE(find_build_setting(name, SettingSpelling::flag), nullptr) << name << " is no build setting";
    }
}

// Each flag with its example, parsed by the command line, gives the recipe that setting the example does.
TEST(Settings, CliFlagsSetTheirSetting) {
    for (const BuildSetting& setting : build_settings()) {
        CLI::App app;
        cli::BuildCliOptions options;
        options.add_to(app);
        std::vector<std::string> args = {setting.flag};
        if (setting.type != SettingType::flag) args.push_back(setting.example);
        if (setting.name != "termination_rays") args.insert(args.end(), {"--termination-rays", "100"});
        std::reverse(args.begin(), args.end());  // CLI11 reads a vector from its back
        app.parse(args);
        const TreeRecipe parsed = options.options("spatial");
        EXPECT_EQ(differing(parsed, with_example(setting)), std::vector<std::string>{}) << setting.flag;
        EXPECT_NE(get_setting(parsed, setting), get_setting(base_recipe(), setting)) << setting.flag;
    }
}

// Each row key with its example gives the recipe that setting the example does; an unknown key is an
// error listing the known ones.
TEST(Settings, CompareRowKeysSetTheirSetting) {
    for (const BuildSetting& setting : build_settings()) {
        const cli::BuilderSpec spec =
            cli::parse_builder_spec("spatial@trays=100;" + setting.row_key + "=" + setting.example, {});
        EXPECT_EQ(differing(spec.options, with_example(setting)), std::vector<std::string>{}) << setting.row_key;
    }
    try {
        (void)cli::parse_builder_spec("spatial@overlap=2", {});
        FAIL() << "an unknown row key was accepted";
    } catch (const Error& error) {
        for (const BuildSetting& setting : build_settings())
            EXPECT_NE(std::string(error.what()).find(setting.row_key), std::string::npos) << setting.row_key;
    }
}

// The reference of every front end lists every setting: docs/cli.md its flag and row key,
// docs/python.md its name (python/tests/test_settings.py checks the other way round).
TEST(Settings, DocsListEverySetting) {
    const std::string cli_doc = read_doc("cli.md"), python_doc = read_doc("python.md");
    ASSERT_FALSE(cli_doc.empty());
    ASSERT_FALSE(python_doc.empty());
    for (const BuildSetting& setting : build_settings()) {
        EXPECT_NE(cli_doc.find("`" + setting.flag), std::string::npos) << setting.flag << " in docs/cli.md";
        EXPECT_NE(cli_doc.find("`" + setting.row_key + "`"), std::string::npos) << setting.row_key << " in docs/cli.md";
        EXPECT_NE(python_doc.find("`" + setting.name + "`"), std::string::npos) << setting.name << " in docs/python.md";
    }
}

TEST(Settings, TextValuesAndTheirErrors) {
    const BuildSetting& penalty = *find_build_setting("overlap_penalty", SettingSpelling::name);
    EXPECT_EQ(std::get<double>(parse_setting(penalty, "inf", "co")), double(kInfinity));
    EXPECT_THROW((void)parse_setting(penalty, "abc", "co"), Error);
    const BuildSetting& memory = *find_build_setting("memory_limit", SettingSpelling::name);
    EXPECT_EQ(std::get<uint64_t>(parse_setting(memory, "1.5K", "memory")), 1536u);
    EXPECT_EQ(std::get<uint64_t>(parse_setting(memory, "0", "memory")), 0u);
    const BuildSetting& leaf = *find_build_setting("max_leaf_size", SettingSpelling::name);
    for (const char* bad : {"-1", "4x", "", "4294967296"}) {
        try {
            (void)parse_setting(leaf, bad, "--max-leaf");
            FAIL() << bad;
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("--max-leaf"), std::string::npos) << error.what();
        }
    }
    TreeRecipe recipe;
    EXPECT_THROW(set_setting(recipe, leaf, 2.0), Error);  // a number for a whole number
    EXPECT_THROW(set_setting(recipe, leaf, uint64_t(1) << 32), Error);
    const BuildSetting& search = *find_build_setting("search", SettingSpelling::name);
    set_setting(recipe, search, std::string("object,grid"));
    EXPECT_EQ(std::get<std::string>(get_setting(recipe, search)), "object+grid");
    set_setting(recipe, search, std::string());
    EXPECT_EQ(recipe.search_spaces, 0u);  // the builder's own
    EXPECT_EQ(default_text(search), "the builder's");
    EXPECT_EQ(default_text(leaf), std::to_string(LimitConfig{}.max_leaf_size));
    EXPECT_EQ(leaf.range_text(), "[1, 1048576]");
}

TEST(Settings, RecipesOfNamesAndQualities) {
    EXPECT_EQ(TreeRecipe::for_builder("cbvh").preset, Preset::cbvh);
    const TreeRecipe optimized = TreeRecipe::for_builder("binned+opt");
    EXPECT_EQ(optimized.builder, "binned");
    EXPECT_EQ(optimized.reinsertion.iterations, kDefaultReinsertionIterations);
    const TreeRecipe embree = TreeRecipe::for_builder("embree-high+opt");
    EXPECT_TRUE(embree.is_embree_tree());
    EXPECT_EQ(embree.preset, Preset::binned);
    EXPECT_EQ(embree.reinsertion.iterations, kDefaultReinsertionIterations);
    try {
        (void)TreeRecipe::for_builder("nope");
        FAIL();
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("embree-high"), std::string::npos) << error.what();
    }
    for (Quality quality : {Quality::fast, Quality::balanced, Quality::high}) {
        const TreeRecipe recipe = TreeRecipe::for_quality(quality);
        const BuildConfig config = BuildConfig::for_quality(quality);
        EXPECT_EQ(recipe.builder, to_string(config.preset));
        EXPECT_EQ(recipe.search_spaces, config.search_spaces);
        EXPECT_EQ(recipe.reinsertion.iterations, config.reinsertion.iterations);
        EXPECT_EQ(parse_quality(to_string(quality)), quality);
    }
    EXPECT_THROW((void)parse_quality("medium"), Error);
    // A builder name and the configuration of another preset is an error, not a mislabelled tree.
    TreeRecipe mislabelled;
    mislabelled.builder = "spatial";
    EXPECT_THROW(mislabelled.validate(), Error);
}

// Embree's trees refuse the settings they cannot honour; termination_optimize needs the rays.
TEST(Settings, RecipeChecksNameTheSetting) {
    for (const BuildSetting& setting : build_settings()) {
        if (!setting.ours_only) continue;
        TreeRecipe recipe = TreeRecipe::for_builder("embree-high");
        set_setting(recipe, setting, parse_setting(setting, setting.example, setting.name));
        try {
            recipe.validate();
            FAIL() << setting.name;
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find(setting.flag), std::string::npos) << error.what();
        }
    }
    TreeRecipe recipe = TreeRecipe::for_builder("spatial");
    recipe.termination.reinsertion_iterations = 4;
    EXPECT_THROW(recipe.validate(), Error);
    recipe.termination_rays = 10;
    EXPECT_NO_THROW(recipe.validate());
}

// The core resolves the recipes of our builders and tree files as build() and load_bvh do, and sends
// the others to the tools.
TEST(Settings, CoreBuildOfARecipe) {
    const Scene scene = soup_prefix(3000);
    TreeRecipe recipe = TreeRecipe::for_builder("spatial");
    recipe.cost.overlap_penalty = 2;
    const Bvh built = spacebvh::build(scene, recipe);
    EXPECT_EQ(first_difference(built, spacebvh::build(scene, static_cast<const BuildConfig&>(recipe))), "");
    EXPECT_EQ(first_difference(built, tools::make_tree(scene, recipe)), "");
    const std::string path = (std::filesystem::temp_directory_path() / "spacebvh_settings_test.sbvh").string();
    save_bvh(path, built, scene.triangles, "test");
    EXPECT_EQ(first_difference(spacebvh::build(scene, TreeRecipe::from_file(path)), built), "");
    EXPECT_EQ(first_difference(tools::make_tree(scene, TreeRecipe::from_file(path)), built), "");
    std::filesystem::remove(path);
    EXPECT_THROW((void)spacebvh::build(scene, TreeRecipe::for_builder("embree-medium")), Error);
    recipe.termination_rays = 10;
    EXPECT_THROW((void)spacebvh::build(scene, recipe), Error);
}

// The termination-aware build of a recipe: the segments of termination_rays bounce rays, traced on a
// quick binned tree, then the build with them; with the split choice off, the build, then the
// termination-aware reinsertion with segments traced on the built tree.
TEST(Settings, TerminationRecipesInTheTools) {
    const Scene scene = soup_prefix(3000);
    TreeRecipe recipe = TreeRecipe::for_builder("spatial");
    recipe.termination_rays = 2000;
    const Bvh made = tools::make_tree(scene, recipe);
    BuildConfig by_hand = recipe;
    const Tracer quick(scene, spacebvh::build(scene, Quality::fast));
    const std::vector<Ray> segments = tools::termination_segments(scene, quick, 2000, 0x7E55A11);
    by_hand.termination.segments = segments;
    EXPECT_EQ(first_difference(made, spacebvh::build(scene, by_hand)), "");
    EXPECT_NE(first_difference(made, spacebvh::build(scene, TreeRecipe::for_builder("spatial"))), "");

    recipe.termination.split_choice = false;
    recipe.termination.reinsertion_iterations = 4;
    EXPECT_EQ(tools::make_tree(scene, recipe).builder, "spatial+topt");
}
