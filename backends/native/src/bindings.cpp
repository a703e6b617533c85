// SPDX-License-Identifier: Apache-2.0
// Python bindings of the native tracer: the only file that includes nanobind. The Python
// wrapper (backends/native/__init__.py) flattens a phongscene.Scene into the arrays below.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "camera.hpp"
#include "render.hpp"
#include "scene.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

template <class T, class Shape>
using In = nb::ndarray<const T, Shape, nb::c_contig, nb::device::cpu>;

using Matrices = In<double, nb::shape<-1, 4, 4>>;
using Rows3 = In<double, nb::shape<-1, 3>>;
using Index3 = In<int32_t, nb::shape<-1, 3>>;
using Index1 = In<int32_t, nb::shape<-1>>;
using Table = In<double, nb::shape<-1, -1>>;
using Vector3 = In<double, nb::shape<3>>;

phong::Vec3 vec3(const Vector3& a) { return {a(0), a(1), a(2)}; }

std::unique_ptr<phong::Scene> make_scene(const Matrices& sphere_world_from_object,
                                         const Matrices& sphere_object_from_world, const Index1& sphere_material,
                                         const Rows3& points, const Index3& triangles, const Index1& triangle_material,
                                         const Rows3& normals, const Index3& normal_indices, const Table& materials,
                                         const Table& lights, const Vector3& ambient) {
    const size_t n_spheres = sphere_world_from_object.shape(0), n_triangles = triangles.shape(0);
    if (sphere_object_from_world.shape(0) != n_spheres || sphere_material.shape(0) != n_spheres)
        throw std::invalid_argument("sphere arrays differ in length");
    if (triangle_material.shape(0) != n_triangles || normal_indices.shape(0) != n_triangles)
        throw std::invalid_argument("triangle arrays differ in length");
    if (materials.shape(1) != phong::kMaterialColumns && materials.shape(0) > 0)
        throw std::invalid_argument("materials must have " + std::to_string(phong::kMaterialColumns) + " columns");
    if (lights.shape(1) != phong::kLightColumns && lights.shape(0) > 0)
        throw std::invalid_argument("lights must have " + std::to_string(phong::kLightColumns) + " columns");
    phong::SceneArrays a;
    a.sphere_world_from_object = sphere_world_from_object.data();
    a.sphere_object_from_world = sphere_object_from_world.data();
    a.sphere_material = sphere_material.data();
    a.sphere_count = n_spheres;
    a.points = points.data();
    a.point_count = points.shape(0);
    a.triangles = triangles.data();
    a.triangle_material = triangle_material.data();
    a.normal_indices = normal_indices.data();
    a.triangle_count = n_triangles;
    a.normals = normals.data();
    a.normal_count = normals.shape(0);
    a.materials = materials.data();
    a.material_count = materials.shape(0);
    a.lights = lights.data();
    a.light_count = lights.shape(0);
    a.ambient = vec3(ambient);
    // The arrays stay alive (held by the caller's frame) while the GIL is released.
    nb::gil_scoped_release release;
    return std::make_unique<phong::Scene>(a);
}

using Image = nb::ndarray<nb::numpy, float, nb::shape<-1, -1, 3>>;

Image render(const phong::Scene& scene, const Vector3& position, const Vector3& forward, const Vector3& up,
             bool orthographic, double horizontal_fov_deg, double ortho_width, int width, int height, int samples,
             const std::string& pattern, int threads, const Vector3& background, const std::string& specular,
             nb::object progress) {
    if (width < 1 || height < 1 || samples < 1) throw std::invalid_argument("width, height and samples must be >= 1");
    phong::RenderSettings settings;
    settings.width = width;
    settings.height = height;
    settings.samples = samples;
    if (pattern == "grid") settings.pattern = phong::SamplePattern::kGrid;
    else if (pattern == "povray-am1") settings.pattern = phong::SamplePattern::kPovrayAm1;
    else throw std::invalid_argument("unknown sample pattern '" + pattern + "'");
    if (specular == "seed") settings.convention = phong::SpecularConvention::kSeed;
    else if (specular == "povray-classic") settings.convention = phong::SpecularConvention::kPovrayClassic;
    else throw std::invalid_argument("unknown specular convention '" + specular + "'");
    settings.threads = threads;
    settings.background = vec3(background);
    const phong::Camera camera = phong::Camera::make(vec3(position), vec3(forward), vec3(up), orthographic,
                                                     horizontal_fov_deg, ortho_width, width, height);

    const size_t count = size_t(width) * size_t(height) * 3;
    float* pixels = new float[count]();
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
    return Image(pixels, {size_t(height), size_t(width), 3}, owner);
}

