// Array <-> C++ helpers: the one place for ownership tricks between NumPy and the core.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
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

/// Runs a voxel grid (ours or PCL's) without the GIL and returns (centroids, counts,
/// voxel_of_point). `run(view, voxel_of_point)` returns a struct with `centroids`
/// (kept * 3 doubles) and `counts` (kept int64).
template <class Run>
py::tuple voxel_grid_to_numpy(const PointsArray& points, Run run) {
    const PointsView view = points_view(points);
    py::array_t<std::int64_t> voxel_of_point(static_cast<py::ssize_t>(view.size));
    std::int64_t* out = voxel_of_point.mutable_data();
    decltype(run(view, out)) result;
    without_gil([&] { result = run(view, out); });
    const auto kept = static_cast<py::ssize_t>(result.counts.size());
    return py::make_tuple(to_numpy(std::move(result.centroids), {kept, 3}),
                          to_numpy(std::move(result.counts), {kept}), voxel_of_point);
}

}  // namespace pcl_rg::bindings
