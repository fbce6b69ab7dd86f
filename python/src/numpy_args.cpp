// SPDX-License-Identifier: MIT
// Reading NumPy arguments in place (numpy_args.hpp).
#include "numpy_args.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "bindings.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"

namespace spacebvh::python {

using namespace spacebvh::tools;

namespace {

std::string shape_text(const py::array& array) {
    std::string text = "(";
    for (py::ssize_t axis = 0; axis < array.ndim(); ++axis)
        text += (axis ? ", " : "") + std::to_string(array.shape(axis));
    return text + (array.ndim() == 1 ? ",)" : ")");
}

std::string dtype_text(const py::array& array) { return py::str(array.dtype()).cast<std::string>(); }

py::array as_array(const py::handle& object) {
    // np.asarray: arrays as they are, anything else (lists, tuples, numbers) converted.
    return py::module_::import("numpy").attr("asarray")(object).cast<py::array>();
}

py::array as_native(const py::array& array, const char* dtype) {
    return py::module_::import("numpy").attr("asarray")(array, py::str(dtype)).cast<py::array>();
}

bool is_native(const py::array& array) { return array.dtype().attr("isnative").cast<bool>(); }

}  // namespace

RealRows RealRows::from(const py::handle& object, const char* what, bool allow_single) {
    py::array array = as_array(object);
    const char kind = array.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u')
        throw py::type_error(std::string(what) + " must be an array of real numbers (float32 or float64), not dtype " +
                             dtype_text(array));
    const py::ssize_t item = array.dtype().itemsize();
    if (kind != 'f' || (item != 4 && item != 8) || !is_native(array)) array = as_native(array, "float64");
    RealRows rows;
    rows.what_ = what;
    rows.float64_ = array.dtype().itemsize() == 8;
    rows.data_ = static_cast<const char*>(array.data());
    if (array.ndim() == 2 && array.shape(1) == 3) {
        rows.rows_ = size_t(array.shape(0));
        rows.row_stride_ = array.strides(0);
        rows.column_stride_ = array.strides(1);
        if (allow_single && rows.rows_ == 1) {
            rows.single_ = true;
            rows.row_stride_ = 0;
        }
    } else if (allow_single && array.ndim() == 1 && array.shape(0) == 3) {
        rows.rows_ = 1;
        rows.single_ = true;
        rows.column_stride_ = array.strides(0);
    } else {
        throw Error(std::string(what) + " must have shape (n, 3)" + (allow_single ? " or (3,)" : "") + ", not " +
                    shape_text(array));
    }
    rows.array_ = std::move(array);
    return rows;
}

IndexRows IndexRows::from(const py::handle& object, const char* what) {
    py::array array = as_array(object);
    const char kind = array.dtype().kind();
    if (kind != 'i' && kind != 'u')
        throw py::type_error(std::string(what) + " must be an array of integers (vertex indices), not dtype " +
                             dtype_text(array));
    if (!is_native(array)) array = as_native(array, "int64");
    // An empty list becomes float64 in np.asarray; it reaches here only as an integer array.
    if (array.ndim() != 2 || array.shape(1) != 3)
        throw Error(std::string(what) + " must have shape (m, 3), not " + shape_text(array));
    IndexRows rows;
    rows.rows_ = size_t(array.shape(0));
    rows.data_ = static_cast<const char*>(array.data());
    rows.row_stride_ = array.strides(0);
    rows.column_stride_ = array.strides(1);
    rows.item_size_ = int(array.dtype().itemsize());
    rows.is_signed_ = kind == 'i';
    rows.array_ = std::move(array);
    return rows;
}

int64_t IndexRows::operator()(size_t row, int column) const {
    const char* p = data_ + py::ssize_t(row) * row_stride_ + column * column_stride_;
    if (is_signed_) {
        switch (item_size_) {
            case 1:
                return *reinterpret_cast<const int8_t*>(p);
            case 2:
                return *reinterpret_cast<const int16_t*>(p);
            case 4:
                return *reinterpret_cast<const int32_t*>(p);
            default:
                return *reinterpret_cast<const int64_t*>(p);
        }
    }
    switch (item_size_) {
        case 1:
            return *reinterpret_cast<const uint8_t*>(p);
        case 2:
            return *reinterpret_cast<const uint16_t*>(p);
        case 4:
            return *reinterpret_cast<const uint32_t*>(p);
        default: {
            const uint64_t value = *reinterpret_cast<const uint64_t*>(p);
            return value > uint64_t(std::numeric_limits<int64_t>::max()) ? std::numeric_limits<int64_t>::max()
                                                                         : int64_t(value);
        }
    }
}

PerRay PerRay::from(const py::handle& object, size_t rays, const char* what) {
    PerRay result;
    if (py::isinstance<py::bool_>(object))
        throw py::type_error(std::string(what) + " must be a number or an array of numbers, not a bool");
    if (py::isinstance<py::float_>(object) || py::isinstance<py::int_>(object)) {
        result.constant_ = object.cast<double>();
        return result;
    }
    py::array array = as_array(object);
    const char kind = array.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u')
        throw py::type_error(std::string(what) + " must be a number or an array of numbers, not dtype " +
                             dtype_text(array));
    if (kind != 'f' || (array.dtype().itemsize() != 4 && array.dtype().itemsize() != 8) || !is_native(array))
        array = as_native(array, "float64");
    const bool float64 = array.dtype().itemsize() == 8;
    if (array.ndim() == 0 || (array.ndim() == 1 && array.shape(0) == 1 && rays != 1)) {  // a NumPy scalar
        const void* p = array.data();
        result.constant_ = float64 ? *static_cast<const double*>(p) : double(*static_cast<const float*>(p));
        return result;
    }
    if (array.ndim() != 1 || size_t(array.shape(0)) != rays)
        throw Error(std::string(what) + " must be a number or an array of " + std::to_string(rays) +
                    " (one per ray), not " + shape_text(array));
    result.float64_ = float64;
    result.data_ = static_cast<const char*>(array.data());
    result.stride_ = array.strides(0);
    result.array_ = std::move(array);
    return result;
}

size_t ray_count(const RealRows& origins, const RealRows& directions) {
    if (origins.rows() == directions.rows()) return origins.rows();
    if (origins.single()) return directions.rows();
    if (directions.single()) return origins.rows();
    throw Error("origins and directions differ in length: " + std::to_string(origins.rows()) + " and " +
                std::to_string(directions.rows()) + " (one of them may be a single row, shared by every ray)");
}

RaySource::RaySource(const Frame& frame, RealRows origins, RealRows directions, PerRay tmin, PerRay tmax)
    : frame_(frame),
      origins_(std::move(origins)),
      directions_(std::move(directions)),
      tmin_(std::move(tmin)),
      tmax_(std::move(tmax)),
      count_(ray_count(origins_, directions_)) {}

const char* RaySource::reason(const Ray& ray) {
    if (!(ray.tmin >= 0.0f) || !(ray.tmax >= ray.tmin)) return "need 0 <= tmin <= tmax";  // also refuses NaN
    return untraceable_ray_reason(ray);
}

void RaySource::fail(size_t i) const {
    Ray ray;
    visit([&](const auto& read) { read(i, ray); });
    std::string text = "ray " + std::to_string(i) + ": " + (reason(ray) ? reason(ray) : "cannot be traced");
    if (!(ray.tmin >= 0.0f) || !(ray.tmax >= ray.tmin))
        text += ", not tmin = " + std::to_string(ray.tmin) + ", tmax = " + std::to_string(ray.tmax);
    else
        text += " (origins row " + std::to_string(origins_.single() ? 0 : i) + ", directions row " +
                std::to_string(directions_.single() ? 0 : i) + ")";
    throw Error(text);
}

std::vector<Ray> make_rays(const RaySource& source) {
    const size_t n = source.size();
    std::vector<Ray> rays(n);
    const size_t bad = source.visit(
        [&](const auto& read) { return first_failing(n, 4096, [&](size_t i) { return read(i, rays[i]); }); });
    if (bad < n) source.fail(bad);
    return rays;
}

RaySource ray_source(const Frame& frame, const py::handle& origins, const py::handle& directions,
                     const py::handle& tmin, const py::handle& tmax) {
    RealRows o = RealRows::from(origins, "origins", true), d = RealRows::from(directions, "directions", true);
    const size_t n = ray_count(o, d);
    PerRay low = PerRay::from(tmin, n, "tmin"), high = PerRay::from(tmax, n, "tmax");
    return RaySource(frame, std::move(o), std::move(d), std::move(low), std::move(high));
}

std::vector<Ray> rays_from_arguments(const Frame& frame, const py::handle& origins, const py::handle& directions,
                                     const py::handle& tmin, const py::handle& tmax, int threads) {
    const RaySource source = ray_source(frame, origins, directions, tmin, tmax);
    std::vector<Ray> rays;
    without_gil(threads, [&] { rays = make_rays(source); });
    return rays;
}

py::array new_real_array(bool float64, std::vector<py::ssize_t> shape) {
    if (float64) return py::array_t<double>(shape);
    return py::array_t<float>(shape);
}

}  // namespace spacebvh::python
