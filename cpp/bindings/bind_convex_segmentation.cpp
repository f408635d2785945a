// Binding of pcl_rg::convex_segmentation (see cpp/include/pcl_rg/convex_segmentation.hpp).
#include <pybind11/stl.h>  // the optional viewpoint: None when unset

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/convex_segmentation.hpp"
#include "pcl_rg/point_scale.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_convex_segmentation(py::module_& m) {
    m.def(
        "point_scale",
        [](const PointsArray& points) {
            const PointsView view = points_view(points);
            PointScale scale;
            without_gil([&] { scale = point_scale(view); });
            return py::make_tuple(scale.spacing, scale.noise, scale.far_points);
        },
        py::arg("points").noconvert(),
        "(spacing, noise, far_points) of the points, see point_scale.hpp. Use "
        "pcl_rg.point_scale.");

    py::class_<ConvexSegmentationParams>(m, "ConvexSegmentationParams")
        .def(py::init<>())
        .def_readwrite("noise_leaves", &ConvexSegmentationParams::noise_leaves)
        .def_readwrite("k", &ConvexSegmentationParams::k)
        .def_readwrite("smoothness_deg", &ConvexSegmentationParams::smoothness_deg)
        .def_readwrite("curvature_threshold", &ConvexSegmentationParams::curvature_threshold)
        .def_readwrite("concavity_tolerance_deg",
                       &ConvexSegmentationParams::concavity_tolerance_deg)
        .def_readwrite("min_cluster_size", &ConvexSegmentationParams::min_cluster_size)
        .def_readwrite("viewpoint", &ConvexSegmentationParams::viewpoint);

    m.def(
        "convex_segmentation",
        [](const PointsArray& points, const ConvexSegmentationParams& params) {
            auto [labels, timings] =
                per_point<std::int32_t>(points, [&](const PointsView& view, std::int32_t* out) {
                    return convex_segmentation(view, params, out);
                });
            return py::make_tuple(labels, timings.normals_seconds, timings.growth_seconds,
                                  timings.merge_seconds, timings.leaf, timings.viewpoint,
                                  timings.far_points);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core convex segmentation: (labels, normals_seconds, growth_seconds, merge_seconds, "
        "leaf, viewpoint, far_points). "
        "Use pcl_rg.convex_segmentation.");

    m.def(
        "default_viewpoint",
        [](const PointsArray& points) {
            const PointsView view = points_view(points);
            return default_viewpoint(view);
        },
        py::arg("points").noconvert(),
        "The viewpoint convex_segmentation uses when none is given (convex_segmentation.hpp).");

    m.def(
        "merge_convex",
        [](const PointsArray& points,
           const py::array_t<std::uint32_t, py::array::c_style>& neighbours,
           const py::array_t<double, py::array::c_style>& normals,
           const py::array_t<std::int32_t, py::array::c_style>& patches,
           const ConvexSegmentationParams& params) {
            const PointsView view = points_view(points);
            const std::size_t n = view.size;
            if (neighbours.ndim() != 2 || static_cast<std::size_t>(neighbours.shape(0)) != n)
                throw std::invalid_argument("neighbours must have shape (N, k)");
            const auto k = static_cast<std::size_t>(neighbours.shape(1));
            if (normals.ndim() != 2 || static_cast<std::size_t>(normals.shape(0)) != n ||
                normals.shape(1) != 3)
                throw std::invalid_argument("normals must have shape (N, 3)");
            if (patches.ndim() != 1 || static_cast<std::size_t>(patches.shape(0)) != n)
                throw std::invalid_argument("patches must have shape (N,)");
            py::array_t<std::int32_t> labels(static_cast<py::ssize_t>(n));
            std::int32_t* out = labels.mutable_data();
            without_gil([&] {
                merge_convex(view, k, neighbours.data(), normals.data(), patches.data(), params,
                             out);
            });
            return labels;
        },
        py::arg("points").noconvert(), py::arg("neighbours").noconvert(),
        py::arg("normals").noconvert(), py::arg("patches").noconvert(), py::arg("params"),
        "The merge step alone on given points, neighbour lists (uint32 (N, k)), unit normals "
        "and patch ids (int32 (N,), -1 for none): int32 labels.");
}

}  // namespace pcl_rg::bindings
