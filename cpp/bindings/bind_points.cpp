// Binding of the points' float32 frame (see cpp/include/pcl_rg/points.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/points.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_points(py::module_& m) {
    m.def(
        "float32_origin",
        [](const PointsArray& points) {
            const PointsView view = points_view(points);
            std::array<double, 3> origin{};
            without_gil([&] { origin = float32_origin(view); });
            return to_numpy(std::vector<double>(origin.begin(), origin.end()), {3});
        },
        py::arg("points").noconvert(),
        "Core: the float64 origin of the k-nearest-neighbour steps' float32 frame.");
    m.def(
        "rows_within_float32_reach",
        [](const PointsArray& points, const py::array_t<double, py::array::c_style>& origin) {
            const PointsView view = points_view(points);
            const std::array<double, 3> from = vector3(origin, "origin");
            std::vector<std::int64_t> rows;
            without_gil([&] {
                for (const std::size_t row : rows_within_float32_reach(view, from))
                    rows.push_back(static_cast<std::int64_t>(row));
            });
            const auto n = static_cast<py::ssize_t>(rows.size());
            return to_numpy(std::move(rows), {n});
        },
        py::arg("points").noconvert(), py::arg("origin").noconvert(),
        "Core: the rows within float32's reach of `origin` on every axis, any number far.");
    m.attr("ORIGIN_FENCE") = kOriginFence;
    m.def("max_far_points", &max_far_points, py::arg("n"),
          "Core: how many far points a k-nearest-neighbour step leaves out of n.");
}

}  // namespace pcl_rg::bindings
