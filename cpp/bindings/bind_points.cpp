// Binding of the points' float32 frame (see cpp/include/pcl_rg/points.hpp).
#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/points.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_points(py::module_& m) {
    m.def(
        "rows_within_float32_reach",
        [](const PointsArray& points) {
            const PointsView view = points_view(points);
            std::vector<std::int64_t> rows;
            without_gil([&] {
                for (const std::size_t row : rows_within_float32_reach(view))
                    rows.push_back(static_cast<std::int64_t>(row));
            });
            const auto n = static_cast<py::ssize_t>(rows.size());
            return to_numpy(std::move(rows), {n});
        },
        py::arg("points").noconvert(),
        "Core: the rows within float32's reach of the points' local origin, any number far.");
    m.def("max_far_points", &max_far_points, py::arg("n"),
          "Core: how many far points a k-nearest-neighbour step leaves out of n.");
}

}  // namespace pcl_rg::bindings
