// The pcl_rg._core extension: registers every binding; no logic of its own.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>

#include "bindings.hpp"
#include "pcl_rg/interrupt.hpp"
#include "without_gil.hpp"

PYBIND11_MODULE(_core, m) {
    m.doc() = "pcl_rg C++ core (internal; use the pcl_rg package).";
    // std::invalid_argument already maps to ValueError in pybind11.
    // Interrupted: the exception a signal handler raised is still pending (see
    // without_gil.hpp); keep it, so Ctrl-C gives KeyboardInterrupt and a handler's own
    // exception comes through as it was raised.
    pybind11::register_local_exception_translator([](std::exception_ptr error) {
        try {
            if (error) std::rethrow_exception(error);
        } catch (const pcl_rg::Interrupted&) {
            if (!PyErr_Occurred()) PyErr_SetNone(PyExc_KeyboardInterrupt);
        }
    });
    pcl_rg::bindings::main_thread_ident = pybind11::module_::import("threading")
                                              .attr("main_thread")()
                                              .attr("ident")
                                              .cast<unsigned long>();
    pcl_rg::bindings::bind_voxel_grid(m);
    pcl_rg::bindings::bind_statistical_outlier_removal(m);
    pcl_rg::bindings::bind_pcl_filters_baseline(m);
    pcl_rg::bindings::bind_lzf_codec(m);
    pcl_rg::bindings::bind_grid_ground(m);
    pcl_rg::bindings::bind_pcl_pmf_baseline(m);
    pcl_rg::bindings::bind_normals(m);
    pcl_rg::bindings::bind_region_growing(m);
    pcl_rg::bindings::bind_region_growing_pcl(m);
    pcl_rg::bindings::bind_tin_ground(m);
}
