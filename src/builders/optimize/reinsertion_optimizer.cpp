// SPDX-License-Identifier: MIT
#include "builders/optimize/reinsertion_optimizer.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <deque>
#include <numeric>
#include <optional>
#include <vector>

#include "builders/optimize/reinsertion_state.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::builders {

using reinsertion::kBatchFraction;
using reinsertion::kGainWindow;
using reinsertion::kMinimumGain;
using reinsertion::kNone;
using reinsertion::Move;
using reinsertion::Optimizer;
using reinsertion::SearchScratch;

ReinsertionReport optimize_by_reinsertion(Bvh& bvh, const ReinsertionOptions& options) {
    ReinsertionReport report;
    // C_T = 0: inner nodes cost nothing, so no move changes the SAH.
    if (options.iterations == 0 || bvh.nodes.size() < 5 || bvh.cost.traversal_cost == 0.0f) return report;
    auto check_cancel = [&] {
        if (options.cancel && options.cancel->load(std::memory_order_relaxed)) throw Cancelled("build cancelled");
    };
    Optimizer optimizer(bvh, options.max_depth, options.segments, options.area_prior);
    report.inner_area_before = optimizer.inner_price();
    optimizer.refit_all();
    report.inner_area_refitted = optimizer.inner_price();
    const size_t batch = std::max<size_t>(1, size_t(kBatchFraction * double(bvh.nodes.size())));
    tbb::enumerable_thread_specific<SearchScratch> scratches;
    std::vector<Move> moves;
    std::deque<double> recent_gains;  // of the last kGainWindow iterations
    for (uint32_t iteration = 0; iteration < options.iterations; ++iteration) {
        check_cancel();
        optimizer.compute_depths();
        const std::vector<uint32_t> candidates = optimizer.select_candidates(batch);
        if (candidates.empty()) break;  // every node was searched since anything near it last changed
        moves.assign(candidates.size(), Move{});
        // Searches read the tree only; each writes its own slot, so the order of work does not matter.
        tbb::parallel_for(tbb::blocked_range<size_t>(0, candidates.size(), 16),
                          [&](const tbb::blocked_range<size_t>& range) {
                              auto& scratch = scratches.local();
                              for (size_t i = range.begin(); i != range.end(); ++i) {
                                  check_cancel();
                                  moves[i] = optimizer.find_best_move(candidates[i], scratch);
                              }
                          });
        for (size_t i = 0; i < candidates.size(); ++i)
            if (moves[i].destination == kNone) optimizer.settle(candidates[i]);
        std::erase_if(moves, [](const Move& move) { return move.destination == kNone; });
        std::sort(moves.begin(), moves.end(), [](const Move& a, const Move& b) {
            return a.gain > b.gain || (a.gain == b.gain && a.node < b.node);
        });
        double gain_of_iteration = 0.0;
        for (const Move& move : moves) {
            const std::optional<double> gain = optimizer.price_move(move.node, move.destination);
            if (!gain || *gain <= optimizer.minimum_gain()) continue;  // earlier moves changed its surroundings
            optimizer.apply(move.node, move.destination);
            gain_of_iteration += *gain;
            ++report.moves;
        }
        report.iterations = iteration + 1;
        report.applied_gain += gain_of_iteration;
        if (options.progress) options.progress(double(iteration + 1) / double(options.iterations));
        recent_gains.push_back(gain_of_iteration);
        if (recent_gains.size() > kGainWindow) recent_gains.pop_front();
        const double recent_gain = std::accumulate(recent_gains.begin(), recent_gains.end(), 0.0);
        if (recent_gains.size() == kGainWindow && recent_gain <= kMinimumGain * optimizer.inner_price()) break;
    }
    report.inner_area_after = optimizer.inner_price();
    bvh = optimizer.emit(bvh);
    return report;
}

}  // namespace spacebvh::builders
