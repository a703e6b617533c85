// SPDX-License-Identifier: Apache-2.0
// Subdivision surfaces refined by OpenSubdiv (the library USD's own renderers use): a USD Mesh's
// control cage in, the triangles of its uniform refinement out, with every vertex on the limit
// surface and the limit surface's normal there. The USD reader calls it, so both backends trace
// the same triangles. The caller (phongscene/usd/subdivision.py) validates the topology first.
#pragma once

#include <cstdint>
#include <vector>

namespace phong {

enum class SubdivisionScheme : int32_t { kCatmullClark = 0, kLoop = 1, kBilinear = 2 };
// USD's interpolateBoundary tokens, in order: none, edgeOnly, edgeAndCorner.
enum class BoundaryInterpolation : int32_t { kNone = 0, kEdgeOnly = 1, kEdgeAndCorner = 2 };
// USD's faceVaryingLinearInterpolation tokens, in order: none, cornersOnly, cornersPlus1,
// cornersPlus2, boundaries, all.
enum class FaceVaryingInterpolation : int32_t {
    kNone = 0,
    kCornersOnly = 1,
    kCornersPlus1 = 2,
    kCornersPlus2 = 3,
    kBoundaries = 4,
    kAll = 5
};

struct SubdivisionCage {
    SubdivisionScheme scheme = SubdivisionScheme::kCatmullClark;
    BoundaryInterpolation boundary = BoundaryInterpolation::kEdgeAndCorner;
    FaceVaryingInterpolation face_varying = FaceVaryingInterpolation::kCornersPlus1;
    bool smooth_triangles = false;   // USD triangleSubdivisionRule "smooth" (Catmull-Clark only)
    const double* points = nullptr;  // (point_count, 3)
    int32_t point_count = 0;
    const int32_t* face_counts = nullptr;  // every count >= 3 (Loop: == 3)
    int32_t face_count = 0;
    const int32_t* face_indices = nullptr;  // sum(face_counts) entries in [0, point_count)
    // Crease edges as vertex pairs (USD's chains split into edges), one sharpness each.
    std::vector<int32_t> crease_pairs;
    std::vector<float> crease_sharpness;
    std::vector<int32_t> corner_indices;
    std::vector<float> corner_sharpness;
    std::vector<int32_t> holes;  // face indices
    // One face-varying channel (texture coordinates), or none: uv_count == 0.
    const double* uvs = nullptr;  // (uv_count, 2)
    int32_t uv_count = 0;
    const int32_t* uv_indices = nullptr;  // one per face corner (sum(face_counts)) into uvs
};

struct RefinedSurface {
    std::vector<double> points;         // (V, 3): the refined vertices projected to the limit surface
    std::vector<double> normals;        // (V, 3): the limit surface's unit normal there (0: undefined)
    std::vector<int32_t> triangles;     // (T, 3) into points, wound as the cage's faces
    std::vector<int32_t> base_face;     // (T): the cage face each triangle refines
    std::vector<double> uvs;            // (U, 2): the channel refined, at the limit
    std::vector<int32_t> uv_triangles;  // (T, 3) into uvs (empty without a channel)
};

// Refines `cage` uniformly `level` (1..10) times. Hole faces produce no triangles.
RefinedSurface refine_subdivision(const SubdivisionCage& cage, int level);

}  // namespace phong
