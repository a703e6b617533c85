// SPDX-License-Identifier: Apache-2.0
// How many threads a scene build (BVH binning and subtrees, the parallel copies of the input)
// may use: every core by default, or the cap the caller set, as a render's thread count caps
// its render. Process-wide, like Embree's device `threads=N`: set before building a scene
// (Python: native.build(scene, threads=N) and the render's settings.threads set it for the
// build they run).
#pragma once

#include <algorithm>
#include <atomic>
#include <thread>

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

}  // namespace phong
