// The core's large working arrays (UnfilledVector's, 4 MiB and up) come from here: a
// block freed by one call is kept for the next, so that a survey of many tiles does not
// pay the kernel to map and zero the same memory once per tile.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pcl_rg::block_cache {

/// The smallest request the cache serves; smaller ones go to operator new. 4 MiB, or
/// 64 KiB when the environment variable PCL_RG_BLOCK_CACHE_CHECK is set at the
/// process's first large allocation (read once, so that allocate and free agree).
std::size_t min_bytes() noexcept;

/// A block of at least `bytes` (>= min_bytes()), aligned to 2 MiB from 4 MiB up so that
/// the kernel can back it with huge pages. A kept block of a fitting size when there is
/// one (its contents are whatever its last user left: write before reading), or a larger
/// kept one when new memory would pass the peak, else new memory (when none can be had,
/// the kept blocks are freed and it is tried once more).
/// Throws std::bad_alloc.
void* take(std::size_t bytes);

/// Returns a block from take() (its size is known): kept for a later take(), or freed.
void give(void* p) noexcept;

/// Frees every kept block; returns their bytes.
std::size_t release() noexcept;

/// Sets the most bytes kept at once (0: keep nothing) and frees kept blocks above it;
/// returns the previous limit. The default is an eighth of the physical memory, or of
/// the cgroup's cap when lower (0 under AddressSanitizer, which must see every block
/// freed).
std::size_t set_limit(std::size_t bytes) noexcept;

struct Stats {
    std::size_t kept_bytes = 0;   // held for a later take()
    std::size_t live_bytes = 0;   // taken and not yet given back
    std::size_t peak_bytes = 0;   // the most bytes asked for at once (live + kept stay
                                  // within 1.25 x that, but for lent blocks' tails)
    std::size_t limit = 0;        // set_limit's
    std::uint64_t reused = 0;     // takes served by a kept block
    std::uint64_t allocated = 0;  // takes served by new memory
};
Stats stats() noexcept;

}  // namespace pcl_rg::block_cache
