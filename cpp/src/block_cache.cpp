// The block cache of block_cache.hpp.
//
// Why: on 10M points tin_ground's large arrays come to about 1.3 GB at their peak and
// grid_ground's to 0.85 GB. Freed, they went back to the kernel (glibc maps blocks this large on
// their own), and the next call had the kernel map and zero them again: a second of system time per
// tin_ground call, a sixth of its CPU time, on the 2-core hosts we measure on. Kept, a repeated
// call reuses them.
//
// How much is kept. The peak is the most bytes the core's arrays have asked for at once
// (each rounded to its alignment). Live and kept blocks together stay within a quarter more
// than that peak (with_room), except for the unused tails of larger blocks lent to smaller
// requests while those are live: so between calls the cache holds at most 1.25 x the
// most ever asked for at once, and a freed block is not kept beyond that or beyond the
// limit (an eighth of the physical memory, or of a cgroup's cap, by default); the blocks
// kept longest go first. When a take() finds no kept block that fits, and new memory
// would pass the peak, it uses a larger kept block rather than drop kept blocks and map
// new memory: a repeated call then maps nothing. Before the peak counted what was asked
// rather than what was taken, a lent block's tail raised it, and with it what could be
// kept: grid_ground on 12 tiles of 2-10M points kept 884 MiB for a peak of 666 MiB
// asked (now 812 MiB, 40 blocks mapped instead of 36; 98 before lending), and calls that
// each asked for one more small array than the last grew it without bound, up to the
// limit. (Other memory taken between calls, a NumPy array or the next tile read, comes on
// top of the kept blocks: pcl_rg.batch gives them back after each task.) When new memory
// cannot be had, the kept blocks go back and the allocation is tried once more. release()
// and set_limit(0) give everything back.
//
// Results do not depend on it: UnfilledVector's contract is that every element is
// written before it is read, and with PCL_RG_BLOCK_CACHE_CHECK set the bytes asked for
// are filled with 0xA5 before a block is handed out (and the cache serves blocks from
// 64 KiB up), which the tests use to show that no result reads what a block held.
#include "pcl_rg/block_cache.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <new>
#include <unordered_map>

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

// What live + kept blocks may come to for a peak of `asked` bytes: a quarter more, the
// most a fitting block may waste, so that blocks lent to smaller requests (whose tails the
// peak does not count) can still be kept for the next call.
std::size_t with_room(std::size_t asked) noexcept {
    return asked > std::numeric_limits<std::size_t>::max() / 5 * 4 ? asked : asked + asked / 4;
}

std::size_t rounded(std::size_t bytes) noexcept {
    const std::size_t align = alignment_of(bytes);
    return (bytes + align - 1) / align * align;
}

// The memory this process may use: the physical memory, or less where the cgroup v2
// root it sees caps it (a container's own); 0 when neither is known. (A cap on a cgroup
// below the root, or a cgroup v1 cap, is not read.)
std::size_t usable_memory() noexcept {
    std::size_t bytes = 0;
#if defined(_SC_PHYS_PAGES) && defined(_SC_PAGE_SIZE)
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    if (pages > 0 && page > 0)
        bytes = static_cast<std::size_t>(pages) * static_cast<std::size_t>(page);
#endif
#if defined(__linux__)
    if (std::FILE* f = std::fopen("/sys/fs/cgroup/memory.max", "r")) {
        unsigned long long cap = 0;
        if (std::fscanf(f, "%llu", &cap) == 1 && cap > 0 && (bytes == 0 || cap < bytes))
            bytes = static_cast<std::size_t>(cap);  // "max" (no cap) reads as no number
        std::fclose(f);
    }
#endif
    return bytes;
}

std::size_t default_limit() noexcept {
#if defined(PCL_RG_ADDRESS_SANITIZER)
    return 0;  // every block freed, so that a use after free is seen
#else
    const std::size_t usable = usable_memory();
    return usable > 0 ? usable / 8 : std::size_t{2} << 30;
#endif
}

struct Kept {
    void* block;
    std::size_t bytes;
    std::uint64_t age;  // when it was kept: the smallest goes first
};

