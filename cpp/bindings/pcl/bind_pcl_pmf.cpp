// Binding of PCL's (Approximate)ProgressiveMorphologicalFilter (see cpp/pcl/pcl_pmf.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_pmf.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_pcl_pmf(py::module_& m) {
    using Params = ProgressiveMorphologicalFilterParams;
    py::class_<Params>(m, "ProgressiveMorphologicalFilterParams")
        .def(py::init<>())
        .def_readwrite("max_window_size", &Params::max_window_size)
        .def_readwrite("slope", &Params::slope)
        .def_readwrite("initial_distance", &Params::initial_distance)
        .def_readwrite("max_distance", &Params::max_distance)
        .def_readwrite("cell_size", &Params::cell_size)
        .def_readwrite("base", &Params::base)
        .def_readwrite("exponential", &Params::exponential)
        .def_readwrite("approximate", &Params::approximate);

    m.def(
        "progressive_morphological_filter",
        [](const PointsArray& points, const Params& params) {
            validate(params);  // before allocating, so bad parameters cost nothing
            return per_point<bool>(points, [&](const PointsView& view, bool* out) {
                pcl_progressive_morphological_filter(view, params, out);
            });
        },
        py::arg("points").noconvert(), py::arg("params"),
        "pcl::(Approximate)ProgressiveMorphologicalFilter: ground mask. Use "
        "pcl_rg.pcl.progressive_morphological_filter.");
}

}  // namespace pcl_rg::bindings
