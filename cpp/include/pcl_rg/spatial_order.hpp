// Orders that keep spatially close points close in memory, and the stable radix
// sort they are built on.
#pragma once

#include <cstdint>
#include <vector>

#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg {

/// Stable LSD radix sort of (key, id) pairs on the low `key_bits` bits of the keys,
/// parallel over contiguous chunks (stability keeps equal keys in id order).
void radix_sort_pairs(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& ids,
                      int key_bits);

/// Stable LSD radix sort of 64-bit values on bits [first_bit, last_bit) only; the
/// other bits ride along (pack a key above an index to sort indices by key).
void radix_sort_bits(UnfilledVector<std::uint64_t>& values, int first_bit, int last_bit);

/// Number of bits needed to write `value` (0 for 0).
inline int bit_width(std::uint64_t value) { return value == 0 ? 0 : 64 - __builtin_clzll(value); }

/// Permutation of [0, size) along a Morton (Z-order) curve of the row-major float32
/// x, y, z: queries and tree leaves then touch memory in order, which makes k-NN
/// searches on randomly ordered input several times faster.
std::vector<std::uint32_t> morton_order(const float* xyz, std::uint32_t size);

}  // namespace pcl_rg
