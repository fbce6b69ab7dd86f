// SPDX-License-Identifier: MIT
// Ray sets of docs/rays.md ("Random numbers", "Ray kinds"), reproduced bit for bit.
//
// This file is compiled with -ffp-contract=off (see CMakeLists.txt): no fused multiply-add, so every
// product and sum below is rounded to float32 exactly as the spec writes it, left to right. The
// vector helpers are private to this file on purpose: the inline ones of geometry.hpp may be
// instantiated in (and linked from) other translation units that do contract to FMA.
#include <algorithm>
#include <cmath>
#include <string>

#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"

namespace spacebvh::tools {

namespace {

// Float32 vector arithmetic in the spec's evaluation order.
Vec3 add(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 sub(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 scale(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
float dot3(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 cross3(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
// normalize(v) = v / |v|, |v| = sqrt(x*x + y*y + z*z), one division per component.
Vec3 normalize3(Vec3 a) {
    float len = std::sqrt(dot3(a, a));
    return {a.x / len, a.y / len, a.z / len};
}

}  // namespace

// ---- splitmix64 (Steele, Lea & Flood 2014), exactly as the spec -------------------------------

uint64_t SplitMix64::next() {
    state_ += 0x9E3779B97F4A7C15ull;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

float SplitMix64::uniform() {
    // The top 24 bits convert to float exactly; the scale by 2^-24 is exact too.
    return float(next() >> 40) * 0x1.0p-24f;
}

void SplitMix64::disk(float& a, float& b, float& s) {
    do {
        a = 2.0f * uniform() - 1.0f;
        b = 2.0f * uniform() - 1.0f;
        s = a * a + b * b;
    } while (!(s < 1.0f));
}

// ---- kinds -------------------------------------------------------------------------------------

RayKind parse_ray_kind(const std::string& text) {
    if (text == "random") return RayKind::random;
    if (text == "primary") return RayKind::primary;
    if (text == "diffuse") return RayKind::diffuse;
    throw Error("unknown ray kind '" + text + "' (expected random, primary or diffuse)");
}

const char* to_string(RayKind kind) {
    switch (kind) {
        case RayKind::random:
            return "random";
        case RayKind::primary:
            return "primary";
        case RayKind::diffuse:
            return "diffuse";
    }
    return "unknown";
}

// Spec "random": origin uniform in the scene box, direction uniform on the sphere (Marsaglia 1972).
std::vector<Ray> generate_random_rays(const AABB& scene_bounds, size_t count, uint64_t seed) {
    if (scene_bounds.is_empty()) throw Error("random rays: the scene bounds are empty");
    const Vec3 lo = scene_bounds.lo;
    const Vec3 ext = sub(scene_bounds.hi, scene_bounds.lo);
    SplitMix64 rng(seed);
    std::vector<Ray> rays;
    rays.reserve(count);
    for (size_t i = 0; i < count; ++i) {
        const float u0 = rng.uniform();
        const float u1 = rng.uniform();
        const float u2 = rng.uniform();
        Ray ray;
        ray.org = {lo.x + u0 * ext.x, lo.y + u1 * ext.y, lo.z + u2 * ext.z};
        float a, b, s;
        do {
            rng.disk(a, b, s);
        } while (s == 0.0f);  // the spec redraws s == 0 (it would give the pole twice as often)
        const float f = 2.0f * std::sqrt(1.0f - s);
        ray.dir = {a * f, b * f, 1.0f - 2.0f * s};
        ray.tmin = 0.0f;
        ray.tmax = kInfinity;
        rays.push_back(ray);
    }
    return rays;
}

// Spec "primary": a pinhole camera, pixel (x, y) has index y*W + x, row 0 at the top.
std::vector<Ray> generate_primary_rays(const Camera& camera, uint32_t width, uint32_t height) {
    if (width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide)
        throw Error("primary rays: image size must be between 1 and " + std::to_string(kMaxImageSide) +
                    " on each side, got " + std::to_string(width) + " x " + std::to_string(height));
    if (!(camera.fovy_degrees > 0.0f && camera.fovy_degrees < 180.0f))
        throw Error("primary rays: fovy must be in (0, 180) degrees, got " + std::to_string(camera.fovy_degrees));
    const Vec3 forward = normalize3(sub(camera.target, camera.eye));
    const Vec3 right = normalize3(cross3(forward, camera.up));
    const Vec3 up = cross3(right, forward);
    if (!is_finite(forward) || !is_finite(right))
        throw Error("primary rays: the camera's eye, target and up do not define a view");
    const double pi = 3.14159265358979323846;
    const float tan_half = float(std::tan(double(camera.fovy_degrees) * pi / 360.0));
    const float aspect = float(width) / float(height);
    const float sx_scale = tan_half * aspect;
    const float w = float(width), h = float(height);

    std::vector<Ray> rays(size_t(width) * height);
    for (uint32_t y = 0; y < height; ++y) {
        const float py = (float(y) + 0.5f) / h;
        const float sy = (1.0f - 2.0f * py) * tan_half;
        for (uint32_t x = 0; x < width; ++x) {
            const float px = (float(x) + 0.5f) / w;
            const float sx = (2.0f * px - 1.0f) * sx_scale;
            Ray& ray = rays[size_t(y) * width + x];
            ray.org = camera.eye;
            ray.dir = normalize3(add(add(forward, scale(right, sx)), scale(up, sy)));
            ray.tmin = 0.0f;
            ray.tmax = kInfinity;
        }
    }
    return rays;
}

// Spec "diffuse": a cosine-distributed bounce off each primary hit, in primary order, with the
// orthonormal basis of Duff et al. 2017 ("Building an Orthonormal Basis, Revisited").
std::vector<Ray> generate_diffuse_rays(const Scene& scene, std::span<const Ray> primary_rays,
                                       std::span<const Hit> primary_hits, uint64_t seed, float epsilon) {
    if (primary_rays.size() != primary_hits.size())
        throw Error("diffuse rays: " + std::to_string(primary_rays.size()) + " primary rays but " +
                    std::to_string(primary_hits.size()) + " hits");
    if (!(epsilon > 0.0f)) {
        const AABB box = scene.bounds();
        const Vec3 ext = sub(box.hi, box.lo);
        epsilon = 1e-4f * std::sqrt(dot3(ext, ext));  // the spec's default, 1e-4 x |scene diagonal|
    }
    SplitMix64 rng(seed);
    std::vector<Ray> rays;
    for (size_t i = 0; i < primary_rays.size(); ++i) {
        const Hit& hit = primary_hits[i];
        if (!hit.is_hit()) continue;
        if (hit.primitive >= scene.triangles.size())
            throw Error("diffuse rays: primary hit " + std::to_string(i) + " names triangle " +
                        std::to_string(hit.primitive) + " but the scene has " + std::to_string(scene.triangles.size()));
        const Ray& primary = primary_rays[i];
        const Triangle& tri = scene.triangles[hit.primitive];
        const Vec3 p = add(primary.org, scale(primary.dir, hit.t));
        Vec3 n = normalize3(cross3(sub(tri.v1, tri.v0), sub(tri.v2, tri.v0)));
        if (!is_finite(n))
            throw Error("diffuse rays: primary hit " + std::to_string(i) + " is on degenerate triangle " +
                        std::to_string(hit.primitive));
        if (dot3(n, primary.dir) > 0.0f) n = {-n.x, -n.y, -n.z};

        const float sign = std::copysign(1.0f, n.z);
        const float k = -1.0f / (sign + n.z);
        const float m = n.x * n.y * k;
        const Vec3 t = {1.0f + sign * n.x * n.x * k, sign * m, -sign * n.x};
        const Vec3 b = {m, sign + n.y * n.y * k, -n.y};

        float a, b2, s;
        rng.disk(a, b2, s);
        const float h = std::sqrt(std::max(0.0f, 1.0f - s));
        Ray ray;
        ray.org = add(p, scale(n, epsilon));
        ray.dir = normalize3(add(add(scale(t, a), scale(b, b2)), scale(n, h)));
        ray.tmin = 0.0f;
        ray.tmax = kInfinity;
        rays.push_back(ray);
    }
    return rays;
}

}  // namespace spacebvh::tools
