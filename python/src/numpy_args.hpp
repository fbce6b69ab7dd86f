// SPDX-License-Identifier: MIT
// NumPy arguments read in place: (n, 3) float32/float64 arrays of any strides (C- or F-ordered,
// sliced), integer index arrays of any width, numbers or arrays of one value per ray. Nothing is
// copied into an intermediate array; the readers keep the array alive and may be used without the
// GIL. Wrong shapes raise spacebvh.Error and wrong dtypes TypeError, both naming the argument.
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/geometry.hpp"

namespace spacebvh::python {

namespace py = pybind11;

// Where a scene's local coordinates sit in the caller's: caller = local + origin, in double. Meshes
// given in float64 are taken into a frame centred on their bounds before rounding to float32, so
// the float32 kernels keep the precision of small coordinates wherever the mesh lies; `float64`
// also says that coordinates and distances come back to the caller as float64.
struct Frame {
    std::array<double, 3> origin{0.0, 0.0, 0.0};
    bool float64 = false;

    float to_local(double caller, int axis) const { return float(caller - origin[size_t(axis)]); }
    double to_caller(float local, int axis) const { return double(local) + origin[size_t(axis)]; }
};

// One coordinate of row `row`, as double, from a typed strided buffer.
template <typename T>
struct StridedRows {
    const char* data;
    py::ssize_t row_stride;  // 0 for a single row broadcast to every row
    py::ssize_t column_stride;
    double operator()(size_t row, int axis) const {
        return double(*reinterpret_cast<const T*>(data + py::ssize_t(row) * row_stride + axis * column_stride));
    }
};

// A read-only (n, 3) array of float32 or float64 (other real dtypes are converted to float64 once).
// With allow_single, a (3,) or (1, 3) array is one row, broadcast by `rows_for`.
class RealRows {
public:
    RealRows() = default;
    static RealRows from(const py::handle& object, const char* what, bool allow_single = false);

    size_t rows() const { return rows_; }
    bool single() const { return single_; }
    bool is_float64() const { return float64_; }
    const char* name() const { return what_; }

    // Calls f(StridedRows<float>) or f(StridedRows<double>).
    template <typename F>
    decltype(auto) visit(F&& f) const {
        if (float64_) return f(StridedRows<double>{data_, row_stride_, column_stride_});
        return f(StridedRows<float>{data_, row_stride_, column_stride_});
    }

private:
    py::object array_;  // keeps the array alive
    const char* what_ = "";
    const char* data_ = nullptr;
    py::ssize_t row_stride_ = 0, column_stride_ = 0;
    size_t rows_ = 0;
    bool float64_ = false, single_ = false;
};

// A read-only (m, 3) array of integers of any width and signedness.
class IndexRows {
public:
    static IndexRows from(const py::handle& object, const char* what);
    size_t rows() const { return rows_; }
    // The index at (row, column); unsigned values beyond int64 come back as int64's maximum (out of
    // range of any mesh either way).
    int64_t operator()(size_t row, int column) const;

private:
    py::object array_;  // keeps the array alive
    const char* data_ = nullptr;
    py::ssize_t row_stride_ = 0, column_stride_ = 0;
    size_t rows_ = 0;
    int item_size_ = 8;
    bool is_signed_ = true;
};

// One number per ray: a Python or NumPy number shared by every ray, or a 1-D array of one per ray.
class PerRay {
public:
    static PerRay from(const py::handle& object, size_t rays, const char* what);
    double operator[](size_t i) const {
        if (data_ == nullptr) return constant_;
        const char* p = data_ + py::ssize_t(i) * stride_;
        return float64_ ? *reinterpret_cast<const double*>(p) : double(*reinterpret_cast<const float*>(p));
    }

private:
    double constant_ = 0.0;
    py::object array_;  // keeps the array alive (null for a constant)
    const char* data_ = nullptr;
    py::ssize_t stride_ = 0;
    bool float64_ = false;
};

// The lowest index i in [0, n) for which passes(i) is false, or n where it holds for all: passes runs
// on the indices in blocks of `grain` across the threads of the calling arena (call without the GIL),
// each block stopping at its first failure (its later indices cannot be the lowest). The answer is the
// same whatever the thread count, so that an error names the same row on every run.
template <typename Passes>
size_t first_failing(size_t n, size_t grain, Passes&& passes) {
    std::atomic<size_t> first{n};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i < range.end(); ++i) {
            if (passes(i)) continue;
            size_t seen = first.load();
            while (i < seen && !first.compare_exchange_weak(seen, i)) {}
            break;
        }
    });
    return first.load();
}

