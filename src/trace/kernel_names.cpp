// SPDX-License-Identifier: MIT
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh {
namespace {

constexpr NodeTest kNodeTests[] = {NodeTest::scalar, NodeTest::sse, NodeTest::avx2, NodeTest::avx512};
constexpr Kernel kWideKernels[] = {Kernel::bvh4, Kernel::bvh8, Kernel::packet8, Kernel::packet16};

int width_of(Kernel kernel) { return kernel == Kernel::bvh4 ? 4 : 8; }

}  // namespace

TracerConfig parse_kernel(const std::string& name) {
    // A wide kernel may end in "@area": Embree's collapse instead of the SAH-optimal one; a bvh4 or
    // bvh8 kernel's name may end (before the @) in "+moller": the moller leaf test; "bvh8q" is bvh8 over
    // quantized nodes.
    std::string kernel = name;
    TracerConfig config;
    if (kernel.rfind("bvh8q", 0) == 0) {
        config.node_format = NodeFormat::quantized;
        kernel.erase(4, 1);
    }
    bool collapse_given = false;
    if (const size_t at = kernel.find('@'); at != std::string::npos) {
        const std::string suffix = kernel.substr(at + 1);
        kernel.resize(at);
        if (suffix == "area")
            config.collapse = WideCollapse::largest_area;
        else if (suffix != "sah")
            throw Error("unknown kernel '" + name + "': a wide kernel takes a collapse, @sah or @area");
        collapse_given = true;
    }
    if (const size_t plus = kernel.find('+'); plus != std::string::npos) {
        const std::string suffix = kernel.substr(plus + 1);
        kernel.resize(plus);
        if (suffix != "moller" || !(kernel.rfind("bvh4", 0) == 0 || kernel.rfind("bvh8", 0) == 0) ||
            kernel.find("scalar") != std::string::npos)
            throw Error("unknown kernel '" + name +
                        "': only bvh4 and bvh8 kernels (not -scalar) take a leaf test, +moller");
        config.leaf_test = LeafTest::moller;
    }
    if (kernel == "binary" && !collapse_given) return TracerConfig{Kernel::binary};
    if (kernel == "auto") return TracerConfig{Kernel::automatic, NodeTest::best, config.collapse, 0, config.leaf_test};
    for (Kernel wide : kWideKernels) {
        const std::string prefix = to_string(wide);
        config.kernel = wide;
        if (config.node_format == NodeFormat::quantized && wide != Kernel::bvh8) continue;
        if (kernel == prefix) return config;
        for (NodeTest test : kNodeTests) {
            config.node_test = test;
            if (kernel == prefix + "-" + to_string(test)) return config;
        }
        config.node_test = NodeTest::best;
    }
    std::string known;
    for (const std::string& known_name : kernel_names()) known += " " + known_name;
    throw Error("unknown kernel '" + name + "'; kernels on this CPU:" + known + " (wide ones also NAME@area)");
}

std::vector<std::string> kernel_names() {
    std::vector<std::string> names{"auto", "binary"};
    for (Kernel wide : kWideKernels) {
        const std::string prefix = to_string(wide);
        names.push_back(prefix);
        for (NodeTest test : supported_node_tests(width_of(wide)))
            if (!((wide == Kernel::packet8 || wide == Kernel::packet16) && test == NodeTest::sse))
                names.push_back(prefix + "-" + to_string(test));
    }
    for (Kernel wide : {Kernel::bvh4, Kernel::bvh8}) {
        const std::string prefix = to_string(wide);
        names.push_back(prefix + "+moller");
        for (NodeTest test : supported_node_tests(width_of(wide)))
            if (test != NodeTest::scalar) names.push_back(prefix + "-" + to_string(test) + "+moller");
    }
    // bvh8 over quantized nodes, with either leaf test.
    names.push_back("bvh8q");
    for (NodeTest test : supported_node_tests(8)) names.push_back(std::string("bvh8q-") + to_string(test));
    names.push_back("bvh8q+moller");
    for (NodeTest test : supported_node_tests(8))
        if (test != NodeTest::scalar) names.push_back(std::string("bvh8q-") + to_string(test) + "+moller");
    return names;
}

std::unique_ptr<Tracer> make_tracer(const std::string& kernel, const MeshView& mesh, const Bvh& bvh) {
    return std::make_unique<Tracer>(mesh, bvh, parse_kernel(kernel));
}

}  // namespace spacebvh
