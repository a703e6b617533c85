// SPDX-License-Identifier: Apache-2.0
#include "subdivision.hpp"

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cassert>
#include <cmath>
#include <memory>
#include <stdexcept>

namespace phong {
namespace {

using namespace OpenSubdiv;
using Descriptor = Far::TopologyDescriptor;
using Refiner = Far::TopologyRefiner;
// Double weights: the limit positions are as exact as the cage's doubles.
using PrimvarRefiner = Far::PrimvarRefinerReal<double>;

// The value types PrimvarRefiner combines: weighted sums of the coarser level's values.
struct Point {
    double x = 0.0, y = 0.0, z = 0.0;
    void Clear() { x = y = z = 0.0; }
    void AddWithWeight(const Point& p, double w) {
        x += w * p.x;
        y += w * p.y;
        z += w * p.z;
    }
};

struct Uv {
    double u = 0.0, v = 0.0;
    void Clear() { u = v = 0.0; }
    void AddWithWeight(const Uv& p, double w) {
        u += w * p.u;
        v += w * p.v;
    }
};

// A per-face value that children inherit unchanged (InterpolateFaceUniform copies it).
struct BaseFace {
    int32_t id = -1;
};

Point cross(const Point& a, const Point& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Point minus(const Point& a, const Point& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double dot(const Point& a, const Point& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

Sdc::Options options_of(const SubdivisionCage& cage) {
    Sdc::Options options;
    switch (cage.boundary) {
        case BoundaryInterpolation::kNone:
            options.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_NONE);
            break;
        case BoundaryInterpolation::kEdgeOnly:
            options.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
            break;
        case BoundaryInterpolation::kEdgeAndCorner:
            options.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
            break;
    }
    static const Sdc::Options::FVarLinearInterpolation fvar[] = {
        Sdc::Options::FVAR_LINEAR_NONE,          Sdc::Options::FVAR_LINEAR_CORNERS_ONLY,
        Sdc::Options::FVAR_LINEAR_CORNERS_PLUS1, Sdc::Options::FVAR_LINEAR_CORNERS_PLUS2,
        Sdc::Options::FVAR_LINEAR_BOUNDARIES,    Sdc::Options::FVAR_LINEAR_ALL};
    options.SetFVarLinearInterpolation(fvar[int(cage.face_varying)]);
    options.SetTriangleSubdivision(cage.smooth_triangles ? Sdc::Options::TRI_SUB_SMOOTH
                                                         : Sdc::Options::TRI_SUB_CATMARK);
    return options;
}

Sdc::SchemeType scheme_of(SubdivisionScheme scheme) {
    switch (scheme) {
        case SubdivisionScheme::kLoop:
            return Sdc::SCHEME_LOOP;
        case SubdivisionScheme::kBilinear:
            return Sdc::SCHEME_BILINEAR;
        default:
            return Sdc::SCHEME_CATMARK;
    }
}

}  // namespace

RefinedSurface refine_subdivision(const SubdivisionCage& cage, int level) {
    assert(level >= 1 && level <= 10);
    assert(cage.crease_pairs.size() == 2 * cage.crease_sharpness.size());
    assert(cage.corner_indices.size() == cage.corner_sharpness.size());
    Descriptor desc;
    desc.numVertices = cage.point_count;
    desc.numFaces = cage.face_count;
    desc.numVertsPerFace = cage.face_counts;
    desc.vertIndicesPerFace = cage.face_indices;
    desc.numCreases = int(cage.crease_sharpness.size());
    desc.creaseVertexIndexPairs = cage.crease_pairs.data();
    desc.creaseWeights = cage.crease_sharpness.data();
    desc.numCorners = int(cage.corner_indices.size());
    desc.cornerVertexIndices = cage.corner_indices.data();
    desc.cornerWeights = cage.corner_sharpness.data();
    desc.numHoles = int(cage.holes.size());
    desc.holeIndices = cage.holes.data();
    Descriptor::FVarChannel channel;
    const bool has_uv = cage.uv_count > 0;
    if (has_uv) {
        channel.numValues = cage.uv_count;
        channel.valueIndices = cage.uv_indices;
        desc.numFVarChannels = 1;
        desc.fvarChannels = &channel;
    }
    std::unique_ptr<Refiner> refiner(Far::TopologyRefinerFactory<Descriptor>::Create(
        desc, Far::TopologyRefinerFactory<Descriptor>::Options(scheme_of(cage.scheme), options_of(cage))));
    if (!refiner) throw std::invalid_argument("OpenSubdiv refused the mesh's topology");
    Refiner::UniformOptions uniform(level);
    uniform.fullTopologyInLastLevel = true;  // the limit masks need the last level's full topology
    refiner->RefineUniform(uniform);

    // Level by level: vertices, the base face of every face, the uv channel.
    const PrimvarRefiner primvars(*refiner);
    std::vector<Point> points(size_t(cage.point_count));
    for (int32_t i = 0; i < cage.point_count; ++i)
        points[size_t(i)] = {cage.points[3 * i], cage.points[3 * i + 1], cage.points[3 * i + 2]};
    std::vector<BaseFace> faces(size_t(cage.face_count));
    for (int32_t f = 0; f < cage.face_count; ++f) faces[size_t(f)].id = f;
    std::vector<Uv> uvs(size_t(cage.uv_count));
    for (int32_t i = 0; i < cage.uv_count; ++i) uvs[size_t(i)] = {cage.uvs[2 * i], cage.uvs[2 * i + 1]};
    for (int l = 1; l <= level; ++l) {
        const Far::TopologyLevel& child = refiner->GetLevel(l);
        std::vector<Point> finer_points(size_t(child.GetNumVertices()));
        Point* points_out = finer_points.data();  // PrimvarRefiner takes its destination by reference
        primvars.Interpolate(l, points.data(), points_out);
        points.swap(finer_points);
        std::vector<BaseFace> finer_faces(size_t(child.GetNumFaces()));
        BaseFace* faces_out = finer_faces.data();
        primvars.InterpolateFaceUniform(l, faces.data(), faces_out);
        faces.swap(finer_faces);
        if (has_uv) {
            std::vector<Uv> finer_uvs(size_t(child.GetNumFVarValues(0)));
            Uv* uvs_out = finer_uvs.data();
            primvars.InterpolateFaceVarying(l, uvs.data(), uvs_out, 0);
            uvs.swap(finer_uvs);
        }
    }
    // Every vertex onto the limit surface, with its tangents there.
    std::vector<Point> limit(points.size()), du(points.size()), dv(points.size());
    Point *limit_out = limit.data(), *du_out = du.data(), *dv_out = dv.data();
    primvars.Limit(points.data(), limit_out, du_out, dv_out);
    std::vector<Uv> limit_uvs(uvs.size());
    Uv* limit_uvs_out = limit_uvs.data();
    if (has_uv) primvars.LimitFaceVarying(uvs.data(), limit_uvs_out, 0);

    // The last level's faces (quads, or triangles under Loop) as triangles, fanned from corner 0.
    RefinedSurface out;
    const Far::TopologyLevel& last = refiner->GetLevel(level);
    std::vector<Point> face_normal_sum(limit.size());  // area-weighted, to orient the limit normals
    for (int f = 0; f < last.GetNumFaces(); ++f) {
        if (last.IsFaceHole(f)) continue;
        const Far::ConstIndexArray v = last.GetFaceVertices(f);
        const Far::ConstIndexArray uv = has_uv ? last.GetFaceFVarValues(f, 0) : Far::ConstIndexArray();
        for (int k = 1; k + 1 < v.size(); ++k) {
            const int corners[3] = {0, k, k + 1};
            for (int c : corners) out.triangles.push_back(v[c]);
            if (has_uv)
                for (int c : corners) out.uv_triangles.push_back(uv[c]);
            out.base_face.push_back(faces[size_t(f)].id);
            const Point n = cross(minus(limit[size_t(v[k])], limit[size_t(v[0])]),
                                  minus(limit[size_t(v[k + 1])], limit[size_t(v[0])]));
            for (int c : corners) face_normal_sum[size_t(v[c])].AddWithWeight(n, 1.0);
        }
    }
    out.points.reserve(3 * limit.size());
    out.normals.reserve(3 * limit.size());
    for (size_t i = 0; i < limit.size(); ++i) {
        out.points.insert(out.points.end(), {limit[i].x, limit[i].y, limit[i].z});
        // The limit normal du × dv, on the side the faces' winding says is out. Where the limit
        // tangents are degenerate (parallel, or zero), the faces' mean normal instead.
        Point n = cross(du[i], dv[i]);
        const Point& faces_n = face_normal_sum[i];
        const double length = std::sqrt(dot(n, n));
        const double tangent_scale = std::sqrt(dot(du[i], du[i]) * dot(dv[i], dv[i]));
        // |du × dv| = |du||dv| sin θ: below this sine the tangents do not span a plane
        // (float-level cancellation in the limit stencils, ~1e-7 relative).
        constexpr double kMinTangentSine = 1e-6;
        if (!(length > kMinTangentSine * tangent_scale)) {
            n = faces_n;
        } else if (dot(n, faces_n) < 0.0) {
            n = {-n.x, -n.y, -n.z};
        }
        const double n_length = std::sqrt(dot(n, n));
        if (n_length > 0.0 && std::isfinite(n_length)) {
            out.normals.insert(out.normals.end(), {n.x / n_length, n.y / n_length, n.z / n_length});
        } else {
            out.normals.insert(out.normals.end(), {0.0, 0.0, 0.0});
        }
    }
    out.uvs.reserve(2 * limit_uvs.size());
    for (const Uv& uv : limit_uvs) out.uvs.insert(out.uvs.end(), {uv.u, uv.v});
    return out;
}

}  // namespace phong
