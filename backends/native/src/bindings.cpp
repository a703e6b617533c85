// SPDX-License-Identifier: Apache-2.0
// Python bindings of the native tracer: the only file that includes nanobind. The C++ structs
// of materials, lights, the camera and the render settings are bound as Python classes with
// named fields; numpy arrays carry only the bulk geometry. The Python wrapper
// (backends/native/__init__.py) builds both from a phongscene.Scene.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/array.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/variant.h>
#include <nanobind/stl/vector.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "build_threads.hpp"
#include "bvh8_group.hpp"
#include "bvh8_packet.hpp"
#include "camera.hpp"
#include "lane_shading.hpp"
#include "lights.hpp"
#include "materials.hpp"
#include "render.hpp"
#include "scene.hpp"
#include "simd_dispatch.hpp"
#include "subdivision.hpp"
#include "triangle_prefilter.hpp"

namespace nb = nanobind;
using namespace nb::literals;

// Vec3 (and RGB) cross as any sequence of three floats from Python and come back as a list, like
// std::array<double, 3>.
namespace nanobind::detail {
template <>
struct type_caster<phong::Vec3> {
    using Xyz = std::array<double, 3>;
    NB_TYPE_CASTER(phong::Vec3, make_caster<Xyz>::Name)

    bool from_python(handle src, uint32_t flags, cleanup_list* cleanup) noexcept {
        make_caster<Xyz> xyz;
        if (!xyz.from_python(src, flags, cleanup)) return false;
        value = {xyz.value[0], xyz.value[1], xyz.value[2]};
        return true;
    }

    static handle from_cpp(const phong::Vec3& v, rv_policy policy, cleanup_list* cleanup) noexcept {
        return make_caster<Xyz>::from_cpp(Xyz{v.x, v.y, v.z}, policy, cleanup);
    }
};
}  // namespace nanobind::detail

