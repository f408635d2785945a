// One bind_<family>() per file of cpp/pcl/; module.cpp calls them all.
#pragma once

#include <pybind11/pybind11.h>

namespace pcl_rg::bindings {

void bind_pcl_filters(pybind11::module_& m);
void bind_pcl_pmf(pybind11::module_& m);
void bind_pcl_lccp(pybind11::module_& m);
void bind_pcl_region_growing(pybind11::module_& m);

}  // namespace pcl_rg::bindings
