// SPDX-License-Identifier: MIT
// Tracer: one layout (binary, 4- or 8-wide) and the kernel tables chosen for it. Every kernel is
// reached through the same two tables (single rays, packets), so the tracer has one implementation
// whatever the kernel.
#include "spacebvh/trace.hpp"
#include "trace/tracer_access.hpp"

#include <string>
#include <variant>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "trace/layout/binary_layout.hpp"
#include "trace/kernels/kernels.hpp"
#include "trace/layout/quantized_layout.hpp"
#include "trace/traversal/traversal_common.hpp"
#include "trace/layout/wide_layout.hpp"

namespace spacebvh {

const char* to_string(Kernel kernel) {
    switch (kernel) {
        case Kernel::automatic:
            return "auto";
        case Kernel::binary:
            return "binary";
        case Kernel::bvh4:
            return "bvh4";
        case Kernel::bvh8:
            return "bvh8";
        case Kernel::packet8:
            return "packet8";
        case Kernel::packet16:
            return "packet16";
    }
    return "?";
}

const char* to_string(NodeTest test) {
    switch (test) {
        case NodeTest::best:
            return "best";
        case NodeTest::scalar:
            return "scalar";
        case NodeTest::sse:
            return "sse";
        case NodeTest::avx2:
            return "avx2";
        case NodeTest::avx512:
            return "avx512";
    }
    return "?";
}

const char* to_string(WideCollapse collapse) { return collapse == WideCollapse::sah_optimal ? "sah" : "area"; }

const char* to_string(LeafTest leaf_test) { return leaf_test == LeafTest::moller ? "moller" : "watertight"; }

const char* to_string(NodeFormat format) { return format == NodeFormat::quantized ? "quantized" : "full"; }

std::vector<NodeTest> supported_node_tests(int width) {
    std::vector<NodeTest> tests;
    for (NodeTest test : {NodeTest::scalar, NodeTest::sse, NodeTest::avx2, NodeTest::avx512})
        if (trace::width_has(width, test) && trace::cpu_has(test)) tests.push_back(test);
    return tests;
}

struct Tracer::Impl {
    TracerConfig config;
    uint32_t packet_size = 0;  // 0: single rays; else rays per packet
    std::variant<trace::BinaryLayout, trace::WideLayout<4>, trace::WideLayout<8>, trace::QuantizedLayout8> layout;
    trace::SingleRayKernels single{};
    trace::PacketKernels packets{};

