// Binding of PCL's VoxelGrid and StatisticalOutlierRemoval (see cpp/pcl/pcl_filters.hpp).
// The parameter structs are module-local: _core registers the same C++ types.
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_filters.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_pcl_filters(py::module_& m) {
    py::class_<VoxelGridParams>(m, "VoxelGridParams", py::module_local())
        .def(py::init<>())
        .def_readwrite("leaf_size", &VoxelGridParams::leaf_size)
        .def_readwrite("min_points_per_voxel", &VoxelGridParams::min_points_per_voxel);
    py::class_<StatisticalOutlierRemovalParams>(m, "StatisticalOutlierRemovalParams",
                                                py::module_local())
        .def(py::init<>())
        .def_readwrite("mean_k", &StatisticalOutlierRemovalParams::mean_k)
        .def_readwrite("std_mul", &StatisticalOutlierRemovalParams::std_mul);

    m.def(
        "voxel_grid",
        [](const PointsArray& points, const VoxelGridParams& params) {
            const PointsView view = points_view(points);
            py::array_t<std::int64_t> voxel_of_point(static_cast<py::ssize_t>(view.size));
            std::int64_t* out = voxel_of_point.mutable_data();
            PclVoxelGridResult result;
            without_gil([&] { result = pcl_voxel_grid(view, params, out); });
            const auto kept = static_cast<py::ssize_t>(result.counts.size());
            return py::make_tuple(to_numpy(std::move(result.centroids), {kept, 3}),
                                  to_numpy(std::move(result.counts), {kept}), voxel_of_point);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::VoxelGrid: (centroids, counts, voxel_of_point). Use pcl_rg.pcl.voxel_grid.");
    m.def(
        "statistical_outlier_removal",
        [](const PointsArray& points, const StatisticalOutlierRemovalParams& params) {
            const PointsView view = points_view(points);
            py::array_t<bool> inlier(static_cast<py::ssize_t>(view.size));
            bool* out = inlier.mutable_data();
            without_gil([&] { pcl_statistical_outlier_removal(view, params, out); });
            return inlier;
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::StatisticalOutlierRemoval: inlier mask. Use "
        "pcl_rg.pcl.statistical_outlier_removal.");
}

}  // namespace pcl_rg::bindings
