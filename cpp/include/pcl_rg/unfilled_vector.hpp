// Vectors that are not zero-filled when sized, for the large arrays of the core that a
// parallel loop writes in full right after.
#pragma once

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

}  // namespace pcl_rg