namespace {

template <class T, class Shape>
using In = nb::ndarray<const T, Shape, nb::c_contig, nb::device::cpu>;

using Matrices = In<double, nb::shape<-1, 4, 4>>;
using Rows3 = In<double, nb::shape<-1, 3>>;
using Index3 = In<int32_t, nb::shape<-1, 3>>;
using Index1 = In<int32_t, nb::shape<-1>>;
using Reals1 = In<double, nb::shape<-1>>;

// The meshes' arrays are the model's own (one list entry per mesh), read in place: no
// concatenated copy on either side.
std::unique_ptr<phong::Scene> make_scene(
    const Matrices& sphere_world_from_object, const Matrices& sphere_object_from_world, const Index1& sphere_material,
    const std::vector<Rows3>& points, const std::vector<Index3>& triangles, const std::vector<Rows3>& normals,
    const std::vector<Index3>& normal_indices, const Index1& mesh_material, const Rows3& mesh_origins,
    std::vector<phong::Material> materials, std::vector<phong::Light> lights, const phong::RGB& ambient,
    bool povray_triangles, std::vector<phong::IntrinsicShape> intrinsics, const std::vector<Rows3>& ball_centers,
    const std::vector<Reals1>& ball_radii, const std::vector<int32_t>& ball_material,
    const std::vector<int32_t>& ball_object) {
    const size_t n_spheres = sphere_world_from_object.shape(0), n_meshes = points.size();
    if (sphere_object_from_world.shape(0) != n_spheres || sphere_material.shape(0) != n_spheres)
        throw std::invalid_argument("sphere arrays differ in length");
    if (triangles.size() != n_meshes || normals.size() != n_meshes || normal_indices.size() != n_meshes ||
        mesh_material.shape(0) != n_meshes || mesh_origins.shape(0) != n_meshes)
        throw std::invalid_argument("mesh lists differ in length");
    phong::GeometryArrays a;
    a.sphere_world_from_object = sphere_world_from_object.data();
    a.sphere_object_from_world = sphere_object_from_world.data();
    a.sphere_material = sphere_material.data();
    a.sphere_count = n_spheres;
    a.povray_triangles = povray_triangles;
    for (const phong::IntrinsicShape& part : intrinsics)
        if (int32_t(part.kind) < 0 || int32_t(part.kind) > int32_t(phong::IntrinsicKind::kSphere))
            throw std::invalid_argument("unknown intrinsic kind");
    a.intrinsics = std::move(intrinsics);
    const size_t n_sets = ball_centers.size();
    if (ball_radii.size() != n_sets || ball_material.size() != n_sets || ball_object.size() != n_sets)
        throw std::invalid_argument("points lists differ in length");
    size_t n_balls = 0;
    for (size_t g = 0; g < n_sets; ++g) {
        const size_t count = ball_centers[g].shape(0);
        if (ball_radii[g].shape(0) != count) throw std::invalid_argument("a points set's radii differ in length");
        // Python validates the scene (phongscene.validate: Points); a radius that is not positive
        // would only give a meaningless image, not a crash, but costs nothing to refuse.
        for (size_t i = 0; i < count; ++i)
            if (!(ball_radii[g](i) > 0.0)) throw std::invalid_argument("a points radius is not > 0");
        if (ball_object[g] < 0) throw std::invalid_argument("a points object number is negative");
        a.balls.push_back({ball_centers[g].data(), ball_radii[g].data(), count, ball_material[g], ball_object[g]});
        n_balls += count;
    }
    size_t n_triangles = 0;
    for (size_t m = 0; m < n_meshes; ++m) {
        phong::MeshArrays mesh;
        mesh.points = points[m].data();
        mesh.point_count = points[m].shape(0);
        mesh.triangles = triangles[m].data();
        mesh.triangle_count = triangles[m].shape(0);
        mesh.normals = normals[m].data();
        mesh.normal_count = normals[m].shape(0);
        if (normal_indices[m].shape(0) != 0) {
            if (normal_indices[m].shape(0) != mesh.triangle_count)
                throw std::invalid_argument("a mesh's normal_indices must have one row per triangle (or none: flat)");
            mesh.normal_indices = normal_indices[m].data();
        }
        mesh.material = mesh_material(m);
        mesh.origin = {mesh_origins(m, 0), mesh_origins(m, 1), mesh_origins(m, 2)};
        n_triangles += mesh.triangle_count;
        a.meshes.push_back(mesh);
    }
    // Triangles are numbered in int32 (leaf refs), their ids in uint32 (primitive refs) and the
    // BVH's 2n - 1 node slots in int32.
    if (n_spheres + n_triangles + a.intrinsics.size() + n_balls > phong::kMaxBvhPrimitives)
        throw std::invalid_argument("too many primitives (at most 2^30)");
    // The arrays stay alive (held by the caller's frame) while the GIL is released.
    nb::gil_scoped_release release;
    return std::make_unique<phong::Scene>(a, std::move(materials), std::move(lights), ambient);
}

using Image = nb::ndarray<nb::numpy, float, nb::shape<-1, -1, 3>>;
using TextureImage = In<float, nb::shape<-1, -1, 3>>;
using CornerUv = In<double, nb::shape<-1, 3, 2>>;

// Every texture a material names exists, and every triangle has its corner uvs (so that a
// Material built by hand with a texture index cannot make the shading read out of bounds).
void check_textures(const phong::Scene& scene) {
    bool textured = false;
    for (const phong::Material& m : scene.materials) {
        const int64_t count = int64_t(scene.textures.size());
        if (m.last_texture() >= count)
            throw std::invalid_argument("a material's texture index is out of range (call set_textures)");
        textured |= m.textured();
    }
    if (textured && scene.corner_uv_rows != scene.triangles.size())
        throw std::invalid_argument("textured materials need corner_uv for every triangle (call set_textures)");
}

// Gives the scene its textures (the caller's arrays, held, not copied; with half_texels a copy
// in half floats, as POV-Ray holds an EXR's texels) and copies the per-corner uvs,
// checking what C++ indexes with.
void set_textures(phong::Scene& scene, const std::vector<TextureImage>& images, const std::vector<phong::Wrap>& wrap_s,
                  const std::vector<phong::Wrap>& wrap_t, const CornerUv& corner_uv, std::array<double, 2> uv_origin,
                  std::array<double, 2> uv_span, bool half_texels) {
    if (wrap_s.size() != images.size() || wrap_t.size() != images.size())
        throw std::invalid_argument("one wrap_s and wrap_t per texture");
    bool textured = false;
    for (const phong::Material& m : scene.materials) {
        const int64_t count = int64_t(images.size());
        if (m.last_texture() >= count) throw std::invalid_argument("a material's texture index is out of range");
        textured |= m.textured();
    }
    if (textured && corner_uv.shape(0) != scene.triangles.size())
        throw std::invalid_argument("corner_uv needs one row per triangle");
    std::vector<phong::Texture> textures(images.size());
    for (size_t i = 0; i < images.size(); ++i) {
        const TextureImage& image = images[i];
        if (image.shape(0) < 1 || image.shape(1) < 1) throw std::invalid_argument("a texture has no texels");
        textures[i].height = int(image.shape(0));
        textures[i].width = int(image.shape(1));
        if (half_texels) {
            auto halves = std::make_shared<std::vector<uint16_t>>(image.size());
            for (size_t k = 0; k < image.size(); ++k) (*halves)[k] = phong::to_half(image.data()[k]);
            textures[i].halves = halves->data();
            textures[i].owner = std::move(halves);
        } else {
            // The ndarray holds a reference to the Python array; nanobind takes the GIL to
            // release it, wherever the scene is destroyed.
            textures[i].texels = image.data();
            textures[i].owner = std::make_shared<TextureImage>(image);
        }
        textures[i].wrap_s = wrap_s[i];
        textures[i].wrap_t = wrap_t[i];
    }
    scene.textures = std::move(textures);
    scene.corner_uv = corner_uv.data();
    scene.corner_uv_rows = corner_uv.shape(0);
    scene.corner_uv_owner = std::make_shared<CornerUv>(corner_uv);
    for (int k = 0; k < 2; ++k) {
        if (!std::isfinite(uv_origin[k]) || !std::isfinite(uv_span[k]) || uv_span[k] == 0.0)
            throw std::invalid_argument("uv_origin and uv_span must be finite, uv_span non-zero");
        scene.uv_origin[k] = uv_origin[k];
        scene.uv_span[k] = uv_span[k];
    }
}

// Gives the scene its environment (a lat-long map: the caller's array, held, not copied; with
// half_texels a copy in half floats, as POV-Ray holds an EXR's texels).
void set_environment(phong::Scene& scene, const TextureImage& image, const phong::RGB& scale,
                     const std::array<double, 9>& dome_from_world, bool half_texels) {
    if (image.shape(0) < 1 || image.shape(1) < 1) throw std::invalid_argument("the environment has no texels");
    phong::Texture texture;
    texture.height = int(image.shape(0));
    texture.width = int(image.shape(1));
    texture.wrap_s = phong::Wrap::kRepeat;  // around the longitude
    texture.wrap_t = phong::Wrap::kClamp;   // at the poles
    if (half_texels) {
        auto halves = std::make_shared<std::vector<uint16_t>>(image.size());
        for (size_t k = 0; k < image.size(); ++k) (*halves)[k] = phong::to_half(image.data()[k]);
        texture.halves = halves->data();
        texture.owner = std::move(halves);
    } else {
        texture.texels = image.data();
        texture.owner = std::make_shared<TextureImage>(image);
    }
    scene.environment.texture = std::move(texture);
    scene.environment.scale = scale;
    std::copy(dome_from_world.begin(), dome_from_world.end(), scene.environment.dome_from_world);
}

using Flags = In<uint8_t, nb::shape<-1>>;

// The lights' shadow switches and links (LightLinking), checked against the scene's counts.
void set_light_links(phong::Scene& scene, const Flags& shadows, const std::vector<Flags>& lit,
                     const std::vector<Flags>& casts) {
    const size_t n = scene.lights.size();
    if (shadows.shape(0) != n || lit.size() != n || casts.size() != n)
        throw std::invalid_argument("one shadow switch, lit and casts array per light");
    std::vector<phong::LightLinking> links(n);
    for (size_t j = 0; j < n; ++j) {
        links[j].shadows = shadows(j) != 0;
        links[j].lit.assign(lit[j].data(), lit[j].data() + lit[j].size());
        links[j].casts.assign(casts[j].data(), casts[j].data() + casts[j].size());
        for (const std::vector<unsigned char>* flags : {&links[j].lit, &links[j].casts})
            if (!flags->empty() && flags->size() != scene.object_count())
                throw std::invalid_argument("a light link needs one flag per object (spheres, then meshes)");
    }
    scene.light_links = std::move(links);
}

Image render(const phong::Scene& scene, const phong::CameraDescription& camera_description,
             const phong::RenderSettings& settings, nb::object progress) {
    if (settings.width < 1 || settings.height < 1 || settings.samples < 1)
        throw std::invalid_argument("width, height and samples must be >= 1");
    if (settings.max_depth < 0 || settings.max_depth > phong::kMaxDepth)
        throw std::invalid_argument("max_depth must be in 0.." + std::to_string(phong::kMaxDepth));
    if (settings.camera_interiors.size() > size_t(phong::kMaxInteriors))
        throw std::invalid_argument("camera_interiors: at most " + std::to_string(phong::kMaxInteriors));
    for (const auto& [object, material] : settings.camera_interiors)
        if (object < 0 || size_t(object) >= scene.object_count() || material < 0 ||
            size_t(material) >= scene.materials.size())
            throw std::invalid_argument("camera_interiors: (object, material) out of range");
    // The Python model validates these (phongscene.validate); a direct caller gets an error, not
    // a 2^(n-1)-sized +AM2 buffer or a NaN threshold.
    const bool native_pattern = settings.sample_pattern == phong::SamplePattern::kStratified ||
                                settings.sample_pattern == phong::SamplePattern::kAdaptive;
    const int most_samples = native_pattern ? 16 : 9;
    if (settings.samples > most_samples) throw std::invalid_argument("samples too large for the sample pattern");
    // The adaptive quadtree halves cells down to 1/samples of a pixel.
    if (settings.sample_pattern == phong::SamplePattern::kAdaptive && (settings.samples & (settings.samples - 1)) != 0)
        throw std::invalid_argument("adaptive: samples must be a power of 2");
    if (!(settings.aa_threshold >= 0.0 && settings.aa_threshold <= 1.0))
        throw std::invalid_argument("aa_threshold must be in [0, 1]");
    check_textures(scene);
    if (scene.instances && scene.instances->stale())
        throw std::invalid_argument("instances were added with rebuild=False and the top level was never built");
    const phong::Camera camera = phong::Camera::make(camera_description, settings.width, settings.height);

    const size_t count = size_t(settings.width) * size_t(settings.height) * 3;
    // Unwritten: render_image stores every pixel (or the render is cancelled and the buffer
    // dropped). Zero-filled here, it was 0.5 % of S2's render instructions, on one thread before
    // the workers start (benchmarks/README.md, issue 25).
    float* pixels = new float[count];
    nb::capsule owner(pixels, [](void* p) noexcept { delete[] static_cast<float*>(p); });

    // A Python exception raised while polling (the progress callback, or KeyboardInterrupt from
    // PyErr_CheckSignals) cancels the render and is re-raised here once the workers stopped.
    std::optional<nb::python_error> error;
    {
        nb::gil_scoped_release release;
        phong::render_image(scene, camera, settings, pixels, [&](int done, int total) {
            nb::gil_scoped_acquire acquire;
            try {
                if (!progress.is_none()) progress(done, total);
                if (PyErr_CheckSignals() != 0) throw nb::python_error();
            } catch (nb::python_error& e) {
                error.emplace(std::move(e));
                return false;
            }
            return true;
        });
    }
    if (error) throw std::move(*error);
    return Image(pixels, {size_t(settings.height), size_t(settings.width), 3}, owner);
}

// The primitive tests take t_min >= 0 (shapes.hpp: sphere_leaves), as the renderer's tolerances are.
void require_t_min(double t_min) {
    if (!(t_min >= 0.0)) throw std::invalid_argument("t_min must be >= 0");
}

// Closest hit per ray through the BVH: (t, primitive id), t = inf and id = -1 on a miss.
nb::tuple intersect(const phong::Scene& scene, const Rows3& origins, const Rows3& dirs, double t_min) {
    require_t_min(t_min);
    const size_t n = origins.shape(0);
    if (dirs.shape(0) != n) throw std::invalid_argument("origins and dirs differ in length");
    if (scene.instances && scene.instances->stale())
        throw std::invalid_argument("instances were added with rebuild=False and the top level was never built");
    double* t = new double[n];
    int64_t* id = new int64_t[n];
    nb::capsule t_owner(t, [](void* p) noexcept { delete[] static_cast<double*>(p); });
    nb::capsule id_owner(id, [](void* p) noexcept { delete[] static_cast<int64_t*>(p); });
    {
        nb::gil_scoped_release release;
        for (size_t i = 0; i < n; ++i) {
            const phong::Ray ray{{origins(i, 0), origins(i, 1), origins(i, 2)}, {dirs(i, 0), dirs(i, 1), dirs(i, 2)}};
            phong::Hit hit;
            if (scene.closest_hit(ray, t_min, HUGE_VAL, hit)) {
                t[i] = hit.t;
                // An instance's hit: -2 - the instance's number (its prototype's primitives are its own).
                id[i] = hit.instance >= 0 ? -2 - int64_t(scene.instances->instance_id(hit.instance))
                                          : scene.primitive_id(hit.ref);
            } else {
                t[i] = HUGE_VAL;
                id[i] = -1;
            }
        }
    }
    return nb::make_tuple(nb::ndarray<nb::numpy, double, nb::shape<-1>>(t, {n}, t_owner),
                          nb::ndarray<nb::numpy, int64_t, nb::shape<-1>>(id, {n}, id_owner));
}

// Whether each ray is blocked in (t_min, t_max[i]): the any-hit walk of shadow rays.
nb::ndarray<nb::numpy, bool, nb::shape<-1>> occluded(const phong::Scene& scene, const Rows3& origins, const Rows3& dirs,
                                                     const Reals1& t_max, double t_min, bool together) {
    require_t_min(t_min);
    const size_t n = origins.shape(0);
    if (dirs.shape(0) != n || t_max.shape(0) != n)
        throw std::invalid_argument("origins, dirs and t_max differ in length");
    if (scene.instances && scene.instances->stale())
        throw std::invalid_argument("instances were added with rebuild=False and the top level was never built");
    bool* blocked = new bool[n];
    nb::capsule owner(blocked, [](void* p) noexcept { delete[] static_cast<bool*>(p); });
    {
        nb::gil_scoped_release release;
        auto ray_at = [&](size_t i) {
            return phong::Ray{{origins(i, 0), origins(i, 1), origins(i, 2)}, {dirs(i, 0), dirs(i, 1), dirs(i, 2)}};
        };
        if (together) {  // consecutive rays in groups of kMaxRaysTogether through Scene::occluded_each, as the lanes
                         // ask them
            for (size_t first = 0; first < n; first += phong::kMaxRaysTogether) {
                const int count = int(std::min(n - first, size_t(phong::kMaxRaysTogether)));
                phong::Ray rays[phong::kMaxRaysTogether];
                double limits[phong::kMaxRaysTogether];
                for (int k = 0; k < count; ++k)
                    rays[k] = ray_at(first + size_t(k)), limits[k] = t_max(first + size_t(k));
                const phong::RayBits answers = scene.occluded_each(rays, count, t_min, limits);
                for (int k = 0; k < count; ++k) blocked[first + size_t(k)] = (answers >> k) & 1u;
            }
        } else {
            for (size_t i = 0; i < n; ++i) blocked[i] = scene.occluded(ray_at(i), t_min, t_max(i));
        }
    }
    return nb::ndarray<nb::numpy, bool, nb::shape<-1>>(blocked, {n}, owner);
}

// Closest hits of rays leaving one origin, kPacketRays (32) at a time through Scene::closest_hit_packet
// (`together`) or one by one through closest_hit with the same rounded origin: (t, primitive id,
// barycentrics (n, 3), packets that walked together). Tests compare the two bit for bit.
nb::tuple intersect_packets(const phong::Scene& scene, const In<double, nb::shape<3>>& origin, const Rows3& dirs,
                            double t_min, bool together) {
    require_t_min(t_min);
    const size_t n = dirs.shape(0);
    if (scene.instances && scene.instances->stale())
        throw std::invalid_argument("instances were added with rebuild=False and the top level was never built");
    double* t = new double[n];
    int64_t* id = new int64_t[n];
    double* bary = new double[3 * n];
    nb::capsule t_owner(t, [](void* p) noexcept { delete[] static_cast<double*>(p); });
    nb::capsule id_owner(id, [](void* p) noexcept { delete[] static_cast<int64_t*>(p); });
    nb::capsule bary_owner(bary, [](void* p) noexcept { delete[] static_cast<double*>(p); });
    int64_t walked_together = 0;
    {
        nb::gil_scoped_release release;
        const phong::Vec3 o{origin(0), origin(1), origin(2)};
        const phong::FloatSlabOrigin rounded(o);
        for (size_t first = 0; first < n; first += phong::kPacketRays) {
            const int count = int(std::min(n - first, size_t(phong::kPacketRays)));
            phong::Ray rays[phong::kPacketRays];
            phong::Hit hits[phong::kPacketRays];
            bool found[phong::kPacketRays];
            for (int r = 0; r < count; ++r) {
                const size_t i = first + size_t(r);
                rays[r] = {o, {dirs(i, 0), dirs(i, 1), dirs(i, 2)}};
            }
            if (together) {
                walked_together += scene.closest_hit_packet(rays, count, rounded, t_min, hits, found);
            } else {
                for (int r = 0; r < count; ++r)
                    found[r] = scene.closest_hit(rays[r], rounded, t_min, HUGE_VAL, hits[r]);
            }
            for (int r = 0; r < count; ++r) {
                const size_t i = first + size_t(r);
                t[i] = found[r] ? hits[r].t : HUGE_VAL;
                id[i] = !found[r]               ? -1
                        : hits[r].instance >= 0 ? -2 - int64_t(scene.instances->instance_id(hits[r].instance))
                                                : scene.primitive_id(hits[r].ref);
                const phong::Barycentric b = found[r] ? hits[r].bary : phong::Barycentric{0, 0, 0};
                bary[3 * i] = b.b0;
                bary[3 * i + 1] = b.b1;
                bary[3 * i + 2] = b.b2;
            }
        }
    }
    return nb::make_tuple(nb::ndarray<nb::numpy, double, nb::shape<-1>>(t, {n}, t_owner),
                          nb::ndarray<nb::numpy, int64_t, nb::shape<-1>>(id, {n}, id_owner),
                          nb::ndarray<nb::numpy, double, nb::shape<-1, 3>>(bary, {n, 3}, bary_owner), walked_together);
}

// The float prefilter (triangle_prefilter.hpp) against the double test, every ray against every
// triangle in runs of eight slots: per ray, the number of triangles the prefilter rejected that
// the double test hits at some t (any t: the prefilter rejects on the edge functions' signs
// alone), which must be 0, and the number it kept; -1 and -1 where it does not apply (no AVX2,
// double storage, corners not in lanes, POV-Ray numerics, a ray outside the bound's range).
nb::tuple prefilter_check(const phong::Scene& scene, const Rows3& origins, const Rows3& dirs) {
    const size_t n = origins.shape(0);
    if (dirs.shape(0) != n) throw std::invalid_argument("origins and dirs differ in length");
    int64_t* wrong = new int64_t[n];
    int64_t* kept = new int64_t[n];
    nb::capsule wrong_owner(wrong, [](void* p) noexcept { delete[] static_cast<int64_t*>(p); });
    nb::capsule kept_owner(kept, [](void* p) noexcept { delete[] static_cast<int64_t*>(p); });
    const bool applies = phong::cpu_has_avx2() && scene.triangles.lanes() && scene.povray_triangles.empty();
    {
        nb::gil_scoped_release release;
        const size_t count = scene.triangles.size();
        for (size_t i = 0; i < n; ++i) {
            const phong::Ray ray{{origins(i, 0), origins(i, 1), origins(i, 2)}, {dirs(i, 0), dirs(i, 1), dirs(i, 2)}};
            const phong::WatertightRay wr(ray.dir);
            phong::TrianglePrefilter8 prefilter;
            wrong[i] = kept[i] = -1;
            if (!applies || !prefilter.set_up(scene.triangles, ray, wr, scene.magnitude)) continue;
            wrong[i] = kept[i] = 0;
            for (size_t slot = 0; slot < count; slot += 8) {
                const int lanes = int(std::min<size_t>(8, count - slot));
                const unsigned candidates = prefilter.candidates(slot, lanes);
                for (int j = 0; j < lanes; ++j) {
                    if (candidates & (1u << j)) {
                        ++kept[i];
                        continue;
                    }
                    double t;
                    phong::Barycentric bary;
                    if (phong::intersect_triangle(scene.triangles[slot + size_t(j)], ray, wr, -HUGE_VAL, HUGE_VAL, t,
                                                  bary))
                        ++wrong[i];
                }
            }
        }
    }
    return nb::make_tuple(nb::ndarray<nb::numpy, int64_t, nb::shape<-1>>(wrong, {n}, wrong_owner),
                          nb::ndarray<nb::numpy, int64_t, nb::shape<-1>>(kept, {n}, kept_owner));
}

// Brute force over every primitive: (number of primitives hit, closest t).
nb::tuple count_hits(const phong::Scene& scene, const Rows3& origins, const Rows3& dirs, double t_min) {
    require_t_min(t_min);
    const size_t n = origins.shape(0);
    if (dirs.shape(0) != n) throw std::invalid_argument("origins and dirs differ in length");
    int32_t* count = new int32_t[n];
    double* t = new double[n];
    nb::capsule c_owner(count, [](void* p) noexcept { delete[] static_cast<int32_t*>(p); });
    nb::capsule t_owner(t, [](void* p) noexcept { delete[] static_cast<double*>(p); });
    {
        nb::gil_scoped_release release;
        for (size_t i = 0; i < n; ++i) {
            const phong::Ray ray{{origins(i, 0), origins(i, 1), origins(i, 2)}, {dirs(i, 0), dirs(i, 1), dirs(i, 2)}};
            count[i] = scene.count_hits(ray, t_min, HUGE_VAL, t[i]);
        }
    }
    return nb::make_tuple(nb::ndarray<nb::numpy, int32_t, nb::shape<-1>>(count, {n}, c_owner),
                          nb::ndarray<nb::numpy, double, nb::shape<-1>>(t, {n}, t_owner));
}

// The triangles' corners as the scene reads them (tests), (T, 3, 3) by input row.
nb::ndarray<nb::numpy, double, nb::shape<-1, 3, 3>> triangle_corners(const phong::Scene& scene) {
    const size_t n = scene.triangles.size();
    double* corners = new double[9 * n];
    nb::capsule owner(corners, [](void* p) noexcept { delete[] static_cast<double*>(p); });
    for (size_t slot = 0; slot < n; ++slot) {
        const phong::TriangleShape t = scene.triangles[slot];
        const phong::Vec3 v[3] = {t.v0, t.v1, t.v2};
        double* row = corners + 9 * size_t(scene.triangle_source[slot]);
        for (int i = 0; i < 3; ++i) {
            row[3 * i] = v[i].x;
            row[3 * i + 1] = v[i].y;
            row[3 * i + 2] = v[i].z;
        }
    }
    return nb::ndarray<nb::numpy, double, nb::shape<-1, 3, 3>>(corners, {n, 3, 3}, owner);
}

}  // namespace

