// SPDX-License-Identifier: MIT
// Images: the CLI's shaded view and traversal-cost heat map through a tracer, and PNG output.
#include <algorithm>

#include "bindings.hpp"
#include "spacebvh/tools/render.hpp"

namespace spacebvh::python {

using namespace spacebvh::tools;

namespace {

// An Image as a (height, width, 3) uint8 array (row 0 at the top).
py::array_t<uint8_t> image_as_array(const Image& image) {
    py::array_t<uint8_t> out({py::ssize_t(image.height), py::ssize_t(image.width), py::ssize_t(3)});
    std::copy(image.rgb.begin(), image.rgb.end(), out.mutable_data());
    return out;
}

// The shaded view (heatmap=False) or the traversal-cost heat map of the primary rays, as the CLI's
// `render`; the heat map also returns its scale and totals.
py::object render(const PyTracer& self, uint32_t width, uint32_t height, const std::string& camera, bool heatmap,
                  const std::string& quantity, double percentile, double scale_max, bool legend) {
    const Camera view = camera_in_frame(self.scene, camera);
    HeatmapOptions options;
    options.quantity = parse_heatmap_quantity(quantity);
    options.percentile = percentile;
    options.scale_max = scale_max;
    options.legend = legend;
    validate(options);  // also for a shaded view: bad heat-map options are refused whatever is drawn
    Image image;
    HeatmapInfo info;
    const Scene& scene = *self.scene.scene;
    without_gil(self.threads, [&] {
        image = heatmap ? render_heatmap(scene, *self.tracer, view, width, height, &info, options)
                        : render_shaded(scene, *self.tracer, view, width, height);
    });
    if (!heatmap) return image_as_array(image);
    py::dict details;
    details["scale_max"] = info.scale_max;
    details["max_value"] = info.max_value;
    details["mean_value"] = info.mean_value;
    details["nodes_visited"] = info.totals.nodes_visited;
    details["triangles_tested"] = info.totals.triangles_tested;
    details["legend_height"] = info.legend_height;
    return py::make_tuple(image_as_array(image), details);
}

}  // namespace

void bind_render(py::module_& m, py::class_<PyTracer>& tracer) {
    tracer.def("render", &render, py::arg("width") = 512u, py::arg("height") = 512u, py::arg("camera") = "",
               py::kw_only(), py::arg("heatmap") = false, py::arg("quantity") = "work", py::arg("percentile") = 0.99,
               py::arg("scale_max") = 0.0, py::arg("legend") = true,
               "The CLI's render through this tracer, with primary_rays()'s camera: a (height, width, 3) uint8 shaded "
               "image; with heatmap=True the per-pixel traversal cost (quantity: work, nodes or triangles; the ramp's "
               "top at the percentile, or at scale_max > 0 to share a scale; legend rows appended below) and a dict of "
               "its scale and totals.");
    m.def(
        "write_png",
        [](const std::string& path, const py::array_t<uint8_t, py::array::c_style | py::array::forcecast>& pixels) {
            if (pixels.ndim() != 3 || pixels.shape(2) != 3 || pixels.shape(0) == 0 || pixels.shape(1) == 0)
                throw Error("write_png needs a (height, width, 3) uint8 array");
            Image image(uint32_t(pixels.shape(1)), uint32_t(pixels.shape(0)));
            std::copy(pixels.data(), pixels.data() + image.rgb.size(), image.rgb.begin());
            py::gil_scoped_release unlocked;
            write_png(path, image);
        },
        py::arg("path"), py::arg("pixels"), "Writes a (height, width, 3) uint8 array, e.g. render()'s, as a PNG file.");
}

}  // namespace spacebvh::python
