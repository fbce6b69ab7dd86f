// SPDX-License-Identifier: MIT
#include "compare_table.hpp"

#include <cstdio>
#include <sstream>

namespace spacebvh::cli::compare {

std::string ratio_text(double value, double reference, int precision) {
    std::ostringstream text;
    text.setf(std::ios::fixed);
    text.precision(precision);
    text << value;
    if (reference > 0) {
        text.precision(2);
        text << " (" << value / reference << "x)";
    }
    return text.str();
}

std::string number_or_dash(std::optional<double> value, int precision) {
    if (!value) return "-";
    std::ostringstream text;
    text.setf(std::ios::fixed);
    text.precision(precision);
    text << *value;
    return text.str();
}

void print_table(const std::vector<Row>& rows, bool verified, bool with_epo) {
    std::printf("| builder | kernel | build ms | nodes | refs | SAH | EPO |");
    for (RayKind kind : kKinds)
        std::printf(" %s Mrays/s | %s occl. Mrays/s | %s boxes/ray (occl.) |", to_string(kind), to_string(kind),
                    to_string(kind));
    std::printf(" wrong |\n|---|---|---:|---:|---:|---:|---:|");
    for (int i = 0; i < 3; ++i) std::printf("---:|---:|---:|");
    std::printf("---:|\n");
    if (rows.empty()) return;
    const Row& base = rows.front();
    for (const Row& row : rows) {
        const bool ours = row.stats.has_value();
        std::printf("| %s | %s | %s | %s | %s | %s | %s |", row.name.c_str(), row.kernel.c_str(),
                    ratio_text(row.build_ms, base.build_ms, 1).c_str(),
                    ours ? std::to_string(row.stats->nodes).c_str() : "-",
                    ours ? std::to_string(row.stats->references).c_str() : "-",
                    number_or_dash(ours ? std::optional(row.stats->sah) : std::nullopt, 2).c_str(),
                    number_or_dash(ours && with_epo ? std::optional(row.stats->epo) : std::nullopt, 2).c_str());
        size_t wrong = 0;
        for (RayKind kind : kKinds) {
            const KindResult& k = row.kinds[int(kind)];
            const KindResult& bk = base.kinds[int(kind)];
            const std::string boxes = k.nodes_per_ray < 0 ? "-"
                                                          : number_or_dash(k.nodes_per_ray, 1) + " (" +
                                                                number_or_dash(k.occlusion_nodes_per_ray, 1) + ")";
            std::printf(" %s | %s | %s |", ratio_text(k.closest_mrays, bk.closest_mrays, 2).c_str(),
                        ratio_text(k.occlusion_mrays, bk.occlusion_mrays, 2).c_str(), boxes.c_str());
            wrong += k.wrong;
        }
        std::printf(" %s |\n", verified ? std::to_string(wrong).c_str() : "-");
    }
    std::printf("\nlayout B/tri (nodes + leaf triangles; Embree: its commit's allocations):");
    for (const Row& row : rows)
        if (row.layout_bytes_per_triangle >= 0)
            std::printf(" %s %s %.1f;", row.name.c_str(),
                        row.kernels[0].empty() ? row.kernel.c_str() : row.kernels[0].c_str(),
                        row.layout_bytes_per_triangle);
    std::printf("\n");
}

nlohmann::json row_json(const Row& row, bool verified, bool with_epo) {
    const bool ours = row.stats.has_value();
    nlohmann::json json = {{"builder", row.name},
                           {"kernel", row.kernel},
                           {"build_ms", row.build_ms},
                           {"build_ms_runs", row.build_ms_runs},
                           {"peak_rss_bytes", row.peak_rss_bytes}};
    if (row.cost) json["cost"] = row.cost->describe();
    // Ours: the layout's exact size; Embree's: what its allocators reserved, which varies with the
    // thread count, hence another name (not part of a run's deterministic result).
    if (row.layout_bytes_per_triangle >= 0)
        json[row.cost ? "layout_bytes_per_triangle" : "allocated_bytes_per_triangle"] = row.layout_bytes_per_triangle;
    if (ours) {
        json["nodes"] = row.stats->nodes;
        json["references"] = row.stats->references;
        json["sah"] = row.stats->sah;
        if (with_epo) json["epo"] = row.stats->epo;
        json["bytes"] = row.stats->bytes;
        json["max_depth"] = row.stats->max_depth;
    }
    for (RayKind kind : kKinds) {
        const KindResult& k = row.kinds[int(kind)];
        nlohmann::json json_kind = {{"closest_mrays", k.closest_mrays},
                                    {"occlusion_mrays", k.occlusion_mrays},
                                    {"closest_ms_runs", k.closest_ms},
                                    {"occlusion_ms_runs", k.occlusion_ms}};
        if (!row.kernels[int(kind)].empty()) json_kind["kernel"] = row.kernels[int(kind)];
        if (k.nodes_per_ray >= 0) {
            json_kind["nodes_per_ray"] = k.nodes_per_ray;
            json_kind["triangles_per_ray"] = k.triangles_per_ray;
            json_kind["occlusion_nodes_per_ray"] = k.occlusion_nodes_per_ray;
            json_kind["occlusion_triangles_per_ray"] = k.occlusion_triangles_per_ray;
        }
        if (verified) json_kind["wrong"] = k.wrong;
        json[to_string(kind)] = json_kind;
    }
    return json;
}

}  // namespace spacebvh::cli::compare
