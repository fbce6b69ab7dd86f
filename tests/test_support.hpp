// Helpers shared by the test files: our answers as hit-file records, ready for verify_against_reference.
#pragma once

#include <span>
#include <vector>

#include "spacebvh/rays.hpp"
#include "spacebvh/tracer.hpp"

namespace spacebvh::testing_support {

inline std::vector<HitRecord> closest_records(const BinaryTracer& tracer, std::span<const Ray> rays) {
    std::vector<Hit> hits(rays.size());
    tracer.intersect(rays, hits);
    std::vector<HitRecord> records(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) records[i] = to_record(hits[i]);
    return records;
}

inline std::vector<HitRecord> occlusion_records(const BinaryTracer& tracer, std::span<const Ray> rays) {
    std::vector<uint8_t> occluded(rays.size());
    tracer.occluded(rays, occluded);
    std::vector<HitRecord> records(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) records[i] = occlusion_record(occluded[i]);
    return records;
}

}  // namespace spacebvh::testing_support
