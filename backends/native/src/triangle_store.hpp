// SPDX-License-Identifier: Apache-2.0
// The triangles' corners in leaf order, held as floats when that loses nothing. USD points are
// float32, and a mesh under an identity (or otherwise float-exact) world transform reaches the
// scene with every coordinate a float: then 9 floats (36 B) hold a triangle instead of 9 doubles
// (72 B), and widening them gives back the very same doubles, so every test and every image is
// bit-identical. At 1M triangles the render is memory-bound, and this halves its largest array.
#pragma once

#include <cstddef>
#include <vector>

#include "math.hpp"
#include "shapes.hpp"

namespace phong {

// A triangle's corners rounded to float (only ever built from float-exact doubles).
struct FloatTriangleShape {
    float v[9];  // v0, v1, v2

    explicit FloatTriangleShape(const TriangleShape& t = {})
        : v{float(t.v0.x), float(t.v0.y), float(t.v0.z), float(t.v1.x), float(t.v1.y),
            float(t.v1.z), float(t.v2.x), float(t.v2.y), float(t.v2.z)} {}

    TriangleShape widen() const {
        return {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}};
    }
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
            narrow_.resize(n);
        else
            wide_.resize(n);
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

}  // namespace phong
