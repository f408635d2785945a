// Orders that keep spatially close points close in memory, and the stable radix
// sort they are built on.
#pragma once

#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace pcl_rg {

/// std::allocator, but resize() default-initializes new elements (leaves integers, plain
/// structs and, in C++17, std::atomic unwritten) instead of zeroing them: for large
/// arrays that a parallel loop writes in full first, where a zero fill would be one more
/// serial pass, faulting in every fresh page on one core.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
    template <class U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    DefaultInitAllocator() = default;
    template <class U>
    DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
        ::new (static_cast<void*>(p)) U;
    }
    // noexcept when the construction is, so that a growing vector may move its elements.
    template <class U, class... Args>
    void construct(U* p, Args&&... args) noexcept(std::is_nothrow_constructible_v<U, Args...>) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

/// A vector whose new elements are not zeroed (DefaultInitAllocator): write each one
/// before reading it.
template <class T>
using UnfilledVector = std::vector<T, DefaultInitAllocator<T>>;

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
