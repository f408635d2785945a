// Binding of the block cache (block_cache.hpp), for pcl_rg.release_memory and
// pcl_rg.set_memory_cache_limit.
#include <pybind11/stl.h>

#include <cstdint>
#include <map>
#include <string>

#include "bindings.hpp"
#include "pcl_rg/block_cache.hpp"
#include "without_gil.hpp"

namespace pcl_rg::bindings {

void bind_block_cache(pybind11::module_& m) {
    m.def(
        "block_cache_release",
        [] {
            std::size_t bytes = 0;  // freeing a gigabyte takes a tenth of a second
            without_gil([&] { bytes = block_cache::release(); });
            return bytes;
        },
        "Free every kept block; return their bytes.");
    m.def(
        "block_cache_set_limit",
        [](std::size_t bytes) {
            std::size_t previous = 0;
            without_gil([&] { previous = block_cache::set_limit(bytes); });
            return previous;
        },
        pybind11::arg("bytes"), "Set the most bytes kept at once; return the previous limit.");
    m.def(
        "block_cache_stats",
        [] {
            const block_cache::Stats s = block_cache::stats();
            return std::map<std::string, std::uint64_t>{{"kept_bytes", s.kept_bytes},
                                                        {"live_bytes", s.live_bytes},
                                                        {"peak_bytes", s.peak_bytes},
                                                        {"limit", s.limit},
                                                        {"reused", s.reused},
                                                        {"allocated", s.allocated},
                                                        {"min_bytes", block_cache::min_bytes()}};
        },
        "The cache's counters: kept, live and peak bytes, limit, blocks reused and allocated, "
        "and the smallest block it serves.");
}

}  // namespace pcl_rg::bindings