// Closest hit per ray through the BVH: (t, primitive id), t = inf and id = -1 on a miss.
nb::tuple intersect(const phong::Scene& scene, const Rows3& origins, const Rows3& dirs, double t_min) {
    const size_t n = origins.shape(0);
    if (dirs.shape(0) != n) throw std::invalid_argument("origins and dirs differ in length");
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
                id[i] = scene.primitive_id(hit.ref);
            } else {
                t[i] = HUGE_VAL;
                id[i] = -1;
            }
        }
    }
    return nb::make_tuple(nb::ndarray<nb::numpy, double, nb::shape<-1>>(t, {n}, t_owner),
                          nb::ndarray<nb::numpy, int64_t, nb::shape<-1>>(id, {n}, id_owner));
}

// Brute force over every primitive: (number of primitives hit, closest t).
nb::tuple count_hits(const phong::Scene& scene, const Rows3& origins, const Rows3& dirs, double t_min) {
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

}  // namespace

NB_MODULE(_native, m) {
    m.doc() = "phongscene native ray tracer (C++17)";
    m.def("hardware_threads", [] { return std::thread::hardware_concurrency(); },
          "Number of hardware threads the tracer uses when threads=0.");
    m.attr("MATERIAL_COLUMNS") = phong::kMaterialColumns;
    m.attr("LIGHT_COLUMNS") = phong::kLightColumns;
    m.attr("SHADOW_WINDOW") = phong::kShadowWindow;
    m.attr("PRIMARY_NEAR") = phong::kPrimaryNear;
    m.attr("SELF_HIT_WINDOW") = phong::kSelfHitWindow;
    m.attr("ACNE_FREE_COSINE") = phong::kAcneFreeCosine;

    nb::class_<phong::Scene>(m, "Scene", "A scene built from flat arrays, with its BVH.")
        .def("__init__",
             [](phong::Scene* self, const Matrices& swo, const Matrices& sow, const Index1& smat, const Rows3& points,
                const Index3& triangles, const Index1& tmat, const Rows3& normals, const Index3& nidx,
                const Table& materials, const Table& lights, const Vector3& ambient) {
                 std::unique_ptr<phong::Scene> built =
                     make_scene(swo, sow, smat, points, triangles, tmat, normals, nidx, materials, lights, ambient);
                 new (self) phong::Scene(std::move(*built));
             },
             "sphere_world_from_object"_a, "sphere_object_from_world"_a, "sphere_material"_a, "points"_a,
             "triangles"_a, "triangle_material"_a, "normals"_a, "normal_indices"_a, "materials"_a, "lights"_a,
             "ambient"_a)
        .def_prop_ro("magnitude", [](const phong::Scene& s) { return s.magnitude; })
        .def("render", &render, "position"_a, "forward"_a, "up"_a, "orthographic"_a, "horizontal_fov_deg"_a,
             "ortho_width"_a, "width"_a, "height"_a, "samples"_a, "pattern"_a, "threads"_a, "background"_a,
             "specular"_a, "progress"_a = nb::none())
        .def("intersect", &intersect, "origins"_a, "dirs"_a, "t_min"_a = 0.0,
             "Closest hit per ray (tests): (t, primitive id); spheres are 0..S-1, then triangles.")
        .def("count_hits", &count_hits, "origins"_a, "dirs"_a, "t_min"_a = 0.0,
             "Brute-force count of primitives hit per ray, and the closest t (tests).");
}
