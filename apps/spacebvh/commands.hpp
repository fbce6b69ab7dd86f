// SPDX-License-Identifier: MIT
// The subcommands of `spacebvh`, each added to the app by its own file (command_NAME.cpp).
#pragma once

#include <CLI/CLI.hpp>

namespace spacebvh::cli {

void add_info_command(CLI::App& app);
void add_build_command(CLI::App& app);
void add_rays_command(CLI::App& app);
void add_trace_command(CLI::App& app);
void add_render_command(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_optimum_command(CLI::App& app);

}  // namespace spacebvh::cli
