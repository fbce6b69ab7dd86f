#include "build/reference.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace spacebvh::build {

std::vector<Reference> make_references(const Scene& scene) {
    std::vector<Reference> references(scene.triangles.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, references.size(), 4096), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i)
            references[i] = {scene.triangles[i].bounds(), uint32_t(i)};
    });
    return references;
}

static ReferenceSummary summarize_serial(std::span<const Reference> references) {
    ReferenceSummary summary;
    for (const Reference& reference : references) {
        summary.bounds.extend(reference.bounds);
        summary.centroid_bounds.extend(reference.bounds.center());
    }
    return summary;
}

ReferenceSummary summarize(std::span<const Reference> references) {
    constexpr size_t kParallelThreshold = 32 * 1024;
    if (references.size() < kParallelThreshold) return summarize_serial(references);
    return tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, references.size(), 8192), ReferenceSummary{},
        [&](const tbb::blocked_range<size_t>& range, ReferenceSummary summary) {
            ReferenceSummary part = summarize_serial(references.subspan(range.begin(), range.size()));
            summary.bounds.extend(part.bounds);
            summary.centroid_bounds.extend(part.centroid_bounds);
            return summary;
        },
        [](ReferenceSummary a, const ReferenceSummary& b) {
            a.bounds.extend(b.bounds);
            a.centroid_bounds.extend(b.centroid_bounds);
            return a;
        });
}

}  // namespace spacebvh::build
