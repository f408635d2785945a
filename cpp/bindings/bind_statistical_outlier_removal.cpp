// Binding of pcl_rg::statistical_outlier_removal (see statistical_outlier_removal.hpp).
#include <array>
#include <optional>

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/statistical_outlier_removal.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_statistical_outlier_removal(py::module_& m) {
    py::class_<StatisticalOutlierRemovalParams>(m, "StatisticalOutlierRemovalParams")
        .def(py::init<>())
        .def_readwrite("mean_k", &StatisticalOutlierRemovalParams::mean_k)
        .def_readwrite("std_mul", &StatisticalOutlierRemovalParams::std_mul);

    m.def(
        "statistical_outlier_removal",
        [](const PointsArray& points, const StatisticalOutlierRemovalParams& params,
           const std::optional<py::array_t<double, py::array::c_style>>& origin) {
            std::array<double, 3> at{};
            if (origin) at = vector3(*origin, "origin");
            auto [inlier, result] = per_point<bool>(points, [&](const PointsView& view, bool* out) {
                return statistical_outlier_removal(view, params, out, origin ? &at : nullptr);
            });
            const auto n = static_cast<py::ssize_t>(result.mean_distance.size());
            return py::make_tuple(inlier, to_numpy(std::move(result.mean_distance), {n}),
                                  result.threshold,
                                  to_numpy(std::move(result.farthest_distance), {n}));
        },
        py::arg("points").noconvert(), py::arg("params"), py::arg("origin") = py::none(),
        "Core SOR: (inlier, mean_distance float32, threshold, farthest_distance float32); "
        "`origin`, the float32 frame's (default: the points' own). Use "
        "pcl_rg.statistical_outlier_removal.");
}

}  // namespace pcl_rg::bindings
