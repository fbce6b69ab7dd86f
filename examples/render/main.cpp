// SPDX-License-Identifier: MIT
// render_example [SCENE] [OUT.png]: one primary ray per pixel through the scene's default camera,
// shaded by |cos| between the ray and the triangle's normal (black where nothing is hit).
#include <spacebvh/spacebvh.hpp>
#include <spacebvh/tools/rays.hpp>
#include <spacebvh/tools/render.hpp>
#include <spacebvh/tools/scene.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    const std::string source = argc > 1 ? argv[1] : "builtin:interior";
    const std::string output = argc > 2 ? argv[2] : "render.png";
    try {
        const spacebvh::tools::Scene scene = spacebvh::tools::load_scene(source);
        const spacebvh::Bvh bvh = spacebvh::build(scene, spacebvh::Quality::balanced);
        const spacebvh::Tracer tracer(scene, bvh);

        const uint32_t width = 640, height = 480;
        const std::vector<spacebvh::Ray> rays =
            spacebvh::tools::generate_primary_rays(spacebvh::tools::default_camera(scene), width, height);
        std::vector<spacebvh::Hit> hits(rays.size());
        tracer.intersect(rays, hits);  // all cores

        spacebvh::tools::Image image(width, height);
        for (size_t i = 0; i < rays.size(); ++i) {
            if (!hits[i].is_hit()) continue;
            const spacebvh::Vec3 n = spacebvh::normalize(scene.triangles[hits[i].primitive].geometric_normal());
            const float shade = std::fabs(spacebvh::dot(n, spacebvh::normalize(rays[i].dir)));
            const uint8_t grey = uint8_t(40 + 215 * shade);
            image.set_pixel(uint32_t(i % width), uint32_t(i / width), {grey, grey, grey});
        }
        spacebvh::tools::write_png(output, image);
        std::printf("%s: %zu triangles, %zu tree nodes -> %s\n", scene.name.c_str(), scene.triangles.size(),
                    bvh.nodes.size(), output.c_str());
    } catch (const spacebvh::Error& error) {
        std::fprintf(stderr, "render_example: %s\n", error.what());
        return 1;
    }
}
