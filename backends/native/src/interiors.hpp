// SPDX-License-Identifier: Apache-2.0
// The interiors a ray travels in. POV-Ray keeps, per ray, the list of the transparent objects'
// interiors it has entered and not left (trace.cpp ComputeRefraction, ref §18): an interior is an
// object's (a copy of an instanced object has its own), so two overlapping glasses of one
// material are two interiors, and nested media (a glass of water) are a list, innermost last.
// The "povray" transmission convention follows that list. The book's convention (Suffern's
// Dielectric: a surface met from behind is left for the outside) holds at most one entry.
#pragma once

#include <array>
#include <cstdint>

#include "materials.hpp"

namespace phong {

// One interior: the object (Scene::object_of numbering; `instance` >= 0 for an instance's copy,
// the object then numbered in its prototype) and its material (ior, interior filter).
struct Interior {
    int32_t instance = -1;
    int32_t object = -1;
    const Material* material = nullptr;
    bool same_object(const Interior& other) const { return instance == other.instance && object == other.object; }
};

// More transparent objects than any modelled scene nests or overlaps at one point (POV-Ray's
// limit is 512). A ray entering one more keeps the list it has: that interior is not recorded,
// so the ray refracts into it as from the innermost and is not faded inside it (no scene here
// comes near; the bound keeps a ray's state a fixed 264 bytes, copied only where a ray refracts).
constexpr int kMaxInteriors = 16;

class Interiors {
  public:
    bool empty() const { return count_ == 0; }
    int size() const { return count_; }
    const Interior& innermost() const { return items_[size_t(count_ - 1)]; }
    // The innermost interior's material, or nullptr outside every object.
    const Material* innermost_material() const { return empty() ? nullptr : innermost().material; }
    bool contains(const Interior& interior) const {
        for (int k = 0; k < count_; ++k)
            if (items_[size_t(k)].same_object(interior)) return true;
        return false;
    }
    void append(const Interior& interior) {
        if (count_ < kMaxInteriors) items_[size_t(count_++)] = interior;
    }
    // Removes `interior` (the list keeps its order); false when the ray was not in it.
    bool remove(const Interior& interior) {
        for (int k = 0; k < count_; ++k)
            if (items_[size_t(k)].same_object(interior)) {
                for (int j = k + 1; j < count_; ++j) items_[size_t(j - 1)] = items_[size_t(j)];
                --count_;
                return true;
            }
        return false;
    }
    // As a shadow ray crosses a surface (POV-Ray's ComputeShadowMedia): leaves the interior it is
    // in, else enters it.
    void toggle(const Interior& interior) {
        if (!remove(interior)) append(interior);
    }

  private:
    std::array<Interior, kMaxInteriors> items_{};
    int count_ = 0;
};

}  // namespace phong
