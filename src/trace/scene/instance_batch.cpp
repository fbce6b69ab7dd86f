// SPDX-License-Identifier: MIT
// RenderScene::attach_instances: many instances at once, their transforms checked and inverted across
// the calling thread's oneTBB arena, then attached in order; nothing is attached when one is bad.
#include <algorithm>
#include <atomic>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "spacebvh/error.hpp"
#include "trace/scene/scene_impl.hpp"

namespace spacebvh {

uint32_t RenderScene::attach_instances(std::span<const std::shared_ptr<const RenderScene>> scenes,
                                       std::span<const InstancePlacement> placements) {
    Impl& s = *impl_;
    s.check_unshared("attach instances");
    const std::string batch = "scene '" + s.name + "': attach_instances";
    const size_t first = s.geometries.size(), n = placements.size();
    if (first + n >= kInvalidIndex)
        throw Error(batch + ": out of geometry ids (" + std::to_string(first) + " used, " + std::to_string(n) +
                    " more asked)");
    for (size_t k = 0; k < scenes.size(); ++k)
        s.check_child(*this, scenes[k].get(), [&] { return batch + ": scenes[" + std::to_string(k) + "]"; });
    const auto make = [&](const InstancePlacement& p) {
        const Impl& c = *scenes[p.scene]->impl_;
        return scene::make_instance_transform(p.transform, c.bounds, c.root_padding, std::string());
    };
    // The lowest bad placement is made again alone to throw its error, so the error does not depend
    // on the thread count.
    std::vector<scene::InstanceTransform> xf(n);
    std::atomic<size_t> first_bad{n};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            try {
                if (placements[i].scene >= scenes.size()) throw Error("scene index out of range");
                xf[i] = make(placements[i]);
            } catch (const Error&) {
                size_t seen = first_bad.load();
                while (i < seen && !first_bad.compare_exchange_weak(seen, i)) {}
                return;  // the rest of this block comes after i
            }
        }
    });
    if (const size_t i = first_bad; i < n) {
        const std::string what =
            batch + ": placements[" + std::to_string(i) + "] (would be geometry " + std::to_string(first + i) + ")";
        if (placements[i].scene >= scenes.size())
            throw Error(what + ": scene index " + std::to_string(placements[i].scene) + ", but " +
                        std::to_string(scenes.size()) + " scene(s) given");
        try {
            (void)make(placements[i]);
        } catch (const Error& e) {
            throw Error(what + e.what());  // its messages start with ": "
        }
    }
    if (s.geometries.capacity() < first + n) s.geometries.reserve(std::max(first + n, 2 * s.geometries.capacity()));
    for (size_t i = 0; i < n; ++i)
        s.add_instance(scenes[placements[i].scene], placements[i].transform, xf[i], placements[i].mask);
    return uint32_t(first);
}

}  // namespace spacebvh
