// SPDX-License-Identifier: MIT
#include "spacebvh/split_optimum.hpp"

#include <vector>

#include "builders/driver/reference.hpp"
#include "builders/search_spaces/exhaustive_split.hpp"
#include "builders/search_spaces/search_spaces.hpp"

namespace spacebvh {
namespace {

std::vector<builders::Reference> references_of(std::span<const Triangle> triangles) {
    std::vector<builders::Reference> references;
    references.reserve(triangles.size());
    for (uint32_t i = 0; i < triangles.size(); ++i) references.push_back({triangles[i].bounds(), i});
    return references;
}

}  // namespace

static_assert(kMaxExhaustiveTriangles == builders::kMaxExhaustiveReferences);

float exhaustive_split_cost(std::span<const Triangle> triangles, const CostModel& cost) {
    const std::vector<builders::Reference> references = references_of(triangles);
    const builders::ReferenceSummary summary = builders::summarize(references);
    return builders::exhaustive_split(references, summary.bounds, cost).cost;
}

float best_local_split_cost(std::span<const Triangle> triangles, uint32_t search_spaces, const BuildConfig& config) {
    const std::vector<builders::Reference> references = references_of(triangles);
    const builders::ReferenceSummary summary = builders::summarize(references);
    const auto finders = builders::make_search_spaces(search_spaces, triangles, config, false, 0.0f);
    builders::Split best;
    for (const auto& finder : finders) {
        // Splitting search spaces get room for every reference to be clipped once.
        const builders::NodeContext context{references, summary, 2 * references.size(), summary.bounds.area(), best};
        const builders::Split split = finder->find(context, config.cost);
        if (split.cost < best.cost) best = split;
    }
    return best.cost;
}

}  // namespace spacebvh
