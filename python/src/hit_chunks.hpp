// SPDX-License-Identifier: MIT
// Every crossing of a batch of rays, gathered so that the bindings write their NumPy arrays (CSR
// form: ray i's hits at offsets[i] .. offsets[i + 1]) in one pass: the rays are walked in chunks of
// kHitChunk across the calling oneTBB arena, each chunk keeping only the record its caller needs per
// hit (compact records move less memory than whole QueryHits), then every chunk writes its disjoint
// range of the output. The order is by ray and then by (t, primitive), as RayQueries::all_hits
// gives it, whatever the thread count.
#pragma once
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "spacebvh/queries.hpp"

namespace spacebvh::python {

inline constexpr size_t kHitChunk = 256;

template <class Record>
struct ChunkedHits {
    std::vector<uint64_t> offsets;            // rays + 1 entries: ray i's records are [offsets[i], offsets[i + 1])
    std::vector<std::vector<Record>> chunks;  // chunk c: the records of rays [c * kHitChunk, (c + 1) * kHitChunk)

    uint64_t size() const { return offsets.back(); }

    // Calls write(k, ray, record) for every record, k its index in ray order, chunks across the calling
    // arena (call without the GIL; each k is written once).
    template <class Write>
    void for_each(Write&& write) const {
        const size_t rays = offsets.size() - 1;
        tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks.size(), 1),
                          [&](const tbb::blocked_range<size_t>& range) {
                              for (size_t c = range.begin(); c != range.end(); ++c) {
                                  const uint64_t base = offsets[c * kHitChunk];
                                  const size_t end = std::min(rays, (c + 1) * kHitChunk);
                                  for (size_t ray = c * kHitChunk; ray < end; ++ray)
                                      for (uint64_t k = offsets[ray]; k < offsets[ray + 1]; ++k)
                                          write(k, ray, chunks[c][k - base]);
                              }
                          });
    }
};

// The crossings of `rays` (at most max_hits each, the nearest), make(hit) kept for each. Call without
// the GIL, in the arena that should do the work.
template <class Record, class Make>
ChunkedHits<Record> collect_chunked_hits(const RayQueries& queries, std::span<const Ray> rays, size_t max_hits,
                                         Make&& make) {
    const size_t n = rays.size(), chunk_count = (n + kHitChunk - 1) / kHitChunk;
    ChunkedHits<Record> result;
    result.offsets.assign(n + 1, 0);
    result.chunks.resize(chunk_count);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunk_count, 1), [&](const tbb::blocked_range<size_t>& range) {
        std::vector<QueryHit> scratch;
        for (size_t c = range.begin(); c != range.end(); ++c) {
            std::vector<Record>& records = result.chunks[c];
            const size_t end = std::min(n, (c + 1) * kHitChunk);
            for (size_t i = c * kHitChunk; i < end; ++i) {
                queries.all_hits(rays[i], scratch, max_hits);
                result.offsets[i + 1] = scratch.size();
                for (const QueryHit& hit : scratch) records.push_back(make(hit));
            }
        }
    });
    for (size_t i = 0; i < n; ++i) result.offsets[i + 1] += result.offsets[i];
    return result;
}

}  // namespace spacebvh::python
