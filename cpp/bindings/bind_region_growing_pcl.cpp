// Binding of PCL's NormalEstimation + RegionGrowing baseline (see region_growing_pcl.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/region_growing_pcl.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_region_growing_pcl(py::module_& m) {
    py::class_<RegionGrowingPclParams>(m, "RegionGrowingPclParams")
        .def(py::init<>())
        .def_readwrite("k", &RegionGrowingPclParams::k)
        .def_readwrite("smoothness_deg", &RegionGrowingPclParams::smoothness_deg)
        .def_readwrite("curvature_threshold", &RegionGrowingPclParams::curvature_threshold)
        .def_readwrite("min_cluster_size", &RegionGrowingPclParams::min_cluster_size)
        .def_readwrite("max_cluster_size", &RegionGrowingPclParams::max_cluster_size);

    m.def(
        "region_growing_pcl",
        [](const PointsArray& points, const RegionGrowingPclParams& params) {
            const PointsView view = points_view(points);
            const auto n = static_cast<py::ssize_t>(view.size);
            py::array_t<std::int32_t> labels(n);
            py::array_t<float> normal({n, py::ssize_t{3}});
            py::array_t<float> curvature(n);
            std::int32_t* out = labels.mutable_data();
            float* normal_out = normal.mutable_data();
            float* curvature_out = curvature.mutable_data();
            RegionGrowingTimings timings;
            without_gil([&] {
                timings = region_growing_pcl(view, params, out, normal_out, curvature_out);
            });
            return py::make_tuple(labels, normal, curvature, timings.normals_seconds,
                                  timings.growth_seconds);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "PCL NormalEstimation + RegionGrowing: (labels, normals float32, curvature float32, "
        "normals_seconds, growth_seconds). Use pcl_rg.region_growing_pcl.");
}

}  // namespace pcl_rg::bindings
