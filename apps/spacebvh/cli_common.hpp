// SPDX-License-Identifier: MIT
// What every subcommand uses: the shared option groups, progress and Ctrl-C, and the run's own report.
#pragma once

#include "commands.hpp"
#include "options.hpp"
#include "progress.hpp"
#include "run_report.hpp"
