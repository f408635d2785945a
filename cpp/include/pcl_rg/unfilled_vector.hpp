// Vectors for the core's large arrays: not zero-filled when sized (a parallel loop
// writes them in full right after), on huge pages when the kernel gives them, and kept
// for the next call when freed (block_cache.hpp).
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "pcl_rg/block_cache.hpp"

namespace pcl_rg {

/// Asks the kernel to back [p, p + bytes) with transparent huge pages, where it allows
/// them only on request (Linux's "madvise" mode); below 4 MiB, or elsewhere, nothing.
/// The core's per-point arrays (tens to hundreds of MiB at 10M points) are filled right
/// after they are sized: with 4 KiB pages that is one page fault per 4 KiB, which cost the
/// ground filters a tenth of their time. NumPy advises its own large arrays the same way.
void advise_huge_pages(void* p, std::size_t bytes) noexcept;

/// std::allocator, but resize() default-initializes new elements (leaves integers, plain
/// structs and, in C++17, std::atomic unwritten) instead of zeroing them: for large
/// arrays that a parallel loop writes in full first, where a zero fill would be one more
/// serial pass, faulting in every fresh page on one core. Its blocks from 4 MiB up come
/// from the block cache (block_cache.hpp), on huge pages, kept between calls.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
    template <class U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    DefaultInitAllocator() = default;
    template <class U>
    DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
    T* allocate(std::size_t n) {
        if (n > std::size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
        if (n * sizeof(T) < block_cache::min_bytes()) return std::allocator<T>::allocate(n);
        return static_cast<T*>(block_cache::take(n * sizeof(T)));
    }
    void deallocate(T* p, std::size_t n) noexcept {
        if (n * sizeof(T) < block_cache::min_bytes())
            std::allocator<T>::deallocate(p, n);
        else
            block_cache::give(p);
    }
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
/// before reading it. Also the type of the per-point arrays that are filled with a value
/// (assign(n, v)), for the huge pages and the kept blocks of its allocations.
template <class T>
using UnfilledVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace pcl_rg
