// The pcl_rg._pcl extension: PCL's own classes (cpp/pcl/); no logic of its own.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "without_gil.hpp"

PYBIND11_MODULE(_pcl, m) {
    m.doc() = "PCL's own classes on pcl_rg's arrays (internal; use pcl_rg.pcl).";
    pcl_rg::bindings::setup_interrupts();
    // VoxelGridParams and StatisticalOutlierRemovalParams are registered once, by _core;
    // importing it makes them known to this module's functions.
    pybind11::module_::import("pcl_rg._core");
    pcl_rg::bindings::bind_pcl_filters(m);
    pcl_rg::bindings::bind_pcl_pmf(m);
    pcl_rg::bindings::bind_pcl_lccp(m);
    pcl_rg::bindings::bind_pcl_region_growing(m);
}
