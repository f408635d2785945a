// Binding of pcl_rg::grid_ground (see cpp/include/pcl_rg/grid_ground.hpp).
#include <pybind11/stl.h>  // std::optional cell_size: None when unset

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/grid_ground.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_grid_ground(py::module_& m) {
    py::class_<GridGroundParams>(m, "GridGroundParams")
        .def(py::init<>())
        // (x, y) tuples, as the dataclass holds them.
        .def_property(
            "block_size",
            [](const GridGroundParams& p) {
                return py::make_tuple(p.block_size[0], p.block_size[1]);
            },
            [](GridGroundParams& p, const std::array<double, 2>& v) { p.block_size = v; })
        .def_property(
            "cell_size",
            [](const GridGroundParams& p) -> py::object {
                if (!p.cell_size) return py::none();  // unset: from the point spacing
                return py::make_tuple((*p.cell_size)[0], (*p.cell_size)[1]);
            },
            [](GridGroundParams& p, const std::optional<std::array<double, 2>>& v) {
                p.cell_size = v;
            })
        .def_readwrite("slope", &GridGroundParams::slope)
        .def_readwrite("height_tolerance", &GridGroundParams::height_tolerance)
        .def_readwrite("min_seed_component", &GridGroundParams::min_seed_component)
        .def_readwrite("outlier_depth", &GridGroundParams::outlier_depth)
        .def_readwrite("grow_across_blocks", &GridGroundParams::grow_across_blocks)
        .def_readwrite("filter_passes", &GridGroundParams::filter_passes)
        .def_readwrite("filter_slope", &GridGroundParams::filter_slope)
        .def_readwrite("filter_tolerance", &GridGroundParams::filter_tolerance)
        .def_readwrite("final_cell", &GridGroundParams::final_cell)
        .def_readwrite("final_above", &GridGroundParams::final_above)
        .def_readwrite("final_below", &GridGroundParams::final_below)
        .def_readwrite("final_slope", &GridGroundParams::final_slope)
        .def_readwrite("final_low_depth", &GridGroundParams::final_low_depth)
        .def_readwrite("final_passes", &GridGroundParams::final_passes);

    m.def(
        "grid_ground",
        [](const PointsArray& points, const GridGroundParams& params) {
            validate(params);  // before allocating, so bad parameters cost nothing
            GridGroundStats stats;
            py::array_t<bool> ground = per_point<bool>(
                points,
                [&](const PointsView& view, bool* out) { grid_ground(view, params, out, &stats); });
            py::dict info;
            info["point_spacing"] = stats.point_spacing;
            info["cell_size"] = py::make_tuple(stats.cell_size[0], stats.cell_size[1]);
            info["filter_passes_run"] = stats.filter_passes_run;
            info["final_passes_run"] = stats.final_passes_run;
            info["prepare_seconds"] = stats.prepare_seconds;
            info["growth_seconds"] = stats.growth_seconds;
            info["final_pass_seconds"] = stats.final_pass_seconds;
            return py::make_tuple(ground, info);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core grid region-growing ground filter: (ground mask, stats dict). Use "
        "pcl_rg.grid_ground.");
}

}  // namespace pcl_rg::bindings