// A vector's elements handed to numpy without a copy: the array owns the moved vector.
template <class T>
nb::ndarray<nb::numpy, T> to_numpy(std::vector<T>&& values, std::initializer_list<size_t> shape) {
    auto* owned = new std::vector<T>(std::move(values));
    nb::capsule owner(owned, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
    return nb::ndarray<nb::numpy, T>(owned->data(), shape, owner);
}

using Rows2 = In<double, nb::shape<-1, 2>>;
using Pairs = In<int32_t, nb::shape<-1, 2>>;
using Weights = In<float, nb::shape<-1>>;

// The USD reader's entry to OpenSubdiv (subdivision.hpp); phongscene/usd/subdivision.py has
// checked every index and count, the C++ asserts.
nb::dict refine_subdivision(const Rows3& points, const Index1& face_counts, const Index1& face_indices,
                            phong::SubdivisionScheme scheme, phong::BoundaryInterpolation boundary,
                            phong::FaceVaryingInterpolation face_varying, bool smooth_triangles,
                            const Pairs& crease_pairs, const Weights& crease_sharpness, const Index1& corner_indices,
                            const Weights& corner_sharpness, const Index1& holes, const Rows2& uvs,
                            const Index1& uv_indices, int level) {
    if (level < 1 || level > 10) throw std::invalid_argument("level must be in 1..10");
    if (crease_pairs.shape(0) != crease_sharpness.shape(0) || corner_indices.shape(0) != corner_sharpness.shape(0))
        throw std::invalid_argument("one sharpness per crease edge and per corner");
    if (uvs.shape(0) != 0 && uv_indices.shape(0) != face_indices.shape(0))
        throw std::invalid_argument("one uv index per face corner");
    phong::SubdivisionCage cage;
    cage.scheme = scheme;
    cage.boundary = boundary;
    cage.face_varying = face_varying;
    cage.smooth_triangles = smooth_triangles;
    cage.points = points.data();
    cage.point_count = int32_t(points.shape(0));
    cage.face_counts = face_counts.data();
    cage.face_count = int32_t(face_counts.shape(0));
    cage.face_indices = face_indices.data();
    cage.crease_pairs.assign(crease_pairs.data(), crease_pairs.data() + 2 * crease_pairs.shape(0));
    cage.crease_sharpness.assign(crease_sharpness.data(), crease_sharpness.data() + crease_sharpness.shape(0));
    cage.corner_indices.assign(corner_indices.data(), corner_indices.data() + corner_indices.shape(0));
    cage.corner_sharpness.assign(corner_sharpness.data(), corner_sharpness.data() + corner_sharpness.shape(0));
    cage.holes.assign(holes.data(), holes.data() + holes.shape(0));
    cage.uvs = uvs.data();
    cage.uv_count = int32_t(uvs.shape(0));
    cage.uv_indices = uv_indices.data();
    phong::RefinedSurface refined;
    {
        nb::gil_scoped_release release;
        refined = phong::refine_subdivision(cage, level);
    }
    const size_t v = refined.points.size() / 3, t = refined.base_face.size(), u = refined.uvs.size() / 2;
    nb::dict out;
    out["points"] = to_numpy(std::move(refined.points), {v, 3});
    out["normals"] = to_numpy(std::move(refined.normals), {v, 3});
    out["triangles"] = to_numpy(std::move(refined.triangles), {t, 3});
    out["base_face"] = to_numpy(std::move(refined.base_face), {t});
    out["uvs"] = to_numpy(std::move(refined.uvs), {u, 2});
    out["uv_triangles"] = to_numpy(std::move(refined.uv_triangles), {refined.uv_triangles.empty() ? 0 : t, 3});
    return out;
}

// Test-only (float_slab_lanes below): row r of `out` (15 floats) for ray r: the FloatSlabRay8
// a ray set up alone has (origin_near, origin_far and inv by axis, t_min, the near rows),
// FloatSlabRay::applies and far_limit; lanes = true: the same from FloatSlabLanes,
// kMaxRaysTogether rays at a time.
PHONG_AVX2 void float_slab_rows(const double* origins, const double* dirs, double t_min, const double* t_max, size_t n,
                                double magnitude, bool lanes, float* out) {
    auto write = [](float* row, const phong::FloatSlabRay8& f, bool applies, float far) PHONG_AVX2 {
        for (int k = 0; k < 3; ++k) {
            row[k] = _mm256_cvtss_f32(f.origin_near[k]);
            row[3 + k] = _mm256_cvtss_f32(f.origin_far[k]);
            row[6 + k] = _mm256_cvtss_f32(f.inv[k]);
            row[10 + k] = float(f.near_row[k]);
        }
        row[9] = _mm256_cvtss_f32(f.t_min);
        row[13] = applies ? 1.0f : 0.0f;
        row[14] = far;
    };
    std::vector<phong::Ray> rays(n);
    for (size_t i = 0; i < n; ++i)
        rays[i] = phong::Ray{{origins[3 * i], origins[3 * i + 1], origins[3 * i + 2]},
                             {dirs[3 * i], dirs[3 * i + 1], dirs[3 * i + 2]}};
    for (size_t first = 0; first < n; first += phong::kMaxRaysTogether) {
        const int count = int(std::min<size_t>(phong::kMaxRaysTogether, n - first));
        phong::FloatSlabLanes set;
        if (lanes) set.set_up(rays.data() + first, count, t_min, t_max + first, magnitude);
        for (int r = 0; r < count; ++r) {
            const phong::Ray& ray = rays[first + size_t(r)];
            phong::Deferred<phong::FloatSlabRay8> f;
            if (lanes) {
                set.emplace(r, f);
                write(out + 15 * (first + size_t(r)), *f, set.applies >> r & 1u, set.far_up[r]);
            } else {
                const phong::Vec3 inv{1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z};
                f.emplace(phong::FloatSlabOrigin(ray.origin), ray.dir, inv, t_min);
                write(out + 15 * (first + size_t(r)), *f,
                      phong::FloatSlabRay::applies(ray.origin, ray.dir, t_min, magnitude),
                      _mm_cvtss_f32(phong::FloatSlabRay::far_limit(t_max[first + size_t(r)])));
            }
        }
    }
}

// Test-only (group_box_tests below): for nodes of eight boxes (lo x, y, z, hi x, y, z each),
// out[node * (1 + n + 8) + ...]: the group's interval test (FloatSlabGroup8::hit), its per-ray
// test of each ray (ray_enters, n masks), then for each child i the rays entering it
// (rays_entering); and alone[node * n + r]: FloatSlabRay8::hit of ray r set up alone. Rays:
// n <= kMaxRaysTogether, each with FloatSlabLanes' applies and bounded bits, one sign per axis.
PHONG_AVX2 void group_box_rows(const phong::Ray* rays, int n, double t_min, const double* t_max, const double* boxes,
                               size_t nodes, double magnitude, uint64_t* out, uint64_t* alone) {
    phong::FloatSlabLanes lanes;
    lanes.set_up(rays, n, t_min, t_max, magnitude);
    const phong::RayBits all = n == 64 ? ~phong::RayBits(0) : (phong::RayBits(1) << n) - 1;
    if ((lanes.applies & lanes.bounded) != all)
        throw std::invalid_argument("group_box_tests: a ray the float test does not cover or bound");
    for (int k = 0; k < 3; ++k)
        if ((lanes.negative[k] & all) != 0 && (lanes.negative[k] & all) != all)
            throw std::invalid_argument("group_box_tests: the rays' direction signs differ");
    const phong::RaySetLanes set(all);
    phong::FloatSlabGroup8 group;
    group.set_up(lanes, all, set);
    for (size_t b = 0; b < nodes; ++b) {
        phong::Bvh8Node node{};
        for (int i = 0; i < 8; ++i)
            for (int row = 0; row < 6; ++row) node.boxes[row][i] = float(boxes[(8 * b + size_t(i)) * 6 + size_t(row)]);
        uint64_t* row = out + b * size_t(1 + n + 8);
        row[0] = uint64_t(group.hit(node));
        __m256 near_planes[3], far_planes[3];
        for (int k = 0; k < 3; ++k) {
            near_planes[k] = _mm256_load_ps(node.boxes[group.near_row[k]]);
            far_planes[k] = _mm256_load_ps(node.boxes[group.far_row[k]]);
        }
        for (int r = 0; r < n; ++r) row[1 + r] = group.ray_enters(near_planes, far_planes, r);
        for (int i = 0; i < 8; ++i) row[1 + n + i] = group.rays_entering(node, i, all);
        for (int r = 0; r < n; ++r) {
            const phong::Ray& ray = rays[r];
            const phong::Vec3 inv{1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z};
            const phong::FloatSlabRay8 f(phong::FloatSlabOrigin(ray.origin), ray.dir, inv, t_min);
            __m256 entry;
            alone[b * size_t(n) + size_t(r)] =
                uint64_t(f.hit(node, _mm256_set1_ps(_mm_cvtss_f32(phong::FloatSlabRay::far_limit(t_max[r]))), entry));
        }
    }
}

NB_MODULE(_native, m) {
    nb::enum_<phong::SubdivisionScheme>(m, "SubdivisionScheme")
        .value("catmull_clark", phong::SubdivisionScheme::kCatmullClark)
        .value("loop", phong::SubdivisionScheme::kLoop)
        .value("bilinear", phong::SubdivisionScheme::kBilinear);
    nb::enum_<phong::BoundaryInterpolation>(m, "BoundaryInterpolation")
        .value("none", phong::BoundaryInterpolation::kNone)
        .value("edge_only", phong::BoundaryInterpolation::kEdgeOnly)
        .value("edge_and_corner", phong::BoundaryInterpolation::kEdgeAndCorner);
    nb::enum_<phong::FaceVaryingInterpolation>(m, "FaceVaryingInterpolation")
        .value("none", phong::FaceVaryingInterpolation::kNone)
        .value("corners_only", phong::FaceVaryingInterpolation::kCornersOnly)
        .value("corners_plus1", phong::FaceVaryingInterpolation::kCornersPlus1)
        .value("corners_plus2", phong::FaceVaryingInterpolation::kCornersPlus2)
        .value("boundaries", phong::FaceVaryingInterpolation::kBoundaries)
        .value("all", phong::FaceVaryingInterpolation::kAll);
    m.def("refine_subdivision", &refine_subdivision, "points"_a, "face_counts"_a, "face_indices"_a, "scheme"_a,
          "boundary"_a, "face_varying"_a, "smooth_triangles"_a, "crease_pairs"_a, "crease_sharpness"_a,
          "corner_indices"_a, "corner_sharpness"_a, "holes"_a, "uvs"_a, "uv_indices"_a, "level"_a,
          "A subdivision surface's cage refined `level` times by OpenSubdiv: a dict of points (V, 3) on the "
          "limit surface, their limit normals (V, 3), triangles (T, 3), base_face (T) (the cage face of each), "
          "uvs (U, 2) and uv_triangles (T, 3) (empty without uvs). Hole faces give no triangles.");
    m.doc() = "phongscene native ray tracer (C++17)";
    m.def(
        "set_build_threads", [](unsigned threads) { phong::build_thread_cap().store(threads); }, "threads"_a,
        "Caps the threads a scene build uses (0: every core), for builds started afterwards in this process.");
    m.def("build_threads", [] { return phong::build_threads(); }, "The threads a scene build uses now.");
    m.def(
        "hardware_threads", [] { return std::thread::hardware_concurrency(); },
        "Number of hardware threads the tracer uses when threads=0.");
    m.def(
        "round_to_half",
        [](const In<float, nb::shape<-1>>& values) {
            const size_t n = values.shape(0);
            float* out = new float[n];
            for (size_t i = 0; i < n; ++i) out[i] = phong::round_to_half(values.data()[i]);
            nb::capsule owner(out, [](void* p) noexcept { delete[] static_cast<float*>(p); });
            return nb::ndarray<nb::numpy, float, nb::shape<-1>>(out, {n}, owner);
        },
        "values"_a, "Test-only: each value rounded to a half float and back, as set_textures(half_texels=True) does.");
    m.def(
        "float_slab_lanes",
        [](const Rows3& origins, const Rows3& dirs, double t_min, const In<double, nb::shape<-1>>& t_max,
           double magnitude, bool lanes) {
            const size_t n = origins.shape(0);
            if (dirs.shape(0) != n || t_max.shape(0) != n)
                throw std::invalid_argument("float_slab_lanes: origins, dirs and t_max differ in length");
            if (!phong::cpu_has_avx2()) throw std::runtime_error("float_slab_lanes: this CPU has no AVX2");
            float* out = new float[15 * n];
            float_slab_rows(origins.data(), dirs.data(), t_min, t_max.data(), n, magnitude, lanes, out);
            nb::capsule owner(out, [](void* p) noexcept { delete[] static_cast<float*>(p); });
            return nb::ndarray<nb::numpy, float, nb::shape<-1, 15>>(out, {n, 15}, owner);
        },
        "origins"_a, "dirs"_a, "t_min"_a, "t_max"_a, "magnitude"_a, "lanes"_a,
        "Test-only: each ray's float slab set-up (FloatSlabRay8's numbers, applies, far limit: 15 floats a "
        "row), alone (lanes=False) or 64 at a time in lanes (FloatSlabLanes, lanes=True). AVX2 only.");
    m.def(
        "group_box_tests",
        [](const Rows3& origins, const Rows3& dirs, double t_min, const Reals1& t_max,
           const In<double, nb::shape<-1, 6>>& boxes, double magnitude) {
            const size_t n = origins.shape(0), m = boxes.shape(0);
            if (dirs.shape(0) != n || t_max.shape(0) != n || n < 1 || n > size_t(phong::kMaxRaysTogether))
                throw std::invalid_argument("group_box_tests: 1 to 64 rays, origins, dirs and t_max alike");
            if (m % 8 != 0) throw std::invalid_argument("group_box_tests: boxes in nodes of eight");
            if (!phong::cpu_has_avx2()) throw std::runtime_error("group_box_tests: this CPU has no AVX2");
            std::vector<phong::Ray> rays(n);
            for (size_t i = 0; i < n; ++i)
                rays[i] = {{origins(i, 0), origins(i, 1), origins(i, 2)}, {dirs(i, 0), dirs(i, 1), dirs(i, 2)}};
            const size_t nodes = m / 8, width = 1 + n + 8;
            uint64_t* out = new uint64_t[nodes * width];
            nb::capsule out_owner(out, [](void* p) noexcept { delete[] static_cast<uint64_t*>(p); });
            uint64_t* alone = new uint64_t[nodes * n];
            nb::capsule alone_owner(alone, [](void* p) noexcept { delete[] static_cast<uint64_t*>(p); });
            group_box_rows(rays.data(), int(n), t_min, t_max.data(), boxes.data(), nodes, magnitude, out, alone);
            return nb::make_tuple(nb::ndarray<nb::numpy, uint64_t, nb::shape<-1, -1>>(out, {nodes, width}, out_owner),
                                  nb::ndarray<nb::numpy, uint64_t, nb::shape<-1, -1>>(alone, {nodes, n}, alone_owner));
        },
        "origins"_a, "dirs"_a, "t_min"_a, "t_max"_a, "boxes"_a, "magnitude"_a,
        "Test-only: a shadow-ray group's box tests (bvh8_group.hpp) of nodes of eight boxes: per node the group's "
        "interval test, each ray's test in the group, each child's entering rays (a row of 1 + n + 8 bit masks), "
        "and each ray's own FloatSlabRay8 test set up alone (n masks a node). AVX2 only.");
    m.def(
        "round_outward",
        [](const Rows3& rows) {
            const size_t n = rows.shape(0);
            float* out = new float[6 * n];
            for (size_t i = 0; i < n; ++i) {
                const phong::Vec3 o{rows(i, 0), rows(i, 1), rows(i, 2)};
                const phong::FloatSlabOrigin simd(o);
                const float scalar[6] = {phong::round_down(o.x), phong::round_down(o.y), phong::round_down(o.z),
                                         phong::round_up(o.x),   phong::round_up(o.y),   phong::round_up(o.z)};
                for (int k = 0; k < 3; ++k) {
                    out[6 * i + k] = simd.down[k];
                    out[6 * i + 3 + k] = simd.up[k];
                }
                // The lanes must give the scalar functions' floats bit for bit (NaN: any NaN), in
                // a ray's origin and in a primitive's box (a point's: its lo and hi are the row).
                phong::Bounds point;
                point.lo = point.hi = o;
                const phong::PrimRef box(point, uint32_t(i));
                if (box.id != uint32_t(i) || box.unused != 0) throw std::runtime_error("PrimRef's id or padding");
                for (int k = 0; k < 6; ++k) {
                    const float lanes[2] = {k < 3 ? simd.down[k] : simd.up[k - 3], k < 3 ? box.lo[k] : box.hi[k - 3]};
                    for (const float lane : lanes)
                        if (std::memcmp(&lane, &scalar[k], sizeof lane) != 0 &&
                            !(std::isnan(lane) && std::isnan(scalar[k])))
                            throw std::runtime_error("FloatSlabOrigin or PrimRef differs from round_down/round_up");
                }
            }
            nb::capsule owner(out, [](void* p) noexcept { delete[] static_cast<float*>(p); });
            return nb::ndarray<nb::numpy, float, nb::shape<-1, 6>>(out, {n, 6}, owner);
        },
        "rows"_a,
        "Test-only: each row's FloatSlabOrigin (down x, y, z, then up), checked (and a PrimRef of the row as a "
        "point) against the scalar round_down and round_up.");
    m.attr("SHADOW_WINDOW") = phong::kShadowWindow;
    m.attr("PRIMARY_NEAR") = phong::kPrimaryNear;
    m.attr("SELF_HIT_WINDOW") = phong::kSelfHitWindow;
    m.attr("ACNE_FREE_COSINE") = phong::kAcneFreeCosine;
    m.attr("MAX_CACHED_FLAT_NORMALS") = phong::kMaxCachedFlatNormals;

    nb::enum_<phong::SamplePattern>(m, "SamplePattern", "Where a pixel's primary rays go (render.hpp).")
        .value("grid", phong::SamplePattern::kGrid)
        .value("povray_am1", phong::SamplePattern::kPovrayAm1)
        .value("povray_am2", phong::SamplePattern::kPovrayAm2)
        .value("stratified", phong::SamplePattern::kStratified)
        .value("adaptive", phong::SamplePattern::kAdaptive);
    nb::enum_<phong::SpecularConvention>(m, "SpecularConvention", "Which Phong specular term (materials.hpp).")
        .value("seed", phong::SpecularConvention::kSeed)
        .value("povray_classic", phong::SpecularConvention::kPovrayClassic);
    nb::enum_<phong::TransmissionConvention>(m, "TransmissionConvention",
                                             "The radiance of a refracted ray: kt/eta^2 (book) or kt (povray).")
        .value("book", phong::TransmissionConvention::kBook)
        .value("povray", phong::TransmissionConvention::kPovray);
    nb::enum_<phong::Numerics>(m, "Numerics", "Which ray tolerances (math.hpp).")
        .value("scale_invariant", phong::Numerics::kScaleInvariant)
        .value("povray", phong::Numerics::kPovray)
        .value("povray_shadow_cache", phong::Numerics::kPovrayShadowCache);

    using phong::Material;
    nb::class_<Material>(m, "Material", "Suffern's Phong material (materials.hpp).")
        .def(nb::init<double, double, double, double, phong::RGB, phong::RGB>(), "ka"_a, "kd"_a, "ks"_a, "exponent"_a,
             "diffuse_color"_a, "specular_color"_a)
        .def_rw("ka", &Material::ka)
        .def_rw("kd", &Material::kd)
        .def_rw("ks", &Material::ks)
        .def_rw("exponent", &Material::exponent)
        .def_rw("diffuse_color", &Material::diffuse_color)
        .def_rw("specular_color", &Material::specular_color)
        .def_rw("diffuse_texture", &Material::diffuse_texture)
        .def_rw("specular_texture", &Material::specular_texture)
        .def_rw("normal_texture", &Material::normal_texture)
        .def_rw("opacity_texture", &Material::opacity_texture)
        .def_rw("opacity_threshold", &Material::opacity_threshold)
        .def_rw("emission", &Material::emission)
        .def_rw("kr", &Material::kr)
        .def_rw("reflective_color", &Material::reflective_color)
        .def_rw("kt", &Material::kt)
        .def_rw("ior", &Material::ior)
        .def_rw("fresnel", &Material::fresnel)
        .def_rw("interior_filter", &Material::interior_filter)
        .def_rw("checker_size", &Material::checker_size)
        .def_rw("instance_color", &Material::instance_color)
        .def_rw("checker_plane", &Material::checker_plane)
        .def_rw("checker_outline_width", &Material::checker_outline_width)
        .def_rw("checker_outline_color", &Material::checker_outline_color)
        .def_rw("checker_color", &Material::checker_color);

    nb::enum_<phong::Wrap>(m, "Wrap", "How a texture continues outside [0, 1] (textures.hpp).")
        .value("repeat", phong::Wrap::kRepeat)
        .value("clamp", phong::Wrap::kClamp)
        .value("mirror", phong::Wrap::kMirror)
        .value("black", phong::Wrap::kBlack);

    using phong::LightTerms;
    nb::class_<LightTerms>(m, "LightTerms", "Multipliers of a light's diffuse and specular terms (lights.hpp).")
        .def(nb::init<double, double>(), "diffuse"_a = 1.0, "specular"_a = 1.0)
        .def_rw("diffuse", &LightTerms::diffuse)
        .def_rw("specular", &LightTerms::specular);

    using phong::PointLight;
    nb::class_<PointLight>(m, "PointLight", "A point light, with POV-Ray's fade when fade_power > 0.")
        .def(nb::init<phong::Vec3, phong::RGB, double, double, bool>(), "position"_a, "color"_a, "fade_distance"_a,
             "fade_power"_a, "inverse_square"_a = false)
        .def_rw("position", &PointLight::position)
        .def_rw("color", &PointLight::color)
        .def_rw("fade_distance", &PointLight::fade_distance)
        .def_rw("fade_power", &PointLight::fade_power)
        .def_rw("inverse_square", &PointLight::inverse_square)
        .def_rw("cone_axis", &PointLight::cone_axis)
        .def_rw("cone_cos_outer", &PointLight::cone_cos_outer)
        .def_rw("cone_cos_inner", &PointLight::cone_cos_inner)
        .def_rw("cone_focus", &PointLight::cone_focus)
        .def_rw("terms", &PointLight::terms);

    using phong::DirectionalLight;
    nb::class_<DirectionalLight>(m, "DirectionalLight", "A light at infinity; made from the direction it travels.")
        .def(
            "__init__",
            [](DirectionalLight* self, const phong::Vec3& direction, const phong::RGB& color) {
                new (self) DirectionalLight(DirectionalLight::travelling(direction, color));
            },
            "direction"_a, "color"_a)
        .def_rw("to_light", &DirectionalLight::to_light)
        .def_rw("color", &DirectionalLight::color)
        .def_rw("terms", &DirectionalLight::terms);

    using phong::RectAreaLight;
    nb::class_<RectAreaLight>(m, "RectAreaLight", "A rectangular area light, samples x samples shadow rays.")
        .def(nb::init<phong::Vec3, phong::Vec3, phong::Vec3, phong::RGB, int, bool>(), "center"_a, "axis_u"_a,
             "axis_v"_a, "color"_a, "samples"_a, "inverse_square"_a = false)
        .def_rw("inverse_square", &RectAreaLight::inverse_square)
        .def_rw("center", &RectAreaLight::center)
        .def_rw("axis_u", &RectAreaLight::axis_u)
        .def_rw("axis_v", &RectAreaLight::axis_v)
        .def_rw("color", &RectAreaLight::color)
        .def_rw("samples", &RectAreaLight::samples)
        .def_rw("terms", &RectAreaLight::terms)
        .def_rw("adaptive", &RectAreaLight::adaptive, "POV-Ray's `adaptive n`; -1: every grid point (its default)")
        .def_rw("cell_samples", &RectAreaLight::cell_samples,
                "> 0: the native cells estimator, cell_samples^2 points per partial cell");

    using phong::SphereAreaLight;
    nb::class_<SphereAreaLight>(m, "SphereAreaLight", "A spherical light: POV-Ray's circular, oriented area light.")
        .def(nb::init<phong::Vec3, double, phong::RGB, int, bool>(), "center"_a, "radius"_a, "color"_a, "samples"_a,
             "inverse_square"_a = false)
        .def_rw("inverse_square", &SphereAreaLight::inverse_square)
        .def_rw("center", &SphereAreaLight::center)
        .def_rw("radius", &SphereAreaLight::radius)
        .def_rw("color", &SphereAreaLight::color)
        .def_rw("samples", &SphereAreaLight::samples)
        .def_rw("terms", &SphereAreaLight::terms)
        .def_rw("adaptive", &SphereAreaLight::adaptive, "POV-Ray's `adaptive n`; -1: every grid point (its default)")
        .def_rw("cell_samples", &SphereAreaLight::cell_samples,
                "> 0: the native cells estimator, cell_samples^2 points per partial cell");

    using phong::IntrinsicShape;
    nb::class_<IntrinsicShape>(m, "IntrinsicShape",
                               "A part of an intrinsic prim (intrinsics.hpp), in its object space.")
        .def(
            "__init__",
            [](IntrinsicShape* self, int kind, const std::array<double, 12>& object_from_world,
               const phong::Vec3& bounds_lo, const phong::Vec3& bounds_hi, double r0, double r1, double z0,
               int32_t material, int32_t object) {
                new (self) IntrinsicShape();
                self->kind = phong::IntrinsicKind(kind);
                for (int k = 0; k < 12; ++k) self->object_from_world.m[k] = object_from_world[size_t(k)];
                self->bounds_lo = bounds_lo;
                self->bounds_hi = bounds_hi;
                self->r0 = r0;
                self->r1 = r1;
                self->z0 = z0;
                self->material = material;
                self->object = object;
            },
            "kind"_a, "object_from_world"_a, "bounds_lo"_a, "bounds_hi"_a, "r0"_a, "r1"_a, "z0"_a, "material"_a,
            "object"_a,
            "kind: 0 box, 1 frustum, 2 disk, 3 square, 4 unbounded plane, 5 sphere; object_from_world: the 3x4 rows; "
            "bounds: its world AABB; object: the model node (light linking's numbering).");

    using phong::CameraDescription;
    nb::class_<CameraDescription>(m, "CameraDescription", "The model's camera (camera.hpp).")
        .def(nb::init<phong::Vec3, phong::Vec3, phong::Vec3, bool, double, double>(), "position"_a, "forward"_a, "up"_a,
             "orthographic"_a, "horizontal_fov_deg"_a, "ortho_width"_a)
        .def_rw("position", &CameraDescription::position)
        .def_rw("forward", &CameraDescription::forward)
        .def_rw("up", &CameraDescription::up)
        .def_rw("orthographic", &CameraDescription::orthographic)
        .def_rw("horizontal_fov_deg", &CameraDescription::horizontal_fov_deg)
        .def_rw("ortho_width", &CameraDescription::ortho_width);

    using phong::RenderSettings;
    nb::class_<RenderSettings>(m, "RenderSettings", "Image size, sampling, threads, background, convention.")
        .def(nb::init<int, int, int, phong::SamplePattern, int, phong::RGB, phong::SpecularConvention,
                      phong::Numerics>(),
             "width"_a, "height"_a, "samples"_a, "sample_pattern"_a, "threads"_a, "background"_a,
             "specular_convention"_a, "numerics"_a = phong::Numerics::kScaleInvariant)
        .def_rw("numerics", &RenderSettings::numerics)
        .def_rw("width", &RenderSettings::width)
        .def_rw("height", &RenderSettings::height)
        .def_rw("samples", &RenderSettings::samples)
        .def_rw("sample_pattern", &RenderSettings::sample_pattern)
        .def_rw("aa_threshold", &RenderSettings::aa_threshold)
        .def_rw("max_depth", &RenderSettings::max_depth)
        .def_rw("transmission_convention", &RenderSettings::transmission_convention)
        .def_rw("camera_interiors", &RenderSettings::camera_interiors)
        .def_rw("threads", &RenderSettings::threads)
        .def_rw("background", &RenderSettings::background)
        .def_rw("specular_convention", &RenderSettings::specular_convention);

    nb::class_<phong::Scene>(m, "Scene", "Geometry from flat arrays, materials and lights, with the BVH.")
        .def(
            "__init__",
            [](phong::Scene* self, const Matrices& swo, const Matrices& sow, const Index1& smat,
               const std::vector<Rows3>& points, const std::vector<Index3>& triangles,
               const std::vector<Rows3>& normals, const std::vector<Index3>& normal_indices,
               const Index1& mesh_material, const Rows3& mesh_origins, std::vector<phong::Material> materials,
               std::vector<phong::Light> lights, const phong::RGB& ambient, bool povray_triangles,
               std::vector<phong::IntrinsicShape> intrinsics, const std::vector<Rows3>& ball_centers,
               const std::vector<Reals1>& ball_radii, const std::vector<int32_t>& ball_material,
               const std::vector<int32_t>& ball_object) {
                std::unique_ptr<phong::Scene> built =
                    make_scene(swo, sow, smat, points, triangles, normals, normal_indices, mesh_material, mesh_origins,
                               std::move(materials), std::move(lights), ambient, povray_triangles,
                               std::move(intrinsics), ball_centers, ball_radii, ball_material, ball_object);
                new (self) phong::Scene(std::move(*built));
            },
            "sphere_world_from_object"_a, "sphere_object_from_world"_a, "sphere_material"_a, "points"_a, "triangles"_a,
            "normals"_a, "normal_indices"_a, "mesh_material"_a, "mesh_origins"_a, "materials"_a, "lights"_a,
            "ambient"_a, "povray_triangles"_a = false, "intrinsics"_a = std::vector<phong::IntrinsicShape>(),
            "ball_centers"_a = std::vector<Rows3>(), "ball_radii"_a = std::vector<Reals1>(),
            "ball_material"_a = std::vector<int32_t>(), "ball_object"_a = std::vector<int32_t>(),
            "points, triangles, normals and normal_indices are lists with one array per mesh (normal_indices "
            "(T, 3) or empty: flat; -1 rows: flat), read in place; triangles are numbered across the meshes in "
            "order. Materials are indexed by sphere_material and mesh_material; lights are summed in list order. "
            "Each mesh is one POV-Ray object with its frame's origin in mesh_origins; with povray_triangles, "
            "triangles are tested as POV-Ray's mesh2 tests them. Points sets: ball_centers (N, 3) and ball_radii "
            "(N,), one array each per set, read in place, with one ball_material and ball_object (light linking's "
            "object number) per set.")
        .def("set_textures", &set_textures, "images"_a, "wrap_s"_a, "wrap_t"_a, "corner_uv"_a,
             "uv_origin"_a = std::array<double, 2>{0.0, 0.0}, "uv_span"_a = std::array<double, 2>{1.0, 1.0},
             "half_texels"_a = false,
             "Textures (float32 (H, W, 3), row 0 at the top; held, not copied; with half_texels, copies in half "
             "floats), indexed by Material.diffuse_texture, specular_texture, normal_texture and opacity_texture, and "
             "the (u, v) "
             "of each triangle corner, (T, 3, 2) in input order; a lookup takes uv_origin + uv_span * (u, v).")
        .def("set_environment", &set_environment, "image"_a, "scale"_a, "dome_from_world"_a, "half_texels"_a = false,
             "The environment rays that hit nothing see (phongscene.scene.Environment): a lat-long image, float32 "
             "(H, W, 3), row 0 at the top (held, not copied; with half_texels, a copy in half floats), its RGB "
             "scale and the dome's frame from world space (row-major 3x3, orthogonal).")
        .def("set_light_links", &set_light_links, "shadows"_a, "lit"_a, "casts"_a,
             "Per light (one entry each): whether it casts shadow rays, and the objects (spheres 0..S-1, then meshes "
             "S + m) it illuminates and that cast its shadows, as uint8 arrays of one flag per object (empty: all).")
        .def(
            "add_instances",
            [](phong::Scene& self, phong::Scene& prototype, const Matrices& world_from_prototype, bool rebuild,
               std::optional<Rows3> colors) {
                if (&prototype == &self) throw std::invalid_argument("a scene cannot be its own prototype");
                if (!prototype.instances_empty()) throw std::invalid_argument("a prototype holds no instances");
                if (colors && colors->shape(0) != world_from_prototype.shape(0))
                    throw std::invalid_argument("colors must have one row per instance");
                auto taken = std::make_unique<phong::Scene>(std::move(prototype));
                nb::gil_scoped_release release;
                self.add_instances(std::move(taken), world_from_prototype.data(), world_from_prototype.shape(0),
                                   rebuild, colors ? colors->data() : nullptr);
            },
            "prototype"_a, "world_from_prototype"_a, "rebuild"_a = true, "colors"_a = nb::none(),
            "Adds copies of `prototype` (a Scene of its meshes in prototype space, taken over: it is empty "
            "afterwards), copy k placed by world_from_prototype[k] (K, 4, 4), column vectors, affine and "
            "invertible; the top-level BVH over every instance is rebuilt (rebuild=False: not yet, the scene cannot "
            "be traced until an add with rebuild=True). colors (K, 3): copy k's cd on the materials with "
            "instance_color (None: their own).")
        .def_prop_ro("instance_count", [](const phong::Scene& s) { return s.instances ? s.instances->size() : 0; })
        .def_prop_ro("prototype_count",
                     [](const phong::Scene& s) { return s.instances ? s.instances->prototype_count() : 0; })
        .def_prop_ro("magnitude", [](const phong::Scene& s) { return s.magnitude; })
        .def_prop_ro(
            "single_precision_triangles", [](const phong::Scene& s) { return s.triangles.single_precision(); },
            "Whether the triangles' corners are held as floats (every vertex a float: the same doubles).")
        .def_prop_ro(
            "triangle_storage",
            [](const phong::Scene& s) {
                if (!s.triangles.mesh_local()) return s.triangles.single_precision() ? "float" : "double";
                return s.triangles.keeps_world() ? "mesh frame and double" : "mesh frame";
            },
            "How the triangles' corners are held (triangle_store.hpp): 'float' or 'double' (world), or in "
            "POV-Ray's numerics 'mesh frame' (floats in each mesh's frame plus its origin: the same doubles), "
            "'mesh frame and double' where some point is not its float plus its origin.")
        .def("triangle_corners", &triangle_corners,
             "The triangles' corners as the tracer reads them, float64 (T, 3, 3) by input row (tests).")
        .def_prop_ro(
            "single_precision_normals", [](const phong::Scene& s) { return s.normals.single_precision(); },
            "Whether the meshes' normals are held as floats (every coordinate a float: the same doubles).")
        .def_prop_ro(
            "walk_width", [](const phong::Scene& s) { return s.walk_width(); },
            "Children per BVH node of the rays' walk: 8 on the AVX2 path, 4 on the SSE2 one (chosen when "
            "the scene is built; PHONGSCENE_NATIVE_SIMD=sse2 forces the portable path).")
        .def_prop_ro(
            "small_scene", [](const phong::Scene& s) { return s.small(); },
            "Whether the rays skip the BVH and test every primitive in lanes (small_scene.hpp: on the AVX2 path, at "
            "most 8 axis-aligned spheres and 8 triangles and no other bounded primitive or instance).")
        .def_prop_ro(
            "lane_lights", [](const phong::Scene& s) { return phong::lane_lights(s); },
            "Whether its lights allow a packet's primary hits to be lit in AVX2 lanes (lane_shading.hpp: the "
            "AVX2 path, no light links, only point lights without fade or cone).")
        .def_prop_ro(
            "leaf_count", [](const phong::Scene& s) { return s.leaf_count(); },
            "Leaves of the walk's BVH (how the SAH grouped the primitives; a root that is one leaf counts 1).")
        .def_prop_ro(
            "tree_digest", [](const phong::Scene& s) { return s.tree_digest(); },
            "A digest of the walk's BVH and leaf order (tests: equal digests, the same tree).")
        .def("render", &render, "camera"_a, "settings"_a, "progress"_a = nb::none(),
             "The image, float32 (height, width, 3), row 0 at the top. progress(done, total) is called from this "
             "thread while rendering; an exception it raises (or Ctrl-C) stops the render.")
        .def("intersect", &intersect, "origins"_a, "dirs"_a, "t_min"_a = 0.0,
             "Closest hit per ray (tests): (t, primitive id); spheres are 0..S-1, then triangles.")
        .def("occluded", &occluded, "origins"_a, "dirs"_a, "t_max"_a, "t_min"_a = 0.0, "together"_a = false,
             "Per ray, whether anything is hit in (t_min, t_max): shadow rays' any-hit walk, one thread; "
             "together=True: consecutive rays in 64s, walking the tree together as two packets' shadow rays do "
             "(tests compare the two).")
        .def("intersect_packets", &intersect_packets, "origin"_a, "dirs"_a, "t_min"_a = 0.0, "together"_a = true,
             "Closest hits of rays from one origin, 32 at a time as primary rays are (tests): (t, primitive id, "
             "barycentrics, packets that walked together); together=False: one by one.")
        .def("prefilter_check", &prefilter_check, "origins"_a, "dirs"_a,
             "The float triangle prefilter against the double test, every ray against every triangle (tests): "
             "per ray, the triangles it rejected that the double test hits at some t (must be 0), and the "
             "triangles it kept; -1 where it does not apply.")
        .def("count_hits", &count_hits, "origins"_a, "dirs"_a, "t_min"_a = 0.0,
             "Brute-force count of primitives hit per ray, and the closest t (tests).");
}
