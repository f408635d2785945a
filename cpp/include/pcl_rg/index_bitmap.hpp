// Sets of point indices as bitmaps, one bit per point: marking is O(1) and safe from
// many threads, and the marked indices come out in increasing order in linear time.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pcl_rg {

/// Sets bit s of a bitmap; atomic, so several threads may mark at once.
inline void mark(std::vector<std::uint64_t>& bits, std::uint32_t s) {
    __atomic_fetch_or(&bits[s >> 6], std::uint64_t{1} << (s & 63), __ATOMIC_RELAXED);
}

/// Clears bit s of a bitmap (not atomic: one thread at a time).
inline void unmark(std::vector<std::uint64_t>& bits, std::uint32_t s) {
    bits[s >> 6] &= ~(std::uint64_t{1} << (s & 63));
}

/// Whether bit s of a bitmap is set.
inline bool marked(const std::vector<std::uint64_t>& bits, std::uint32_t s) {
    return (bits[s >> 6] >> (s & 63) & 1u) != 0;
}

/// Appends the set bits' positions to `out` (a vector of std::uint32_t), in increasing
/// order, and clears them. Blocks of words are counted first (a cheap serial popcount of
/// the non-zero words), so that many positions (the first work lists of tin_ground,
/// millions) are written in parallel, each block at its own offset: the result is the
/// serial one.
template <class Indices>
void take_marked(std::vector<std::uint64_t>& bits, Indices& out) {
    constexpr std::size_t kBlockWords = 2048;      // 131072 positions per block
    constexpr std::size_t kParallelMarks = 65536;  // fewer: one thread, no region to wait for
    const std::size_t words = bits.size();
    const auto blocks = static_cast<std::ptrdiff_t>((words + kBlockWords - 1) / kBlockWords);
    std::vector<std::size_t> offset(static_cast<std::size_t>(blocks) + 1, out.size());
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        std::size_t marks = 0;
        const std::size_t end = std::min(words, (b + 1) * kBlockWords);
        for (std::size_t w = b * kBlockWords; w < end; ++w)
            if (bits[w] != 0)  // late bitmaps are sparse; the popcount is a libgcc call
                marks += static_cast<std::size_t>(__builtin_popcountll(bits[w]));
        offset[b + 1] = offset[b] + marks;
    }
    out.resize(offset[blocks]);
#pragma omp parallel for schedule(static) if (offset[blocks] - offset[0] > kParallelMarks)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        std::size_t k = offset[b];
        const std::size_t end = std::min(words, (b + 1) * kBlockWords);
        for (std::size_t w = b * kBlockWords; w < end; ++w) {
            for (std::uint64_t word = bits[w]; word != 0; word &= word - 1)
                out[k++] = static_cast<std::uint32_t>(w * 64 + __builtin_ctzll(word));
            bits[w] = 0;
        }
    }
}

/// The positions s in [0, n) with keep(s), in increasing order: size(m) is told how many
/// there are, then put(k, s) receives the k-th. Fixed blocks of positions are counted,
/// then each is filled at its offset, in parallel for large n: the same output whatever
/// the threads.
template <class Keep, class Size, class Put>
void keep_in_order(std::size_t n, Keep keep, Size size, Put put) {
    constexpr std::size_t kBlock = 65536;
    const auto blocks = static_cast<std::ptrdiff_t>((n + kBlock - 1) / kBlock);
    std::vector<std::size_t> offset(static_cast<std::size_t>(blocks) + 1, 0);
#pragma omp parallel for schedule(static) if (blocks > 1)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        std::size_t kept = 0;
        for (std::size_t s = b * kBlock; s < std::min(n, (b + 1) * kBlock); ++s) kept += keep(s);
        offset[b + 1] = kept;
    }
    for (std::ptrdiff_t b = 0; b < blocks; ++b) offset[b + 1] += offset[b];
    size(offset[blocks]);
#pragma omp parallel for schedule(static) if (blocks > 1)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        std::size_t k = offset[b];
        for (std::size_t s = b * kBlock; s < std::min(n, (b + 1) * kBlock); ++s)
            if (keep(s)) put(k++, s);
    }
}

/// The distinct point indices `indices` (each < n) in increasing order: through a bitmap
/// of the n points when they are not very few (linear), else by sorting.
inline std::vector<std::uint32_t> in_index_order(std::vector<std::uint32_t> indices,
                                                 std::size_t n) {
    if (indices.size() < n / 1024) {
        std::sort(indices.begin(), indices.end());
        return indices;
    }
    std::vector<std::uint64_t> bits((n + 63) / 64, 0);
    for (const std::uint32_t i : indices) bits[i >> 6] |= std::uint64_t{1} << (i & 63);
    indices.clear();
    take_marked(bits, indices);
    return indices;
}

}  // namespace pcl_rg