    const void* layout_data() const {
        return std::visit([](const auto& l) { return static_cast<const void*>(&l); }, layout);
    }
};

namespace {

int width_of(Kernel kernel) {
    switch (kernel) {
        case Kernel::binary:
            return 2;
        case Kernel::bvh4:
            return 4;
        default:
            return 8;
    }
}

uint32_t packet_size_of(Kernel kernel) { return kernel == Kernel::packet8 ? 64 : kernel == Kernel::packet16 ? 256 : 0; }

void check_belongs(std::span<const Triangle> triangles, const Bvh& bvh) {
    for (uint32_t primitive : bvh.primitives)
        if (primitive >= triangles.size())
            throw Error("tracer: the tree names triangle " + std::to_string(primitive) + " but the mesh has " +
                        std::to_string(triangles.size()) + " (a tree built over other geometry?)");
}

}  // namespace

Tracer::Tracer(const MeshView& mesh, const Bvh& bvh, Kernel kernel) : Tracer(mesh, bvh, TracerConfig{kernel}) {}

Tracer::Tracer(const MeshView& mesh, const Bvh& bvh, const TracerConfig& requested) : impl_(std::make_unique<Impl>()) {
    TracerConfig config = requested;
    // The fastest single-ray kernel measured on every scene: 8 wide with the widest node test.
    if (config.kernel == Kernel::automatic) config.kernel = Kernel::bvh8;
    const int width = width_of(config.kernel);
    const uint32_t packet_size =
        packet_size_of(config.kernel) && config.packet_size ? config.packet_size : packet_size_of(config.kernel);
    if (packet_size > trace::kMaxPacket || (config.packet_size && !packet_size))
        throw Error("packet size must be in [1, " + std::to_string(trace::kMaxPacket) +
                    "] and only for packet kernels, got " + std::to_string(config.packet_size));
    const TriangleStore store(mesh);
    check_belongs(store.triangles(), bvh);
    if (config.leaf_test != LeafTest::watertight && (width == 2 || packet_size))
        throw Error(std::string("kernel '") + to_string(config.kernel) + "' has no leaf test '" +
                    to_string(config.leaf_test) + "' (bvh4 and bvh8 only)");
    if (config.node_format != NodeFormat::full && (config.kernel != Kernel::bvh8))
        throw Error(std::string("kernel '") + to_string(config.kernel) + "' has no node format '" +
                    to_string(config.node_format) + "' (bvh8 only)");
    if (width == 2) {
        if (config.node_test != NodeTest::best || config.collapse != WideCollapse::sah_optimal)
            throw Error("the binary kernel takes no node test and no collapse");
        impl_->layout.emplace<0>(trace::make_binary_layout(store.triangles(), bvh));
        impl_->single = trace::binary_kernels();
    } else {
        if (config.node_test == NodeTest::best) config.node_test = supported_node_tests(width).back();
        if (!trace::width_has(width, config.node_test) || (packet_size && config.node_test == NodeTest::sse))
            throw Error(std::string("kernel '") + to_string(config.kernel) + "' has no node test '" +
                        to_string(config.node_test) + "'");
        if (!trace::cpu_has(config.node_test))
            throw Error(std::string("this CPU lacks the instructions of node test '") + to_string(config.node_test) +
                        "'");
        const auto add_planes = [&](auto& layout) {
            if (config.leaf_test == LeafTest::moller) layout.planes = trace::make_pack_planes(layout.packs);
            if (!config.keep_refit_map) std::vector<uint32_t>().swap(layout.source);
        };
        if (width == 4) {
            add_planes(impl_->layout.emplace<1>(trace::collapse_to_wide<4>(store.triangles(), bvh, config.collapse)));
        } else if (config.node_format == NodeFormat::quantized) {
            trace::WideLayout<8> wide = trace::collapse_to_wide<8>(store.triangles(), bvh, config.collapse);
            add_planes(wide);
            impl_->layout.emplace<3>(trace::quantize_wide(std::move(wide)));
        } else {
            add_planes(impl_->layout.emplace<2>(trace::collapse_to_wide<8>(store.triangles(), bvh, config.collapse)));
        }
        impl_->single = trace::single_ray_kernels(width, config.node_test, config.leaf_test, config.node_format);
        if (packet_size) impl_->packets = trace::packet_kernels(config.node_test);
    }
    impl_->packet_size = packet_size;
    impl_->config = config;
}

bool Tracer::refit(const MeshView& mesh, const Bvh& bvh) {
    const TriangleStore store(mesh);
    check_belongs(store.triangles(), bvh);
    return TracerInternals::refit_checked(*this, mesh, store.triangles(), bvh);
}

bool TracerInternals::refit_checked(Tracer& tracer, const MeshView& mesh, std::span<const Triangle> triangles,
                                    const Bvh& bvh, bool same_degenerate) {
    Tracer::Impl& impl = *tracer.impl_;
    if (auto* wide4 = std::get_if<trace::WideLayout<4>>(&impl.layout))
        if (trace::refit_wide(*wide4, triangles, bvh, same_degenerate)) return true;
    if (auto* wide8 = std::get_if<trace::WideLayout<8>>(&impl.layout))
        if (trace::refit_wide(*wide8, triangles, bvh, same_degenerate)) return true;
    // Into the same Impl, so the layout keeps its address (TracerInternals::entry stays valid).
    Tracer fresh(mesh, bvh, impl.config);
    impl = std::move(*fresh.impl_);
    return false;
}

void TracerInternals::refit_tree_checked(Tracer& tracer, const MeshView& mesh, std::span<const Triangle> triangles,
                                         Bvh& bvh) {
    Tracer::Impl& impl = *tracer.impl_;
    if (auto* wide4 = std::get_if<trace::WideLayout<4>>(&impl.layout))
        if (trace::refit_tree_and_wide(*wide4, triangles, bvh) == trace::TreeRefit::done) return;
    if (auto* wide8 = std::get_if<trace::WideLayout<8>>(&impl.layout))
        if (trace::refit_tree_and_wide(*wide8, triangles, bvh) == trace::TreeRefit::done) return;
    refit_boxes(bvh, triangles);
    refit_checked(tracer, mesh, triangles, bvh, true);
}

trace::TreeRefit TracerInternals::refit_tree_unchecked(Tracer& tracer, std::span<const Triangle> moved,
                                                       std::span<const Triangle> current, Bvh& bvh) {
    Tracer::Impl& impl = *tracer.impl_;
    if (auto* wide4 = std::get_if<trace::WideLayout<4>>(&impl.layout))
        return trace::refit_tree_and_wide(*wide4, moved, bvh, current);
    if (auto* wide8 = std::get_if<trace::WideLayout<8>>(&impl.layout))
        return trace::refit_tree_and_wide(*wide8, moved, bvh, current);
    return trace::TreeRefit::unsupported;
}

trace::KernelEntry TracerInternals::entry(const Tracer& tracer) {
    const Tracer::Impl& impl = *tracer.impl_;
    return {impl.single.closest, impl.single.occluded, impl.layout_data()};
}

Tracer::~Tracer() = default;
Tracer::Tracer(Tracer&&) noexcept = default;
Tracer& Tracer::operator=(Tracer&&) noexcept = default;

Hit Tracer::intersect(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    impl_->single.closest(impl_->layout_data(), ray, hit);
    return hit;
}

Hit Tracer::intersect(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit hit;
    impl_->single.closest_stats(impl_->layout_data(), ray, hit, &stats);
    return hit;
}

bool Tracer::occluded(const Ray& ray) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return impl_->single.occluded(impl_->layout_data(), ray, unused);
}

