// SPDX-License-Identifier: MIT
// WideTracer: the collapsed layout plus the single-ray kernels of the chosen node test.
#include "spacebvh/wide_tracer.hpp"

#include <cmath>
#include <variant>

#include "spacebvh/error.hpp"
#include "spacebvh/packet_tracer.hpp"
#include "trace/kernels.hpp"
#include "trace/traversal_common.hpp"
#include "trace/wide_layout.hpp"

namespace spacebvh {

const char* to_string(NodeTest test) {
    switch (test) {
        case NodeTest::best: return "best";
        case NodeTest::scalar: return "scalar";
        case NodeTest::sse: return "sse";
        case NodeTest::avx2: return "avx2";
        case NodeTest::avx512: return "avx512";
    }
    return "?";
}

const char* to_string(WideCollapse collapse) {
    return collapse == WideCollapse::sah_optimal ? "sah" : "area";
}

std::string collapse_suffix(WideCollapse collapse) {
    return collapse == WideCollapse::sah_optimal ? "" : std::string("@") + to_string(collapse);
}

std::vector<NodeTest> supported_node_tests(int width) {
    std::vector<NodeTest> tests;
    for (NodeTest test : {NodeTest::scalar, NodeTest::sse, NodeTest::avx2, NodeTest::avx512})
        if (trace::width_has(width, test) && trace::cpu_has(test)) tests.push_back(test);
    return tests;
}

struct WideTracer::Impl {
    int width;
    NodeTest test;
    WideCollapse collapse;
    std::variant<trace::WideLayout<4>, trace::WideLayout<8>> layout;
    trace::SingleRayKernels kernels;

    const void* layout_data() const {
        return width == 4 ? static_cast<const void*>(&std::get<0>(layout)) : static_cast<const void*>(&std::get<1>(layout));
    }
};

WideTracer::WideTracer(const Scene& scene, const Bvh& bvh, int width, NodeTest test, WideCollapse collapse) {
    if (width != 4 && width != 8) throw Error("wide BVH width must be 4 or 8, got " + std::to_string(width));
    if (test == NodeTest::best) test = supported_node_tests(width).back();
    if (!trace::width_has(width, test))
        throw Error(std::string("node test '") + to_string(test) + "' does not exist for width " + std::to_string(width));
    if (!trace::cpu_has(test)) throw Error(std::string("this CPU lacks the instructions of node test '") + to_string(test) + "'");
    impl_ = std::make_unique<Impl>();
    impl_->width = width;
    impl_->test = test;
    impl_->collapse = collapse;
    if (width == 4)
        impl_->layout.emplace<0>(trace::collapse_to_wide<4>(scene, bvh, collapse));
    else
        impl_->layout.emplace<1>(trace::collapse_to_wide<8>(scene, bvh, collapse));
    impl_->kernels = trace::single_ray_kernels(width, test);
}

WideTracer::~WideTracer() = default;
WideTracer::WideTracer(WideTracer&&) noexcept = default;
WideTracer& WideTracer::operator=(WideTracer&&) noexcept = default;

Hit WideTracer::intersect(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    impl_->kernels.closest(impl_->layout_data(), ray, hit);
    return hit;
}

Hit WideTracer::intersect(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    impl_->kernels.closest_stats(impl_->layout_data(), ray, hit, &stats);
    return hit;
}

bool WideTracer::occluded(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return impl_->kernels.occluded(impl_->layout_data(), ray, unused);
}

bool WideTracer::occluded(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return impl_->kernels.occluded_stats(impl_->layout_data(), ray, unused, &stats);
}

void WideTracer::intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats) const {
    const void* layout = impl_->layout_data();
    const trace::SingleRayKernels& kernels = impl_->kernels;
    trace::intersect_batch(rays, hits, stats, [&](const Ray& ray, Hit& hit, TraversalStats* s) {
        return s ? kernels.closest_stats(layout, ray, hit, s) : kernels.closest(layout, ray, hit);
    });
}

