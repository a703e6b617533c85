// SPDX-License-Identifier: Apache-2.0
// The triangles' corners in leaf order (and the meshes' vertex normals), held as floats when
// that loses nothing. USD points are float32, and a mesh under an identity (or otherwise
// float-exact) world transform reaches the scene with every coordinate a float: then 9 floats
// (36 B) hold a triangle instead of 9 doubles (72 B), and widening them gives back the very same
// doubles, so every test and every image is bit-identical. At 1M triangles this halves the C++
// scene's largest array (S2: 72 -> 36 MB); USD normals are float32 too (normal3f), so their copy
// halves as well (S2: 12 -> 6 MB).
#pragma once

#include <cstddef>
#include <vector>

#include "huge_pages.hpp"
#include "math.hpp"
#include "shapes.hpp"

namespace phong {

// A triangle's corners rounded to float (only ever built from float-exact doubles).
struct FloatTriangleShape {
    float v[9];  // v0, v1, v2

    explicit FloatTriangleShape(const TriangleShape& t = {})
        : v{float(t.v0.x), float(t.v0.y), float(t.v0.z), float(t.v1.x), float(t.v1.y),
            float(t.v1.z), float(t.v2.x), float(t.v2.y), float(t.v2.z)} {}

    TriangleShape widen() const { return {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}}; }
};

// Whether double(float(x)) == x: a coordinate that float storage keeps exactly. NaN is not (it
// compares unequal), so such a mesh keeps double storage and its own behaviour.
inline bool float_exact(double x) { return double(float(x)) == x; }

// Leaf-order triangle corners in one of two precisions, chosen per scene when it is built
// (float when every mesh vertex is float_exact, else double); read as doubles either way.
class TriangleStore {
  public:
    void resize(size_t n, bool single_precision) {
        single_precision_ = single_precision;
        if (single_precision)
            resize_huge(narrow_, n);
        else
            resize_huge(wide_, n);
    }
    // Stores slot k's corners (float_exact when single_precision()).
    void set(size_t k, const TriangleShape& t) {
        if (single_precision_)
            narrow_[k] = FloatTriangleShape(t);
        else
            wide_[k] = t;
    }
    TriangleShape operator[](size_t k) const { return single_precision_ ? narrow_[k].widen() : wide_[k]; }
    size_t size() const { return single_precision_ ? narrow_.size() : wide_.size(); }
    bool single_precision() const { return single_precision_; }

  private:
    bool single_precision_ = false;
    std::vector<FloatTriangleShape> narrow_;
    std::vector<TriangleShape> wide_;
};

// Rows of 3 doubles (the meshes' normals), held as floats when every coordinate is
// float_exact; read back as the same doubles.
class Vec3Store {
  public:
    // Stores `rows` (count x 3) of each of `parts`, concatenated in order.
    template <class Parts>
    void assign(const Parts& parts) {
        size_t count = 0;
        single_precision_ = true;
        for (const auto& [rows, n] : parts) {
            count += n;
            for (size_t i = 0; i < 3 * n && single_precision_; ++i) single_precision_ = float_exact(rows[i]);
        }
        std::vector<float>().swap(narrow_);
        std::vector<Vec3>().swap(wide_);
        if (single_precision_)
            reserve_huge(narrow_, 3 * count);
        else
            reserve_huge(wide_, count);
        for (const auto& [rows, n] : parts)
            for (size_t i = 0; i < n; ++i) {
                if (single_precision_)
                    narrow_.insert(narrow_.end(), {float(rows[3 * i]), float(rows[3 * i + 1]), float(rows[3 * i + 2])});
                else
                    wide_.push_back({rows[3 * i], rows[3 * i + 1], rows[3 * i + 2]});
            }
    }
    Vec3 operator[](size_t k) const {
        if (!single_precision_) return wide_[k];
        const float* v = &narrow_[3 * k];
        return {v[0], v[1], v[2]};
    }
    size_t size() const { return single_precision_ ? narrow_.size() / 3 : wide_.size(); }
    bool single_precision() const { return single_precision_; }

  private:
    bool single_precision_ = false;
    std::vector<float> narrow_;
    std::vector<Vec3> wide_;
};

}  // namespace phong