// Blocks dropped under the mutex, freed after it: a list that never allocates, so that
// nothing here fails for want of memory.
struct Dropped {
    std::array<Kept, kMaxKept> blocks{};
    std::size_t count = 0;

    std::size_t bytes() const noexcept {
        std::size_t total = 0;
        for (std::size_t k = 0; k < count; ++k) total += blocks[k].bytes;
        return total;
    }
    void free_all() noexcept {
        for (std::size_t k = 0; k < count; ++k) std::free(blocks[k].block);
        count = 0;
    }
};

struct State {
    std::mutex mutex;
    std::array<Kept, kMaxKept> kept{};
    std::size_t kept_count = 0;
    std::uint64_t clock = 0;
    // Taken blocks: their true sizes, and the sizes asked for (rounded), less when a
    // larger kept block was lent.
    struct Taken {
        std::size_t bytes, asked;
    };
    std::unordered_map<void*, Taken> live;
    std::size_t asked_bytes = 0;    // of the live blocks, as asked for: what the peak counts
    std::size_t pending_bytes = 0;  // counted in asked_bytes and live_bytes, not yet mapped
    Stats stats;

    State() { stats.limit = default_limit(); }

    void drop_oldest(Dropped& dropped) noexcept {
        std::size_t oldest = 0;
        for (std::size_t k = 1; k < kept_count; ++k)
            if (kept[k].age < kept[oldest].age) oldest = k;
        dropped.blocks[dropped.count++] = kept[oldest];
        stats.kept_bytes -= kept[oldest].bytes;
        kept[oldest] = kept[--kept_count];
    }
    // Drops the oldest kept blocks while `too_many()` holds.
    template <class Predicate>
    void drop_while(Dropped& dropped, Predicate too_many) noexcept {
        while (kept_count > 0 && too_many()) drop_oldest(dropped);
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

// New memory for a block of `size` bytes, or nullptr.
void* map_block(std::size_t size) noexcept {
    void* block = std::aligned_alloc(alignment_of(size), size);
    if (block != nullptr) advise_huge_pages(block, size);
    return block;
}

}  // namespace

std::size_t min_bytes() noexcept { return check_mode() ? kCheckMinBytes : kMinBytes; }

void* take(std::size_t bytes) {
    const std::size_t size = rounded(bytes);
    if (size < bytes) throw std::bad_alloc();  // rounding wrapped around
    State& s = state();
    Dropped dropped;
    void* block = nullptr;
    std::size_t bound = 0;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        // The smallest kept block that holds `size` bytes and wastes at most `slack`.
        const auto smallest_holding = [&](std::size_t slack) {
            std::size_t best = s.kept_count;
            for (std::size_t k = 0; k < s.kept_count; ++k) {
                const std::size_t b = s.kept[k].bytes;
                if (b >= size && b - size <= slack &&
                    (best == s.kept_count || b < s.kept[best].bytes))
                    best = k;
            }
            return best;
        };
        // What live + kept may come to if this take maps new memory: the most bytes asked
        // for at once, this block's included, but not another thread's pending ones, which
        // may yet fail. Asked, not taken: a lent block's unused tail would otherwise raise
        // the bound for the next take, and each call could lend and map more than the last.
        bound = std::max(s.stats.peak_bytes, s.asked_bytes - s.pending_bytes + size);
        const std::size_t room = with_room(bound);
        // One that fits, wasting at most a quarter; failing that, when new memory would
        // pass that bound, any that holds it (the room above the bound does not make new
        // memory preferable to a lent block: with the room as this test, tin_ground's
        // second call mapped a block more than its first). A call asks for its arrays in
        // its own order, and a small one asked for while the block of its size is still
        // live would otherwise drop the oldest kept block, which may be the largest:
        // grid_ground mapped and zeroed 280 MiB afresh per call on 10M points (then 0),
        // and after a pause of a second or more, when the host had taken the freed pages
        // back, that cost 0.4-0.5 s of system time per call.
        std::size_t best = smallest_holding(size / 4 + alignment_of(size));
        if (best == s.kept_count && s.stats.live_bytes + size + s.stats.kept_bytes > bound)
            best = smallest_holding(std::numeric_limits<std::size_t>::max());
        if (best < s.kept_count) {
            const Kept found = s.kept[best];
            s.live.emplace(found.block, State::Taken{found.bytes, size});  // may throw first
            s.kept[best] = s.kept[--s.kept_count];
            s.stats.kept_bytes -= found.bytes;
            s.stats.live_bytes += found.bytes;
            s.asked_bytes += size;
            s.stats.peak_bytes = std::max(s.stats.peak_bytes, s.asked_bytes - s.pending_bytes);
            ++s.stats.reused;
            block = found.block;
        } else {
            // New memory, counted live at once (so that a take in another thread meanwhile
            // sees it) and pending until it is there: first drop kept blocks so that live +
            // kept stays within the room above the bound.
            s.stats.live_bytes += size;
            s.asked_bytes += size;
            s.pending_bytes += size;
            s.drop_while(dropped, [&] { return s.stats.live_bytes + s.stats.kept_bytes > room; });
        }
    }
    dropped.free_all();
    if (block == nullptr) {
        block = map_block(size);
        if (block == nullptr) {
            // Short of memory: what is kept goes back first, then one more try.
            release();
            block = map_block(size);
        }
        std::lock_guard<std::mutex> lock(s.mutex);
        if (block != nullptr) {
            try {
                s.live.emplace(block, State::Taken{size, size});
            } catch (...) {
                std::free(block);
                block = nullptr;
            }
        }
        s.pending_bytes -= size;
        if (block == nullptr) {
            s.stats.live_bytes -= size;
            s.asked_bytes -= size;
            throw std::bad_alloc();
        }
        // The bound, not what is asked now: kept blocks were dropped down to its room, and
        // a block given back by another thread meanwhile must not leave more kept than that
        // (it did, when the peak was taken from the live bytes here).
        s.stats.peak_bytes = std::max(s.stats.peak_bytes, bound);
        ++s.stats.allocated;
    }
    if (check_mode()) std::memset(block, kCheckFill, size);
    return block;
}

