// SPDX-License-Identifier: Apache-2.0
// Transparent huge pages for the build's large arrays (the primitive boxes, the tree's nodes,
// the leaf-order copies). A scene build writes ~130 MiB of fresh memory at 1M triangles: in
// 4 KiB pages that is ~33,000 page faults, each taking the kernel's locks, which two build
// threads then queue on. Where THP is in "madvise" mode (Debian's default) a region asked for
// faults in 2 MiB at a time: S2's C++ build 0.49 -> 0.45 s at one thread, 0.31 -> 0.26-0.30 s at
// two (benchmarks/README.md, "Issue 25.5"). Only memory that is written becomes resident, so
// capacity reserved and never written stays free; a region partly written holds at most one
// more 2 MiB page than it would in small pages.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace phong {

// Arrays below this size gain nothing worth a system call.
constexpr size_t kHugePageMinBytes = size_t(4) << 20;

// Asks for huge pages over the whole 2 MiB pages inside [p, p + bytes), before they are first
// written. A hint: where the kernel has no THP (or it is off) nothing changes.
inline void advise_huge_pages([[maybe_unused]] const void* p, [[maybe_unused]] size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (bytes < kHugePageMinBytes) return;
    constexpr uintptr_t kHugePage = uintptr_t(2) << 20;
    const uintptr_t begin = (uintptr_t(p) + kHugePage - 1) & ~(kHugePage - 1);
    const uintptr_t end = (uintptr_t(p) + bytes) & ~(kHugePage - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#endif
}

// Hands the whole small pages inside [begin, end) back to the kernel: memory a region of an
// array faulted in but never used (with huge pages, the rest of the 2 MiB page its last write
// fell in). Pages never touched stay free either way.
inline void release_unused([[maybe_unused]] const void* begin, [[maybe_unused]] const void* end) {
#if defined(__linux__) && defined(MADV_DONTNEED)
    constexpr uintptr_t kSmallPage = 4096;
    const uintptr_t from = (uintptr_t(begin) + kSmallPage - 1) & ~(kSmallPage - 1);
    const uintptr_t to = uintptr_t(end) & ~(kSmallPage - 1);
    if (to > from) madvise(reinterpret_cast<void*>(from), to - from, MADV_DONTNEED);
#endif
}

// v.reserve(n) with the new capacity advised (v must be empty: nothing of it written yet).
template <class T, class Allocator>
void reserve_huge(std::vector<T, Allocator>& v, size_t n) {
    v.reserve(n);
    advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

// v.resize(n) of an empty v, its memory advised before the values are written.
template <class T, class Allocator, class... Value>
void resize_huge(std::vector<T, Allocator>& v, size_t n, const Value&... value) {
    reserve_huge(v, n);
    v.resize(n, value...);
}

}  // namespace phong