bool Tracer::occluded(const Ray& ray, TraversalStats& stats) const {
    const trace::StandardFloatingPointMode mode;
    Hit unused;
    return impl_->single.occluded_stats(impl_->layout_data(), ray, unused, &stats);
}

namespace {
// Runs `trace(first, count, stats)` for every packet of `size` consecutive rays, in parallel. The next
// packet's rays are fetched while one is traced: a packet of cheap rays (primary occlusion) spends
// much of its time waiting for its rays otherwise, as each range starts a new stream.
template <typename Trace>
void for_each_packet(std::span<const Ray> rays, size_t size, TraversalStats* stats, Trace&& trace) {
    const size_t ray_count = rays.size();
    const size_t packets = (ray_count + size - 1) / size;
    trace::for_each_range(packets, 16, stats, [&](size_t begin, size_t end, TraversalStats& local) {
        for (size_t p = begin; p < end; ++p) {
            const size_t next = (p + 1) * size, next_end = std::min(ray_count, next + size);
            for (size_t line = next * sizeof(Ray); line < next_end * sizeof(Ray); line += 64)
                __builtin_prefetch(reinterpret_cast<const char*>(rays.data()) + line);
            trace(p * size, uint32_t(std::min(size, ray_count - p * size)), stats ? &local : nullptr);
        }
    });
}

void check_batch(size_t rays, size_t answers) {
    if (answers < rays)
        throw Error("tracer: " + std::to_string(rays) + " rays but room for " + std::to_string(answers) + " answers");
}
}  // namespace

