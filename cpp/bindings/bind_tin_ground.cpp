// Binding of pcl_rg::tin_ground (see tin_ground.hpp).
#include <pybind11/stl.h>  // std::optional lengths: None when unset

#include "bindings.hpp"
#include "numpy_io.hpp"
#include "pcl_rg/tin_ground.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_tin_ground(py::module_& m) {
    py::class_<TinGroundParams>(m, "TinGroundParams")
        .def(py::init<>())
        .def_readwrite("max_building_size", &TinGroundParams::max_building_size)
        .def_readwrite("max_terrain_angle", &TinGroundParams::max_terrain_angle)
        .def_readwrite("iteration_angle", &TinGroundParams::iteration_angle)
        .def_readwrite("iteration_distance", &TinGroundParams::iteration_distance)
        .def_readwrite("reduce_angle_edge", &TinGroundParams::reduce_angle_edge)
        .def_readwrite("stop_edge", &TinGroundParams::stop_edge)
        .def_readwrite("near_vertex_distance", &TinGroundParams::near_vertex_distance)
        .def_readwrite("seed_cell", &TinGroundParams::seed_cell)
        .def_readwrite("seed_tolerance", &TinGroundParams::seed_tolerance)
        .def_readwrite("outlier_depth", &TinGroundParams::outlier_depth)
        .def_readwrite("opening_rank", &TinGroundParams::opening_rank)
        .def_readwrite("border_vertices", &TinGroundParams::border_vertices)
        .def_readwrite("final_cell", &TinGroundParams::final_cell)
        .def_readwrite("final_above", &TinGroundParams::final_above)
        .def_readwrite("final_below", &TinGroundParams::final_below)
        .def_readwrite("final_slope", &TinGroundParams::final_slope)
        .def_readwrite("final_low_depth", &TinGroundParams::final_low_depth)
        .def_readwrite("densify_cell", &TinGroundParams::densify_cell);

    m.def(
        "tin_ground",
        [](const PointsArray& points, const TinGroundParams& params) {
            auto [ground, stats] = per_point<bool>(points, [&](const PointsView& view, bool* out) {
                return tin_ground(view, params, out);
            });
            py::dict info;
            info["seeds"] = stats.seeds;
            info["iterations"] = stats.iterations;
            info["tin_vertices"] = stats.tin_vertices;
            info["tests"] = stats.tests;
            info["prepare_seconds"] = stats.prepare_seconds;
            info["triangulation_seconds"] = stats.triangulation_seconds;
            info["classification_seconds"] = stats.classification_seconds;
            info["point_spacing"] = stats.point_spacing;
            info["stop_edge"] = stats.stop_edge;
            info["near_vertex_distance"] = stats.near_vertex_distance;
            info["seed_cell"] = stats.seed_cell;
            info["final_cell"] = stats.final_cell;
            info["densify_cell"] = stats.densify_cell;
            return py::make_tuple(ground, info);
        },
        py::arg("points").noconvert(), py::arg("params"),
        "Core progressive TIN densification: (ground mask, stats dict). Use pcl_rg.tin_ground.");
}

}  // namespace pcl_rg::bindings
