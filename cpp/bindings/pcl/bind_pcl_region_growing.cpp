// Binding of PCL's NormalEstimation and RegionGrowing (see cpp/pcl/pcl_region_growing.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_region_growing.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_pcl_region_growing(py::module_& m) {
    py::class_<NormalEstimationParams>(m, "NormalEstimationParams")
        .def(py::init<>())
        .def_readwrite("k", &NormalEstimationParams::k);
    py::class_<RegionGrowingPclParams>(m, "RegionGrowingPclParams")
        .def(py::init<>())
        .def_readwrite("k", &RegionGrowingPclParams::k)
        .def_readwrite("smoothness_deg", &RegionGrowingPclParams::smoothness_deg)
        .def_readwrite("curvature_threshold", &RegionGrowingPclParams::curvature_threshold)
        .def_readwrite("min_cluster_size", &RegionGrowingPclParams::min_cluster_size)
        .def_readwrite("max_cluster_size", &RegionGrowingPclParams::max_cluster_size);

    m.def(
        "normal_estimation",
        [](const PointsArray& points, const NormalEstimationParams& params) {
            const PointsView view = points_view(points);
            const auto n = static_cast<py::ssize_t>(view.size);
            py::array_t<float> normal({n, py::ssize_t{3}});
            py::array_t<float> curvature(n);
            float* normal_out = normal.mutable_data();
            float* curvature_out = curvature.mutable_data();
            without_gil([&] { pcl_normal_estimation(view, params, normal_out, curvature_out); });
            return py::make_tuple(normal, curvature);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::NormalEstimation: (normals float32 (N, 3), curvature float32 (N,)). Use "
        "pcl_rg.pcl.normals.");
    m.def(
        "region_growing",
        [](const PointsArray& points, const RegionGrowingPclParams& params) {
            auto [labels, timings] =
                per_point<std::int32_t>(points, [&](const PointsView& view, std::int32_t* out) {
                    return pcl_region_growing(view, params, out);
                });
            return py::make_tuple(labels, timings.normals_seconds, timings.growth_seconds);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::NormalEstimation + pcl::RegionGrowing: (labels, normals_seconds, "
        "growth_seconds). Use pcl_rg.pcl.region_growing.");
}

}  // namespace pcl_rg::bindings
