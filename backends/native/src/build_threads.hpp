// SPDX-License-Identifier: Apache-2.0
// How many threads a scene build (BVH binning, subtrees and collapse, the parallel copies of the
// input) may use: every core by default, or the cap the caller set, as a render's thread count
// caps its render. Process-wide, like Embree's device `threads=N`: set before building a scene
// (Python: native.build(scene, threads=N) and the render's settings.threads set it for the
// build they run). And for_chunks, which runs a build's simple passes on them.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <future>
#include <thread>
#include <vector>

namespace phong {

inline std::atomic<unsigned>& build_thread_cap() {
    static std::atomic<unsigned> cap{0};  // 0: every hardware thread
    return cap;
}

// The threads a build may use now: the cap, else the hardware's (at least 1).
inline unsigned build_threads() {
    const unsigned cap = build_thread_cap().load(std::memory_order_relaxed);
    return cap > 0 ? cap : std::max(1u, std::thread::hardware_concurrency());
}

// Runs fn(begin, end) over [0, n) in chunks on the build threads when n is large enough to pay
// for the threads (1M triangles: ~0.1 s of serial copying per pass, ~1 ms for a pass that writes
// or reads 1M numbers, next to ~0.1 ms to start a thread), else in one piece. The first exception
// in chunk order is rethrown once every chunk has finished, so errors are the same as a serial
// loop's.
constexpr size_t kParallelCopyMinItems = size_t(1) << 16;
// Chunks per build thread, taken in turn from a shared counter: a thread slowed by the host (a
// busy core) takes fewer of them, where one fixed chunk per thread left the others waiting.
constexpr size_t kChunksPerThread = 4;

template <class Fn>
void for_chunks(size_t n, Fn&& fn) {
    const size_t threads = n >= kParallelCopyMinItems ? build_threads() : 1;
    if (threads < 2) {
        fn(size_t(0), n);
        return;
    }
    const size_t chunks = threads * kChunksPerThread;
    std::vector<std::exception_ptr> errors(chunks);
    std::atomic<size_t> next_chunk{0};
    auto work = [&] {
        for (size_t c; (c = next_chunk.fetch_add(1, std::memory_order_relaxed)) < chunks;) {
            try {
                fn(n * c / chunks, n * (c + 1) / chunks);
            } catch (...) {
                errors[c] = std::current_exception();
            }
        }
    };
    std::vector<std::future<void>> rest;
    for (size_t t = 1; t < threads; ++t) rest.push_back(std::async(std::launch::async, work));
    work();
    for (std::future<void>& f : rest) f.get();
    for (const std::exception_ptr& error : errors)
        if (error) std::rethrow_exception(error);
}

}  // namespace phong
