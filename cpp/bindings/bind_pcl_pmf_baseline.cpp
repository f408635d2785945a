// Binding of PCL's ProgressiveMorphologicalFilter, for benchmarks only.
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/pcl_pmf_baseline.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_pcl_pmf_baseline(py::module_& m) {
    m.def(
        "pcl_progressive_morphological_filter",
        [](const PointsArray& points, const py::array_t<double, py::array::c_style>& origin,
           int max_window_size, double slope, double initial_distance, double max_distance,
           double cell_size, double base, bool exponential) {
            const PointsView view = points_view(points);
            const auto shift = vector3(origin, "origin");
            PclProgressiveMorphologicalFilterParams params;
            params.max_window_size = max_window_size;
            params.slope = slope;
            params.initial_distance = initial_distance;
            params.max_distance = max_distance;
            params.cell_size = cell_size;
            params.base = base;
            params.exponential = exponential;
            validate(params);
            py::array_t<bool> ground(static_cast<py::ssize_t>(view.size));
            bool* out = ground.mutable_data();
            without_gil([&] { pcl_progressive_morphological_filter(view, shift, params, out); });
            return ground;
        },
        py::arg("points").noconvert(), py::arg("origin").noconvert(), py::kw_only(),
        py::arg("max_window_size") = 20, py::arg("slope") = 1.0,
        py::arg("initial_distance") = 0.5, py::arg("max_distance") = 3.0,
        py::arg("cell_size") = 1.0, py::arg("base") = 2.0, py::arg("exponential") = true,
        "pcl::ProgressiveMorphologicalFilter on points - origin (float32); ground mask. "
        "Defaults are PCL's tutorial parameters. Benchmark baseline only.");
}

}  // namespace pcl_rg::bindings
