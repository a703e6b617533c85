// SPDX-License-Identifier: Apache-2.0
// Vectors that size without writing. std::vector::resize(n) value-initialises: for a trivial
// type it zeroes every element. The binary tree's 2n - 1 node slots (bvh.hpp) are sized so that
// subtrees built on other threads can start at fixed slots; most slots are never used, and
// zeroing them would fault in pages nothing reads. With this allocator resize(n)
// default-initialises instead: a trivial element is left as it is, and its page is not touched
// until the element is written.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace phong {

template <class T>
struct UninitialisedAllocator : std::allocator<T> {
    using value_type = T;
    template <class U>
    struct rebind {
        using other = UninitialisedAllocator<U>;
    };
    UninitialisedAllocator() noexcept = default;
    template <class U>
    UninitialisedAllocator(const UninitialisedAllocator<U>&) noexcept {}

    template <class U>
    void construct(U* p) noexcept {
        ::new (static_cast<void*>(p)) U;  // default-initialisation: nothing for a trivial U
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

// A vector whose resize() leaves new trivial elements unwritten.
template <class T>
using UninitialisedVector = std::vector<T, UninitialisedAllocator<T>>;

// Room for one T, constructed later by emplace() (and never destroyed: T must not need it).
// For arrays of objects made per use: GCC zero-fills an array of std::optional<T> whole, which
// for a ray packet's searches and prefilters was two `rep stos` of 1.6 KB a packet
// (benchmarks/README.md, issue 25).
template <class T>
union Deferred {
    static_assert(std::is_trivially_destructible_v<T>);
    Deferred() {}
    T value;

    template <class... Args>
    void emplace(Args&&... args) {
        ::new (static_cast<void*>(&value)) T(std::forward<Args>(args)...);
    }
    T* operator->() { return &value; }
    T& operator*() { return value; }
};

// Room for N T's in a row, each constructed by emplace(k, ...) before it is read (and never
// destroyed). A T with default member initialisers (Vec3, Ray, RGB) makes `T items[N]` a
// zero-fill: a packet's eight rays and colours were two `rep stos` a packet, ~1 % of a
// render's time (benchmarks/README.md, issue 25).
template <class T, size_t N>
union DeferredArray {
    static_assert(std::is_trivially_destructible_v<T>);
    DeferredArray() {}
    T items[N];

    template <class... Args>
    void emplace(size_t k, Args&&... args) {
        ::new (static_cast<void*>(&items[k])) T(std::forward<Args>(args)...);
    }
    T* data() { return items; }
    const T& operator[](size_t k) const { return items[k]; }
};

}  // namespace phong
