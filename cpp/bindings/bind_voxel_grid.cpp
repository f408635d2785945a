// Binding of pcl_rg::voxel_grid (see cpp/include/pcl_rg/voxel_grid.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/voxel_grid.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_voxel_grid(py::module_& m) {
    py::class_<VoxelGridParams>(m, "VoxelGridParams")
        .def(py::init<>())
        .def_readwrite("leaf_size", &VoxelGridParams::leaf_size)
        .def_readwrite("min_points_per_voxel", &VoxelGridParams::min_points_per_voxel);

    m.def(
        "voxel_grid",
        [](const PointsArray& points, const VoxelGridParams& params) {
            const PointsView view = points_view(points);
            py::array_t<std::int64_t> voxel_of_point(static_cast<py::ssize_t>(view.size));
            std::int64_t* out = voxel_of_point.mutable_data();
            VoxelGridResult result;
            without_gil([&] { result = voxel_grid(view, params, out); });
            const auto kept = static_cast<py::ssize_t>(result.counts.size());
            return py::make_tuple(to_numpy(std::move(result.centroids), {kept, 3}),
                                  to_numpy(std::move(result.counts), {kept}), voxel_of_point);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core VoxelGrid: (centroids, counts, voxel_of_point). Use pcl_rg.voxel_grid.");
}

}  // namespace pcl_rg::bindings
