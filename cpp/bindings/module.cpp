// The pcl_rg._core extension: registers every binding; no logic of its own.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>

#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
    m.doc() = "pcl_rg C++ core (internal; use the pcl_rg package).";
    // std::invalid_argument already maps to ValueError in pybind11.
    pcl_rg::bindings::bind_voxel_grid(m);
    pcl_rg::bindings::bind_statistical_outlier_removal(m);
    pcl_rg::bindings::bind_pcl_filters_baseline(m);
    pcl_rg::bindings::bind_lzf_codec(m);
}