void Tracer::intersect(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats) const {
    check_batch(rays.size(), hits.size());
    const void* layout = impl_->layout_data();
    if (impl_->packet_size) {
        for_each_packet(rays, impl_->packet_size, stats, [&](size_t first, uint32_t count, TraversalStats* s) {
            impl_->packets.closest(layout, &rays[first], count, &hits[first], s);
        });
        return;
    }
    const trace::SingleRayKernels& kernels = impl_->single;
    trace::intersect_batch(rays, hits, stats, [&](const Ray& ray, Hit& hit, TraversalStats* s) {
        return s ? kernels.closest_stats(layout, ray, hit, s) : kernels.closest(layout, ray, hit);
    });
}

void Tracer::occluded(std::span<const Ray> rays, std::span<uint8_t> result, TraversalStats* stats) const {
    check_batch(rays.size(), result.size());
    const void* layout = impl_->layout_data();
    if (impl_->packet_size) {
        for_each_packet(rays, impl_->packet_size, stats, [&](size_t first, uint32_t count, TraversalStats* s) {
            impl_->packets.occluded(layout, &rays[first], count, &result[first], s);
        });
        return;
    }
    const trace::SingleRayKernels& kernels = impl_->single;
    trace::occluded_batch(rays, result, stats, [&](const Ray& ray, Hit& hit, TraversalStats* s) {
        return s ? kernels.occluded_stats(layout, ray, hit, s) : kernels.occluded(layout, ray, hit);
    });
}

size_t Tracer::memory_bytes() const {
    return std::visit(
        [](const auto& layout) -> size_t {
            using Layout = std::decay_t<decltype(layout)>;
            if constexpr (std::is_same_v<Layout, trace::BinaryLayout>) {
                return layout.buffer.size() * sizeof(layout.buffer[0]);
            } else {
                size_t bytes = layout.nodes.size() * sizeof(layout.nodes[0]) +
                               layout.packs.size() * sizeof(trace::TrianglePack) +
                               layout.planes.size() * sizeof(trace::PackPlanes);
                if constexpr (!std::is_same_v<Layout, trace::QuantizedLayout8>)
                    bytes += (layout.source.size() + layout.lanes.size()) * sizeof(uint32_t);  // the refit maps
                return bytes;
            }
        },
        impl_->layout);
}

size_t Tracer::node_count() const {
    return std::visit(
        [](const auto& layout) -> size_t {
            if constexpr (std::is_same_v<std::decay_t<decltype(layout)>, trace::BinaryLayout>)
                return layout.node_count;
            else
                return layout.nodes.size();
        },
        impl_->layout);
}

std::string Tracer::name() const {
    const TracerConfig& c = impl_->config;
    std::string name = to_string(c.kernel);
    if (c.node_format == NodeFormat::quantized) name += "q";
    if (c.kernel != Kernel::binary) name += std::string("-") + to_string(c.node_test);
    if (impl_->packet_size && impl_->packet_size != packet_size_of(c.kernel))
        name += "-x" + std::to_string(impl_->packet_size);
    if (c.leaf_test != LeafTest::watertight) name += std::string("+") + to_string(c.leaf_test);
    if (c.collapse != WideCollapse::sah_optimal) name += std::string("@") + to_string(c.collapse);
    return name;
}

const TracerConfig& Tracer::config() const { return impl_->config; }

std::vector<uint32_t> tile_order(uint32_t width, uint32_t height, uint32_t tile) {
    if (tile == 0) throw Error("tile size must be at least 1");
    std::vector<uint32_t> order;
    order.reserve(size_t(width) * height);
    for (uint32_t ty = 0; ty < height; ty += tile)
        for (uint32_t tx = 0; tx < width; tx += tile)
            for (uint32_t y = ty; y < std::min(height, ty + tile); ++y)
                for (uint32_t x = tx; x < std::min(width, tx + tile); ++x) order.push_back(y * width + x);
    return order;
}

}  // namespace spacebvh
