// Binding of pcl_rg::normals (see cpp/include/pcl_rg/normals.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/normals.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_normals(py::module_& m) {
    py::class_<NormalsParams>(m, "NormalsParams")
        .def(py::init<>())
        .def_readwrite("k", &NormalsParams::k);
    m.attr("QUADRIC_CONDITION_LIMIT") = kQuadricConditionLimit;

    m.def(
        "normals",
        [](const PointsArray& points, const NormalsParams& params) {
            const PointsView view = points_view(points);
            const auto n = static_cast<py::ssize_t>(view.size);
            py::array_t<double> normal({n, py::ssize_t{3}});
            py::array_t<double> surface_variation(n), gaussian(n), mean(n), k1(n), k2(n);
            NormalsOutput out;
            out.normal = normal.mutable_data();
            out.surface_variation = surface_variation.mutable_data();
            out.gaussian_curvature = gaussian.mutable_data();
            out.mean_curvature = mean.mutable_data();
            out.k1 = k1.mutable_data();
            out.k2 = k2.mutable_data();
            std::size_t far_points = 0;
            without_gil([&] { far_points = normals(view, params, out); });
            return py::make_tuple(normal, surface_variation, gaussian, mean, k1, k2, far_points);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core normals: (normal, surface_variation, gaussian, mean, k1, k2, far_points). Use "
        "pcl_rg.normals.");
    m.def(
        "neighbour_lists",
        [](const PointsArray& points, const NormalsParams& params,
           std::optional<std::size_t> leaf_budget, std::optional<std::size_t> heap_from_k) {
            const PointsView view = points_view(points);
            std::vector<std::uint32_t> lists;
            without_gil([&] { lists = neighbour_lists(view, params, leaf_budget, heap_from_k); });
            const auto rows = static_cast<py::ssize_t>(view.size);
            return to_numpy(std::move(lists), {rows, static_cast<py::ssize_t>(params.k)});
        },
        py::arg("points").noconvert(), py::arg("params"), py::arg("leaf_budget") = py::none(),
        py::arg("heap_from_k") = py::none(),
        "uint32 (N, k) neighbour lists of pcl_rg.normals and pcl_rg.region_growing. "
        "leaf_budget (tests): leaves of nanoflann's walk before a query walks again by "
        "the branches' boxes (default 64 + k); heap_from_k (tests): the least k whose "
        "lists are kept in a heap, not nanoflann's sorted list. The lists depend on "
        "neither.");
}

}  // namespace pcl_rg::bindings
