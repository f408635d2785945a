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

/// Whether bit s of a bitmap is set.
inline bool marked(const std::vector<std::uint64_t>& bits, std::uint32_t s) {
    return (bits[s >> 6] >> (s & 63) & 1u) != 0;
}

/// Appends the set bits' positions to `out`, in increasing order, and clears them.
inline void take_marked(std::vector<std::uint64_t>& bits, std::vector<std::uint32_t>& out) {
    for (std::size_t w = 0; w < bits.size(); ++w) {
        for (std::uint64_t word = bits[w]; word != 0; word &= word - 1)
            out.push_back(static_cast<std::uint32_t>(w * 64 + __builtin_ctzll(word)));
        bits[w] = 0;
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
