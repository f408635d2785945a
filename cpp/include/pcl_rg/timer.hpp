// Stage clocks of the core's statistics (the stage times pcl_rg.collect_diagnostics shows).
#pragma once

#include <chrono>

namespace pcl_rg {

/// Wall-clock seconds since `start`, on the steady clock.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace pcl_rg
