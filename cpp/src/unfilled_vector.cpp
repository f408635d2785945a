// Huge-page advice for the core's large arrays (see unfilled_vector.hpp).
#include "pcl_rg/unfilled_vector.hpp"

#include <cstddef>
#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace pcl_rg {

void advise_huge_pages(void* p, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    // The threshold NumPy uses: below it an array spans too few huge pages to matter.
    constexpr std::size_t kMinBytes = std::size_t{4} << 20;
    constexpr std::uintptr_t kPage = 4096;
    if (p == nullptr || bytes < kMinBytes) return;
    // madvise wants a page-aligned start; the kernel then uses huge pages for the 2 MiB
    // aligned stretches inside. A refusal (no THP in this kernel) only leaves the small
    // pages, so the result is ignored. Once glibc serves such blocks from its heap (a
    // free raises its mmap threshold), the advice outlives the block on that range: a
    // few MiB of huge pages may stay with the process (6-10 MiB after three calls).
    const auto start = reinterpret_cast<std::uintptr_t>(p);
    const std::uintptr_t first = (start + kPage - 1) & ~(kPage - 1);
    const std::uintptr_t end = start + bytes;
    if (end > first) madvise(reinterpret_cast<void*>(first), end - first, MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

}  // namespace pcl_rg
