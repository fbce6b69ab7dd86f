// SPDX-License-Identifier: MIT
// What a command reports about its own run: times, their median, peak memory, and its JSON file.
#pragma once

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace spacebvh::cli {

// The peak resident set of this process so far (getrusage ru_maxrss), in bytes.
size_t peak_rss_bytes();

double milliseconds_since(std::chrono::steady_clock::time_point start);
double median(std::vector<double> values);
// Writes `json` to `path` (nothing when the path is empty); throws Error when it cannot.
void write_json(const std::string& path, const nlohmann::json& json);

}  // namespace spacebvh::cli
