// Binding of PCL's VoxelGrid and StatisticalOutlierRemoval (see cpp/pcl/pcl_filters.hpp).
// The parameter structs are _core's: the module imports pcl_rg._core first (module.cpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_filters.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_pcl_filters(py::module_& m) {
    m.def(
        "voxel_grid",
        [](const PointsArray& points, const VoxelGridParams& params) {
            return voxel_grid_to_numpy(points, [&](const PointsView& view, std::int64_t* out) {
                return pcl_voxel_grid(view, params, out);
            });
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::VoxelGrid: (centroids, counts, voxel_of_point). Use pcl_rg.pcl.voxel_grid.");
    m.def(
        "statistical_outlier_removal",
        [](const PointsArray& points, const StatisticalOutlierRemovalParams& params) {
            return per_point<bool>(points, [&](const PointsView& view, bool* out) {
                pcl_statistical_outlier_removal(view, params, out);
            });
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::StatisticalOutlierRemoval: inlier mask. Use "
        "pcl_rg.pcl.statistical_outlier_removal.");
}

}  // namespace pcl_rg::bindings
