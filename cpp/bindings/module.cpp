// The pcl_rg._core extension: registers every binding; no logic of its own.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "without_gil.hpp"

PYBIND11_MODULE(_core, m) {
    m.doc() = "pcl_rg C++ core (internal; use the pcl_rg package).";
    pcl_rg::bindings::setup_interrupts();
    pcl_rg::bindings::bind_voxel_grid(m);
    pcl_rg::bindings::bind_statistical_outlier_removal(m);
    pcl_rg::bindings::bind_lzf_codec(m);
    pcl_rg::bindings::bind_grid_ground(m);
    pcl_rg::bindings::bind_normals(m);
    pcl_rg::bindings::bind_region_growing(m);
    pcl_rg::bindings::bind_convex_segmentation(m);
    pcl_rg::bindings::bind_tin_ground(m);
    pcl_rg::bindings::bind_delaunay(m);
    pcl_rg::bindings::bind_point_spacing(m);
    pcl_rg::bindings::bind_points(m);
    pcl_rg::bindings::bind_block_cache(m);
}
