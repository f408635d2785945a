// The one way the bindings release the GIL: the core runs without it, and Ctrl-C (any
// Python signal handler) still reaches it through the core's interrupt polls.
#pragma once

#include <pybind11/pybind11.h>

#include <exception>
#include <optional>
#include <utility>

#include "pcl_rg/interrupt.hpp"

namespace pcl_rg::bindings {

namespace py = pybind11;

/// threading.main_thread().ident, set when the module is imported: only that thread
/// runs Python's signal handlers (PyErr_CheckSignals does nothing elsewhere), so only
/// there is a checker worth the GIL. A process forked from another thread keeps the old
/// value, and its calls are then simply not interruptible.
inline unsigned long main_thread_ident = 0;

/// The checker: runs the pending Python signal handlers. True when one raised, e.g.
/// KeyboardInterrupt from the default SIGINT handler; the exception stays pending for
/// the translator of Interrupted (setup_interrupts).
inline bool python_signal_raised() {
    py::gil_scoped_acquire gil;
    return PyErr_CheckSignals() != 0;
}

/// What every extension module does on import, before binding anything: Interrupted
/// (thrown by without_gil below) keeps the exception a signal handler raised, so Ctrl-C
/// gives KeyboardInterrupt and a handler's own exception comes through as it was raised;
/// and main_thread_ident is recorded. std::invalid_argument already maps to ValueError.
inline void setup_interrupts() {
    py::register_local_exception_translator([](std::exception_ptr error) {
        try {
            if (error) std::rethrow_exception(error);
        } catch (const Interrupted&) {
            if (!PyErr_Occurred()) PyErr_SetNone(PyExc_KeyboardInterrupt);
        }
    });
    main_thread_ident =
        py::module_::import("threading").attr("main_thread")().attr("ident").cast<unsigned long>();
}

/// Calls work() (the core) with the GIL released. Throws Interrupted when a signal
/// handler raised during the call, whatever work() did after that: a partial result
/// must not come back with an exception pending.
template <class Work>
void without_gil(Work&& work) {
    std::optional<InterruptScope> scope;
    if (PyThread_get_thread_ident() == main_thread_ident) scope.emplace(&python_signal_raised);
    try {
        py::gil_scoped_release release;
        std::forward<Work>(work)();
    } catch (...) {
        if (scope && scope->stop_requested()) throw Interrupted();
        throw;
    }
    if (scope && scope->stop_requested()) throw Interrupted();
}

}  // namespace pcl_rg::bindings
