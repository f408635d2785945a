// Array <-> C++ helpers: the one place for ownership tricks between NumPy and the core.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "pcl_rg/points.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

namespace py = pybind11;

/// What the module accepts for points: float64, C order, never converted here (the
/// Python layer converts visibly, see pcl_rg._validation.as_points).
using PointsArray = py::array_t<double, py::array::c_style>;

/// View of an (N, 3) float64 C-contiguous array; the array must outlive the view.
inline PointsView points_view(const PointsArray& points) {
    if (points.ndim() != 2 || points.shape(1) != 3)
        throw std::invalid_argument("points must have shape (N, 3)");
    return PointsView{points.data(), static_cast<std::size_t>(points.shape(0))};
}

/// A 3-vector from a (3,) float64 array.
inline std::array<double, 3> vector3(const py::array_t<double, py::array::c_style>& v,
                                     const char* name) {
    if (v.ndim() != 1 || v.shape(0) != 3)
        throw std::invalid_argument(std::string(name) + " must have shape (3,)");
    return {v.data()[0], v.data()[1], v.data()[2]};
}

/// Hands a vector's buffer to NumPy without copying; the capsule frees it.
template <class T>
py::array_t<T> to_numpy(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
    auto* owned = new std::vector<T>(std::move(values));
    py::capsule free_when_done(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
    return py::array_t<T>(shape, owned->data(), free_when_done);
}

}  // namespace pcl_rg::bindings

namespace pcl_rg::bindings {

/// Runs `run(view, out)` without the GIL, `out` being a new NumPy array of one T per point
/// that `run` fills. Returns that array, or (that array, what `run` returned) when `run`
/// returns something (statistics, stage times).
template <class T, class Run>
auto per_point(const PointsArray& points, Run run) {
    const PointsView view = points_view(points);
    py::array_t<T> values(static_cast<py::ssize_t>(view.size));
    T* out = values.mutable_data();
    using Result = decltype(run(view, out));
    if constexpr (std::is_void_v<Result>) {
        without_gil([&] { run(view, out); });
        return values;
    } else {
        Result result;
        without_gil([&] { result = run(view, out); });
        return std::make_pair(values, std::move(result));
    }
}

/// Runs a voxel grid (ours or PCL's) without the GIL and returns (centroids, counts,
/// voxel_of_point). `run(view, voxel_of_point)` returns a struct with `centroids`
/// (kept * 3 doubles) and `counts` (kept int64).
template <class Run>
py::tuple voxel_grid_to_numpy(const PointsArray& points, Run run) {
    auto [voxel_of_point, result] = per_point<std::int64_t>(points, run);
    const auto kept = static_cast<py::ssize_t>(result.counts.size());
    return py::make_tuple(to_numpy(std::move(result.centroids), {kept, 3}),
                          to_numpy(std::move(result.counts), {kept}), voxel_of_point);
}

}  // namespace pcl_rg::bindings
