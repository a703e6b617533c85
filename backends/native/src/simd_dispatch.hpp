// SPDX-License-Identifier: Apache-2.0
// Which SIMD path the BVH walks take, chosen at run time when a Scene is built: the 8-wide AVX2
// walk (bvh8.hpp) where the CPU has AVX2, else the 4-wide SSE2 one (bvh4.hpp), which any x86-64
// runs. The environment variable PHONGSCENE_NATIVE_SIMD forces one: "sse2" (the portable path:
// tests compare the two), "avx2" (an error on a CPU without it), "auto" or unset (the best).
#pragma once

#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

namespace phong {

constexpr const char* kSimdEnvironmentVariable = "PHONGSCENE_NATIVE_SIMD";

// A function compiled for AVX2 inside the baseline build, called only where use_avx2() chose it.
#define PHONG_AVX2 __attribute__((target("avx2")))

inline bool cpu_has_avx2() {
#if defined(__x86_64__) || defined(__i386__)
    return __builtin_cpu_supports("avx2");
#else
    return false;
#endif
}

// True for the AVX2 path. Throws std::invalid_argument on a value it does not know, or "avx2"
// on a CPU without AVX2.
inline bool use_avx2() {
    const char* value = std::getenv(kSimdEnvironmentVariable);
    if (value == nullptr || *value == '\0' || std::strcmp(value, "auto") == 0) return cpu_has_avx2();
    if (std::strcmp(value, "sse2") == 0) return false;
    if (std::strcmp(value, "avx2") == 0) {
        if (!cpu_has_avx2())
            throw std::invalid_argument(std::string(kSimdEnvironmentVariable) + "=avx2 but this CPU has no AVX2");
        return true;
    }
    throw std::invalid_argument(std::string(kSimdEnvironmentVariable) + "=" + value + ": expected auto, sse2 or avx2");
}

}  // namespace phong