void WideTracer::occluded(std::span<const Ray> rays, std::span<uint8_t> result, TraversalStats* stats) const {
    const void* layout = impl_->layout_data();
    const trace::SingleRayKernels& kernels = impl_->kernels;
    trace::occluded_batch(rays, result, stats, [&](const Ray& ray, Hit& hit, TraversalStats* s) {
        return s ? kernels.occluded_stats(layout, ray, hit, s) : kernels.occluded(layout, ray, hit);
    });
}

size_t WideTracer::memory_bytes() const {
    return std::visit([](const auto& layout) {
        return layout.nodes.size() * sizeof(layout.nodes[0]) + layout.packs.size() * sizeof(trace::TrianglePack);
    }, impl_->layout);
}

size_t WideTracer::node_count() const {
    return std::visit([](const auto& layout) { return layout.nodes.size(); }, impl_->layout);
}

std::string WideTracer::name() const {
    return "bvh" + std::to_string(impl_->width) + "-" + to_string(impl_->test) + collapse_suffix(impl_->collapse);
}
int WideTracer::width() const { return impl_->width; }
NodeTest WideTracer::node_test() const { return impl_->test; }

std::unique_ptr<Tracer> make_tracer(const std::string& name, const Scene& scene, const Bvh& bvh) {
    // A wide kernel may end in "@area": Embree's collapse instead of the SAH-optimal one.
    std::string kernel = name;
    WideCollapse collapse = WideCollapse::sah_optimal;
    if (const size_t at = kernel.find('@'); at != std::string::npos) {
        const std::string suffix = kernel.substr(at + 1);
        kernel.resize(at);
        if (suffix == "area" && kernel != "binary") {
            collapse = WideCollapse::largest_area;
        } else if (suffix != "sah" || kernel == "binary") {
            throw Error("unknown kernel '" + name + "': only wide kernels take a collapse, @sah or @area");
        }
    }
    if (kernel == "binary") return std::make_unique<BinaryTracer>(scene, bvh);
    // The fastest single-ray kernel on the benchmark scenes (bench/): 8 wide with the widest node test.
    if (kernel == "auto") return std::make_unique<WideTracer>(scene, bvh, 8, NodeTest::best, collapse);
    for (int width : {4, 8}) {
        const std::string prefix = "bvh" + std::to_string(width);
        if (kernel == prefix) return std::make_unique<WideTracer>(scene, bvh, width, NodeTest::best, collapse);
        for (NodeTest test : {NodeTest::scalar, NodeTest::sse, NodeTest::avx2, NodeTest::avx512})
            if (kernel == prefix + "-" + to_string(test)) return std::make_unique<WideTracer>(scene, bvh, width, test, collapse);
    }
    for (uint32_t tile : {8u, 16u}) {
        const std::string prefix = "packet" + std::to_string(tile);
        if (kernel == prefix) return std::make_unique<PacketTracer>(scene, bvh, tile * tile, NodeTest::best, collapse);
        for (NodeTest test : {NodeTest::scalar, NodeTest::avx2, NodeTest::avx512})
            if (kernel == prefix + "-" + to_string(test))
                return std::make_unique<PacketTracer>(scene, bvh, tile * tile, test, collapse);
    }
    std::string known;
    for (const std::string& known_name : kernel_names()) known += " " + known_name;
    throw Error("unknown kernel '" + name + "'; kernels on this CPU:" + known + " (wide ones also NAME@area)");
}

std::vector<std::string> kernel_names() {
    std::vector<std::string> names{"auto", "binary"};
    for (int width : {4, 8}) {
        names.push_back("bvh" + std::to_string(width));
        for (NodeTest test : supported_node_tests(width)) names.push_back("bvh" + std::to_string(width) + "-" + to_string(test));
    }
    for (uint32_t tile : {8u, 16u}) {
        names.push_back("packet" + std::to_string(tile));
        for (NodeTest test : supported_node_tests(8)) names.push_back("packet" + std::to_string(tile) + "-" + to_string(test));
    }
    return names;
}

}  // namespace spacebvh
