// SPDX-License-Identifier: MIT
// The table `compare` prints per scene and the JSON it writes per row.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "compare_rows.hpp"

namespace spacebvh::cli::compare {

// "12.34 (1.05x)": a value and its ratio to a reference (no ratio when the reference is not positive).
std::string ratio_text(double value, double reference, int precision);
// The value in fixed notation, or "-" when there is none.
std::string number_or_dash(std::optional<double> value, int precision);

// Prints the rows as a markdown table (Mrays/s as ratios to the first row), then every row's layout
// bytes per triangle. `verified`: the rows' wrong counts were checked; `with_epo`: EPO was computed.
void print_table(const std::vector<Row>& rows, bool verified, bool with_epo);
// One row as the JSON `compare --json` writes (docs/cli.md).
nlohmann::json row_json(const Row& row, bool verified, bool with_epo);

}  // namespace spacebvh::cli::compare