// Reads the points `rows` into `out` (as many), each coordinate by put(out[i], axis, value), across
// the threads of the calling arena (call without the GIL). Returns the lowest index of a row with a
// coordinate that is not finite (whose point is then left partly written), or out.size().
template <typename Point, typename Put>
size_t read_finite_points(const RealRows& rows, std::span<Point> out, Put&& put) {
    return rows.visit([&](auto read) {
        return first_failing(out.size(), size_t(1) << 14, [&](size_t i) {
            for (int axis = 0; axis < 3; ++axis) {
                const double value = read(i, axis);
                if (!std::isfinite(value)) return false;
                put(out[i], axis, value);
            }
            return true;
        });
    });
}

// The number of rays that origins and directions describe: both have k rows, or one of them a single
// row broadcast to the other's k. Throws Error naming both otherwise.
size_t ray_count(const RealRows& origins, const RealRows& directions);

// Rays read in place: caller-frame origins and directions and per-ray [tmin, tmax], each ray taken
// into the scene's local frame and checked as ray files are (untraceable_ray_reason) when read.
class RaySource {
public:
    RaySource(const Frame& frame, RealRows origins, RealRows directions, PerRay tmin, PerRay tmax);
    size_t size() const { return count_; }
    // Calls f(read) with read(i, ray) writing ray i and returning whether it can be traced.
    template <typename F>
    decltype(auto) visit(F&& f) const {
        return origins_.visit([&](const auto& o) {
            return directions_.visit([&](const auto& d) {
                return f([&](size_t i, Ray& ray) {
                    for (int axis = 0; axis < 3; ++axis) {
                        ray.org[axis] = frame_.to_local(o(i, axis), axis);
                        ray.dir[axis] = float(d(i, axis));
                    }
                    ray.tmin = float(tmin_[i]);
                    ray.tmax = float(tmax_[i]);
                    return reason(ray) == nullptr;
                });
            });
        });
    }
    // Throws Error naming ray i and why it cannot be traced.
    [[noreturn]] void fail(size_t i) const;

private:
    static const char* reason(const Ray& ray);  // nullptr: traceable
    Frame frame_;
    RealRows origins_, directions_;
    PerRay tmin_, tmax_;
    size_t count_ = 0;
};

// Rays in the scene's local frame (RaySource), the first bad one named (the lowest index, whatever
// the thread count). Call without the GIL, inside the arena that should do the work.
std::vector<Ray> make_rays(const RaySource& source);

// Rays per block of in_ray_blocks: a block's rays (8 KiB) and answers stay in the first-level cache.
constexpr size_t kRayBlock = 256;

// Runs trace(first, rays) over the source's rays in blocks of kRayBlock across the calling arena (call
// without the GIL), each block's rays read into a buffer on the stack, so that no array of every ray
// (or of every answer before its conversion) is made: trace writes block's answers straight into
// the output arrays at first + i. A block with a ray that cannot be traced is not traced; afterwards
// the lowest such ray is named (RaySource::fail), whatever the thread count.
template <typename Trace>
void in_ray_blocks(const RaySource& source, Trace&& trace) {
    const size_t n = source.size();
    const size_t blocks = (n + kRayBlock - 1) / kRayBlock;
    const size_t bad = source.visit([&](const auto& read) {
        std::atomic<size_t> first_bad{n};
        tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks, 4), [&](const tbb::blocked_range<size_t>& range) {
            std::array<Ray, kRayBlock> rays;
            for (size_t b = range.begin(); b < range.end(); ++b) {
                const size_t first = b * kRayBlock, count = std::min(kRayBlock, n - first);
                size_t i = 0;
                while (i < count && read(first + i, rays[i])) ++i;
                if (i < count) {
                    size_t seen = first_bad.load();
                    while (first + i < seen && !first_bad.compare_exchange_weak(seen, first + i)) {}
                    continue;
                }
                trace(first, std::span<const Ray>(rays.data(), count));
            }
        });
        return first_bad.load();
    });
    if (bad < n) source.fail(bad);
}

// Parses the Python arguments (with the GIL) into a RaySource.
RaySource ray_source(const Frame& frame, const py::handle& origins, const py::handle& directions,
                     const py::handle& tmin, const py::handle& tmax);

// Parses the Python arguments (with the GIL) and makes the rays in the arena of `threads` threads
// without it.
std::vector<Ray> rays_from_arguments(const Frame& frame, const py::handle& origins, const py::handle& directions,
                                     const py::handle& tmin, const py::handle& tmax, int threads);

// A fresh (n,) or (n, 3) array of float32 or float64, by the frame.
py::array new_real_array(bool float64, std::vector<py::ssize_t> shape);

}  // namespace spacebvh::python
