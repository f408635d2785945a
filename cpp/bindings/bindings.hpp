// One bind_<stem>() per algorithm; module.cpp calls them all.
#pragma once

#include <pybind11/pybind11.h>

namespace pcl_rg::bindings {

void bind_voxel_grid(pybind11::module_& m);
void bind_statistical_outlier_removal(pybind11::module_& m);
void bind_lzf_codec(pybind11::module_& m);
void bind_grid_ground(pybind11::module_& m);
void bind_normals(pybind11::module_& m);
void bind_region_growing(pybind11::module_& m);
void bind_convex_segmentation(pybind11::module_& m);
void bind_tin_ground(pybind11::module_& m);
void bind_delaunay(pybind11::module_& m);
void bind_point_spacing(pybind11::module_& m);
void bind_points(pybind11::module_& m);
void bind_block_cache(pybind11::module_& m);

}  // namespace pcl_rg::bindings
