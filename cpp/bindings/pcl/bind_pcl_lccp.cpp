// Binding of PCL's SupervoxelClustering + LCCPSegmentation (see cpp/pcl/pcl_lccp.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_lccp.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_pcl_lccp(py::module_& m) {
    py::class_<LccpParams>(m, "LccpParams")
        .def(py::init<>())
        .def_readwrite("voxel_resolution", &LccpParams::voxel_resolution)
        .def_readwrite("seed_resolution", &LccpParams::seed_resolution)
        .def_readwrite("spatial_importance", &LccpParams::spatial_importance)
        .def_readwrite("normal_importance", &LccpParams::normal_importance)
        .def_readwrite("refinement_iterations", &LccpParams::refinement_iterations)
        .def_readwrite("concavity_tolerance_deg", &LccpParams::concavity_tolerance_deg)
        .def_readwrite("smoothness_threshold", &LccpParams::smoothness_threshold)
        .def_readwrite("k_factor", &LccpParams::k_factor)
        .def_readwrite("sanity_check", &LccpParams::sanity_check)
        .def_readwrite("min_segment_size", &LccpParams::min_segment_size)
        .def_readwrite("viewpoint", &LccpParams::viewpoint);

    m.def(
        "lccp",
        [](const PointsArray& points, const LccpParams& params) {
            const PointsView view = points_view(points);
            validate(params);  // before allocating, so bad parameters cost nothing
            py::array_t<std::int32_t> labels(static_cast<py::ssize_t>(view.size));
            std::int32_t* out = labels.mutable_data();
            LccpTimings timings;
            without_gil([&] { timings = pcl_lccp(view, params, out); });
            return py::make_tuple(labels, timings.supervoxel_seconds, timings.segmentation_seconds);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::SupervoxelClustering + pcl::LCCPSegmentation: (labels, supervoxel_seconds, "
        "segmentation_seconds). Use pcl_rg.pcl.lccp.");
}

}  // namespace pcl_rg::bindings
