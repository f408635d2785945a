// The block cache of block_cache.hpp.
//
// Why: on 10M points tin_ground's large arrays come to about 950 MiB and grid_ground's
// to 650 MiB. Freed, they went back to the kernel (glibc maps blocks this large on their
// own), and the next call had the kernel map and zero them again: a second of system
// time per tin_ground call, a sixth of its CPU time, on the 2-core hosts we measure on.
// Kept, a repeated call reuses them.
//
// How much is kept. A freed block is kept unless that would pass the limit (an eighth
// of the physical memory by default), in which case the blocks kept longest are freed
// first. When a take() finds no kept block that fits and must map new memory, kept
// blocks are freed first, the oldest first, until the live and kept bytes together stay
// within the most live bytes this process has ever had: so the cache never raises the
// process's peak memory, it only holds on to what an earlier call already used.
// release() and set_limit(0) give everything back.
//
// Results do not depend on it: UnfilledVector's contract is that every element is
// written before it is read, and with PCL_RG_BLOCK_CACHE_CHECK set every block is
// filled with 0xA5 bytes before it is handed out (and the cache serves blocks from
// 64 KiB up), which the tests use to show that no result reads what a block held.
#include "pcl_rg/block_cache.hpp"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <new>
#include <unordered_map>
#include <vector>

#include "pcl_rg/unfilled_vector.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <pthread.h>
#include <unistd.h>
#endif

#if defined(__SANITIZE_ADDRESS__)
#define PCL_RG_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PCL_RG_ADDRESS_SANITIZER 1
#endif
#endif

namespace pcl_rg::block_cache {

namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;
constexpr std::size_t kPage = 4096;
constexpr std::size_t kMinBytes = std::size_t{4} << 20;
constexpr std::size_t kCheckMinBytes = std::size_t{64} << 10;
constexpr unsigned char kCheckFill = 0xA5;
constexpr std::size_t kMaxKept = 64;  // kept blocks at once (a call uses about a dozen)

bool check_mode() noexcept {
    static const bool check = std::getenv("PCL_RG_BLOCK_CACHE_CHECK") != nullptr;
    return check;
}

// Blocks from 4 MiB up are whole 2 MiB pages, aligned, for the kernel's huge pages.
std::size_t alignment_of(std::size_t bytes) noexcept {
    return bytes >= kMinBytes ? kHugePage : kPage;
}

std::size_t rounded(std::size_t bytes) noexcept {
    const std::size_t align = alignment_of(bytes);
    return (bytes + align - 1) / align * align;
}

std::size_t default_limit() noexcept {
#if defined(PCL_RG_ADDRESS_SANITIZER)
    return 0;  // every block freed, so that a use after free is seen
#elif defined(_SC_PHYS_PAGES) && defined(_SC_PAGE_SIZE)
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    if (pages > 0 && page > 0)
        return static_cast<std::size_t>(pages) / 8 * static_cast<std::size_t>(page);
    return std::size_t{2} << 30;
#else
    return std::size_t{2} << 30;
#endif
}

struct Kept {
    void* block;
    std::size_t bytes;
    std::uint64_t age;  // when it was kept: the smallest goes first
};

struct State {
    std::mutex mutex;
    std::array<Kept, kMaxKept> kept{};
    std::size_t kept_count = 0;
    std::uint64_t clock = 0;
    std::unordered_map<void*, std::size_t> live;  // taken blocks and their true sizes
    Stats stats;

    State() { stats.limit = default_limit(); }

    // Drops the oldest kept block into `freed`.
    void drop_oldest(std::vector<Kept>& freed) {
        std::size_t oldest = 0;
        for (std::size_t k = 1; k < kept_count; ++k)
            if (kept[k].age < kept[oldest].age) oldest = k;
        freed.push_back(kept[oldest]);
        stats.kept_bytes -= kept[oldest].bytes;
        kept[oldest] = kept[--kept_count];
    }
};

// Never destroyed: vectors freed during the static destruction of other objects still
// find it. A fork() while another thread holds the mutex would leave it locked for good
// in the child, so fork waits for it and both sides release it (as glibc's malloc does).
State& state() {
    static State* const s = [] {
        auto* made = new State();
#if defined(__unix__) || defined(__APPLE__)
        pthread_atfork([] { state().mutex.lock(); }, [] { state().mutex.unlock(); },
                       [] { state().mutex.unlock(); });
#endif
        return made;
    }();
    return *s;
}

void free_all(const std::vector<Kept>& blocks) noexcept {
    for (const Kept& k : blocks) std::free(k.block);
}

}  // namespace

