// SPDX-License-Identifier: MIT
#include "run_report.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <fstream>

#include "spacebvh/error.hpp"

namespace spacebvh::cli {

size_t peak_rss_bytes() {
    struct rusage usage {};
    if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
    return size_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

double milliseconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

double median(std::vector<double> values) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    const size_t n = values.size();
    return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

void write_json(const std::string& path, const nlohmann::json& json) {
    if (path.empty()) return;
    std::ofstream out(path);
    if (!out) throw Error("cannot write JSON file '" + path + "'");
    out << json.dump(2) << '\n';
    if (!out) throw Error("error writing JSON file '" + path + "'");
}

}  // namespace spacebvh::cli
