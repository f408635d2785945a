// Binding of pcl_rg::region_growing (see cpp/include/pcl_rg/region_growing.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/region_growing.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_region_growing(py::module_& m) {
    py::enum_<SeedMeasure>(m, "SeedMeasure")
        .value("curvedness", SeedMeasure::curvedness)
        .value("gaussian", SeedMeasure::gaussian)
        .value("mean", SeedMeasure::mean)
        .value("surface_variation", SeedMeasure::surface_variation)
        .value("concavity", SeedMeasure::concavity);

    py::class_<RegionGrowingParams>(m, "RegionGrowingParams")
        .def(py::init<>())
        .def_readwrite("k", &RegionGrowingParams::k)
        .def_readwrite("smoothness_deg", &RegionGrowingParams::smoothness_deg)
        .def_readwrite("curvature_threshold", &RegionGrowingParams::curvature_threshold)
        .def_readwrite("min_cluster_size", &RegionGrowingParams::min_cluster_size)
        .def_readwrite("max_cluster_size", &RegionGrowingParams::max_cluster_size)
        .def_readwrite("seed_measure", &RegionGrowingParams::seed_measure)
        .def_readwrite("viewpoint", &RegionGrowingParams::viewpoint);

    m.def(
        "region_growing",
        [](const PointsArray& points, const RegionGrowingParams& params) {
            auto [labels, timings] =
                per_point<std::int32_t>(points, [&](const PointsView& view, std::int32_t* out) {
                    return region_growing(view, params, out);
                });
            return py::make_tuple(labels, timings.normals_seconds, timings.growth_seconds,
                                  timings.far_points);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core region growing: (labels, normals_seconds, growth_seconds, far_points). Use "
        "pcl_rg.region_growing.");

    m.def(
        "grow_regions",
        [](const py::array_t<std::uint32_t, py::array::c_style>& neighbours,
           const py::array_t<double, py::array::c_style>& normals,
           const py::array_t<double, py::array::c_style>& measure,
           const RegionGrowingParams& params) {
            if (neighbours.ndim() != 2)
                throw std::invalid_argument("neighbours must have shape (N, k)");
            const auto n = static_cast<std::size_t>(neighbours.shape(0));
            const auto k = static_cast<std::size_t>(neighbours.shape(1));
            if (normals.ndim() != 2 || static_cast<std::size_t>(normals.shape(0)) != n ||
                normals.shape(1) != 3)
                throw std::invalid_argument("normals must have shape (N, 3)");
            if (measure.ndim() != 1 || static_cast<std::size_t>(measure.shape(0)) != n)
                throw std::invalid_argument("measure must have shape (N,)");
            py::array_t<std::int32_t> labels(static_cast<py::ssize_t>(n));
            std::int32_t* out = labels.mutable_data();
            without_gil([&] {
                grow_regions(n, k, neighbours.data(), normals.data(), measure.data(), params, out);
            });
            return labels;
        },
        py::arg("neighbours").noconvert(), py::arg("normals").noconvert(),
        py::arg("measure").noconvert(), py::arg("params"),
        "Growth alone on given neighbour lists (uint32 (N, k)), unit normals and seed "
        "measure: int32 labels.");
}

}  // namespace pcl_rg::bindings
