// Binding of pcl_rg::voxel_grid (see cpp/include/pcl_rg/voxel_grid.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/voxel_grid.hpp"

namespace pcl_rg::bindings {

void bind_voxel_grid(py::module_& m) {
    py::class_<VoxelGridParams>(m, "VoxelGridParams")
        .def(py::init<>())
        .def_readwrite("leaf_size", &VoxelGridParams::leaf_size)
        .def_readwrite("min_points_per_voxel", &VoxelGridParams::min_points_per_voxel);

    m.def(
        "voxel_grid",
        [](const PointsArray& points, const VoxelGridParams& params) {
            return voxel_grid_to_numpy(points, [&](const PointsView& view, std::int64_t* out) {
                return voxel_grid(view, params, out);
            });
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core VoxelGrid: (centroids, counts, voxel_of_point). Use pcl_rg.voxel_grid.");
}

}  // namespace pcl_rg::bindings