void give(void* p) noexcept {
    if (p == nullptr) return;
    State& s = state();
    Dropped dropped;
    bool keep = false;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        const auto it = s.live.find(p);
        if (it != s.live.end()) {  // else not take()'s (a bug elsewhere): freed, not kept
            const std::size_t size = it->second.bytes;
            s.asked_bytes -= it->second.asked;
            s.live.erase(it);
            s.stats.live_bytes -= size;
            // Kept within the limit, and with live + kept within the room above the peak,
            // as take() leaves them when it maps: only the tails of lent blocks still live
            // can pass it, and a lent block that comes back is not kept beyond it. (Another
            // thread's pending bytes are not in the peak yet: not counted.)
            const std::size_t others = s.stats.live_bytes - s.pending_bytes;
            const std::size_t room = with_room(s.stats.peak_bytes);
            const auto too_many = [&] {
                return s.kept_count == kMaxKept || s.stats.kept_bytes + size > s.stats.limit ||
                       others + s.stats.kept_bytes + size > room;
            };
            if (size <= s.stats.limit && others + size <= room) {
                s.drop_while(dropped, too_many);
                s.kept[s.kept_count++] = Kept{p, size, ++s.clock};
                s.stats.kept_bytes += size;
                keep = true;
            }
        }
    }
    dropped.free_all();
    if (!keep) std::free(p);
}

std::size_t release() noexcept {
    State& s = state();
    Dropped dropped;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.drop_while(dropped, [] { return true; });
    }
    const std::size_t bytes = dropped.bytes();
    dropped.free_all();
    return bytes;
}

std::size_t set_limit(std::size_t bytes) noexcept {
    State& s = state();
    Dropped dropped;
    std::size_t previous;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        previous = s.stats.limit;
        s.stats.limit = bytes;
        s.drop_while(dropped, [&] { return s.stats.kept_bytes > bytes; });
    }
    dropped.free_all();
    return previous;
}

Stats stats() noexcept {
    State& s = state();
    std::lock_guard<std::mutex> lock(s.mutex);
    return s.stats;
}

}  // namespace pcl_rg::block_cache
