// Binding of PCL's own filter classes, for benchmarks and equivalence tests only.
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/pcl_filters_baseline.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_pcl_filters_baseline(py::module_& m) {
    m.def(
        "pcl_voxel_grid",
        [](const PointsArray& points, const py::array_t<double, py::array::c_style>& origin,
           const VoxelGridParams& params) {
            const PointsView view = points_view(points);
            const auto shift = vector3(origin, "origin");
            std::vector<double> centroids;
            without_gil([&] { centroids = pcl_voxel_grid(view, shift, params); });
            const auto rows = static_cast<py::ssize_t>(centroids.size() / 3);
            return to_numpy(std::move(centroids), {rows, 3});
        },
        py::arg("points").noconvert(), py::arg("origin").noconvert(), py::arg("params"),
        "pcl::VoxelGrid on points - origin (float32); centroids + origin.");
    m.def(
        "pcl_statistical_outlier_removal",
        [](const PointsArray& points, const py::array_t<double, py::array::c_style>& origin,
           const StatisticalOutlierRemovalParams& params) {
            const PointsView view = points_view(points);
            const auto shift = vector3(origin, "origin");
            py::array_t<bool> inlier(static_cast<py::ssize_t>(view.size));
            bool* out = inlier.mutable_data();
            without_gil([&] { pcl_statistical_outlier_removal(view, shift, params, out); });
            return inlier;
        },
        py::arg("points").noconvert(), py::arg("origin").noconvert(), py::arg("params"),
        "pcl::StatisticalOutlierRemoval on points - origin (float32); inlier mask.");
}

}  // namespace pcl_rg::bindings
