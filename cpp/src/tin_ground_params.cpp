// tin_ground's parameters (tin_ground.hpp): the range check, and the lengths left unset
// taken from the point spacing. Part of tin_ground, apart from its steps (tin_ground.cpp).
#include <algorithm>
#include <optional>

#include "pcl_rg/check.hpp"
#include "pcl_rg/final_pass.hpp"
#include "pcl_rg/tin_ground.hpp"

namespace pcl_rg {

void validate(const TinGroundParams& params) {
    check::real("max_building_size", params.max_building_size, check::positive());
    check::real("max_terrain_angle", params.max_terrain_angle,
                {std::nullopt, 0.0, std::nullopt, 90.0});
    check::real("iteration_angle", params.iteration_angle, {std::nullopt, 0.0, 90.0, std::nullopt});
    check::real("iteration_distance", params.iteration_distance, check::positive());
    check::real("reduce_angle_edge", params.reduce_angle_edge, check::positive());
    if (params.stop_edge) check::real("stop_edge", *params.stop_edge, check::positive());
    if (params.near_vertex_distance)
        check::real("near_vertex_distance", *params.near_vertex_distance, check::non_negative());
    if (params.seed_cell) check::real("seed_cell", *params.seed_cell, check::non_negative());
    check::real("seed_tolerance", params.seed_tolerance, check::non_negative());
    check::real("outlier_depth", params.outlier_depth, check::non_negative());
    check::integer("opening_rank", params.opening_rank,
                   {1.0, std::nullopt, static_cast<double>(kTinMaxOpeningRank), std::nullopt});
    if (params.densify_cell)
        check::real("densify_cell", *params.densify_cell, check::non_negative());
    validate(final_pass_params(params));
}

TinGroundParams with_spacing(const TinGroundParams& params, double spacing) {
    TinGroundParams resolved = params;
    const auto fill = [](std::optional<double>& length, double value) {
        if (!length) length = value;
    };
    fill(resolved.stop_edge, std::min(kTinStopEdgeCap, kTinStopEdgePerSpacing * spacing));
    fill(resolved.near_vertex_distance,
         std::min(kTinNearVertexCap, kTinNearVertexPerSpacing * spacing));
    fill(resolved.seed_cell, tin_lattice_length(kTinSeedCellCap, kTinSeedCellPerSpacing, spacing));
    fill(resolved.final_cell,
         tin_lattice_length(kTinFinalCellCap, kTinFinalCellPerSpacing, spacing));
    fill(resolved.densify_cell,
         tin_lattice_length(kTinDensifyCellCap, kTinDensifyCellPerSpacing, spacing));
    return resolved;
}

}  // namespace pcl_rg
