// SPDX-License-Identifier: MIT
// spacebvh: build, inspect, trace and compare BVHs built by space subdivision.
#include <cstdio>
#include <exception>
#include <string>

#include "cli_common.hpp"
#include "spacebvh/error.hpp"

int main(int argc, char** argv) {
    CLI::App app{
        "spacebvh: BVHs by space subdivision (Popov et al. 2009) - build, trace, measure, compare with Embree"};
    app.require_subcommand(1);
    app.set_help_all_flag("--help-all", "help for every subcommand");
    spacebvh::cli::add_info_command(app);
    spacebvh::cli::add_build_command(app);
    spacebvh::cli::add_rays_command(app);
    spacebvh::cli::add_trace_command(app);
    spacebvh::cli::add_render_command(app);
    spacebvh::cli::add_compare_command(app);
    spacebvh::cli::add_optimum_command(app);
    // CLI11 would only say "A subcommand is required": name the word it did not know.
    if (argc > 1 && argv[1][0] != '-') {
        bool known = false;
        std::string names;
        for (const CLI::App* command : app.get_subcommands({})) {
            known = known || command->get_name() == argv[1];
            names += (names.empty() ? "" : ", ") + command->get_name();
        }
        if (!known) {
            std::fprintf(stderr, "spacebvh: error: unknown command '%s' (commands: %s; see --help)\n", argv[1],
                         names.c_str());
            return 2;
        }
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version exit 0; every usage error exits 2 (CLI11's own codes are 100+).
        const int status = app.exit(e);
        return status == 0 ? 0 : 2;
    } catch (const spacebvh::Cancelled& e) {
        std::fprintf(stderr, "spacebvh: stopped (%s, Ctrl-C)\n", e.what());
        return 130;  // the shell's code for a command ended by SIGINT
    } catch (const spacebvh::Error& e) {
        std::fprintf(stderr, "spacebvh: error: %s\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "spacebvh: error: out of memory\n");
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "spacebvh: internal error: %s\n", e.what());
        return 3;
    }
    return 0;
}