std::size_t min_bytes() noexcept { return check_mode() ? kCheckMinBytes : kMinBytes; }

void* take(std::size_t bytes) {
    const std::size_t size = rounded(bytes);
    if (size < bytes) throw std::bad_alloc();  // rounding wrapped around
    State& s = state();
    std::vector<Kept> freed;
    void* block = nullptr;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        // The smallest kept block that fits without wasting more than a quarter.
        const std::size_t slack = size / 4 + alignment_of(size);
        std::size_t best = s.kept_count;
        for (std::size_t k = 0; k < s.kept_count; ++k) {
            const std::size_t b = s.kept[k].bytes;
            if (b >= size && b - size <= slack && (best == s.kept_count || b < s.kept[best].bytes))
                best = k;
        }
        if (best < s.kept_count) {
            const Kept found = s.kept[best];
            s.live.emplace(found.block, found.bytes);  // may throw: nothing changed yet
            s.kept[best] = s.kept[--s.kept_count];
            s.stats.kept_bytes -= found.bytes;
            s.stats.live_bytes += found.bytes;
            ++s.stats.reused;
            block = found.block;
        } else {
            // New memory: first free kept blocks so that live + kept stays within the peak.
            const std::size_t live_after = s.stats.live_bytes + size;
            s.stats.peak_bytes = std::max(s.stats.peak_bytes, live_after);
            freed.reserve(s.kept_count);
            while (s.kept_count > 0 && live_after + s.stats.kept_bytes > s.stats.peak_bytes)
                s.drop_oldest(freed);
        }
    }
    free_all(freed);
    if (block == nullptr) {
        block = std::aligned_alloc(alignment_of(size), size);
        if (block == nullptr) throw std::bad_alloc();
        advise_huge_pages(block, size);
        std::lock_guard<std::mutex> lock(s.mutex);
        try {
            s.live.emplace(block, size);
        } catch (...) {
            std::free(block);
            throw;
        }
        s.stats.live_bytes += size;
        ++s.stats.allocated;
    }
    if (check_mode()) std::memset(block, kCheckFill, size);
    return block;
}

void give(void* p, std::size_t bytes) noexcept {
    if (p == nullptr) return;
    State& s = state();
    std::vector<Kept> freed;
    bool keep = false;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        const auto it = s.live.find(p);
        const std::size_t size = it != s.live.end() ? it->second : rounded(bytes);
        if (it != s.live.end()) s.live.erase(it);
        s.stats.live_bytes -= std::min(s.stats.live_bytes, size);
        if (size <= s.stats.limit) {
            try {
                freed.reserve(s.kept_count + 1);
                while (s.kept_count > 0 &&
                       (s.kept_count == kMaxKept || s.stats.kept_bytes + size > s.stats.limit))
                    s.drop_oldest(freed);
                s.kept[s.kept_count++] = Kept{p, size, ++s.clock};
                s.stats.kept_bytes += size;
                keep = true;
            } catch (const std::bad_alloc&) {
                // No room to list what to free: free this block instead of keeping it.
            }
        }
    }
    free_all(freed);
    if (!keep) std::free(p);
}

std::size_t release() noexcept {
    State& s = state();
    std::vector<Kept> freed;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        try {
            freed.reserve(s.kept_count);
        } catch (const std::bad_alloc&) {
            return 0;
        }
        while (s.kept_count > 0) s.drop_oldest(freed);
    }
    std::size_t bytes = 0;
    for (const Kept& k : freed) bytes += k.bytes;
    free_all(freed);
    return bytes;
}

std::size_t set_limit(std::size_t bytes) noexcept {
    State& s = state();
    std::vector<Kept> freed;
    std::size_t previous;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        previous = s.stats.limit;
        s.stats.limit = bytes;
        try {
            freed.reserve(s.kept_count);
            while (s.kept_count > 0 && s.stats.kept_bytes > bytes) s.drop_oldest(freed);
        } catch (const std::bad_alloc&) {
            // Nothing dropped: the blocks stay kept until the next give() or take().
        }
    }
    free_all(freed);
    return previous;
}

Stats stats() noexcept {
    State& s = state();
    std::lock_guard<std::mutex> lock(s.mutex);
    return s.stats;
}

}  // namespace pcl_rg::block_cache
