// Binding of pcl_rg::point_spacing (see cpp/include/pcl_rg/point_spacing.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/point_spacing.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_point_spacing(py::module_& m) {
    m.def(
        "point_spacing",
        [](const PointsArray& points) {
            const PointsView view = points_view(points);
            double spacing = 0.0;
            without_gil([&] { spacing = point_spacing(view); });
            return spacing;
        },
        py::arg("points").noconvert(),
        "Core mean XY point spacing (NaN when undefined). Use pcl_rg.point_spacing.");
}

}  // namespace pcl_rg::bindings
