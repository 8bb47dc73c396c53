// python/src/bind_lightmap.cpp - prt's Python module: scenes and SH lightmaps
// (Scene, load_scene, Lightmap, read_lightmap, precompute_lightmap,
// lightmap_from_rows, unwrap_scene, atlas_stats, lightmap_scene, write_scene;
// docs/LIGHTMAPS.md).
#include "module.h"

#include <prt/gltf.h>
#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/subsurface_scatter.h>
#include <prt/transfer_io.h>
#include <prt/unwrap.h>

#include <cmath>
#include <string>

namespace prt::python {
namespace {

// uv_set= (and Scene.lightmap_uv_set's requested=): -1 (choose) or 0 to
// kMaxLightmapUvSet, the rule of Scene::lightmap_uv_set, named here.
int uv_set_arg(int uv_set, const char* what) {
  if (uv_set < -1 || uv_set > prt::kMaxLightmapUvSet)
    throw Error(std::string(what) + ": " + std::to_string(uv_set) +
                ": expected -1 (choose: TEXCOORD_1 where every object has it, else TEXCOORD_0) or 0 to " +
                std::to_string(prt::kMaxLightmapUvSet) + " (TEXCOORD_N)");
  return uv_set;
}

// unwrap_scene, atlas_stats, lightmap_scene, write_scene (prt/unwrap.h).
void bind_unwrap(py::module_& m) {
  const auto stats_dict = [](const prt::AtlasStats& s) {
    return py::dict(py::arg("width") = s.width, py::arg("height") = s.height, py::arg("texel_size") = s.texel_size,
                    py::arg("charts") = s.charts, py::arg("covered_texels") = s.covered, py::arg("use") = s.use,
                    py::arg("max_stretch") = s.max_stretch, py::arg("max_area_ratio") = s.max_area_ratio,
                    py::arg("min_gap") = s.min_gap, py::arg("shared_texels") = s.shared_texels,
                    py::arg("degenerate_triangles") = s.degenerate, py::arg("seconds") = s.seconds);
  };
  m.def(
      "unwrap_scene",
      [stats_dict](const prt::Scene& scene, int width, int height, double texel_size, int padding, double max_stretch) {
        if (width < 1 || height < 1 || width > prt::kMaxLightmapSize || height > prt::kMaxLightmapSize)
          throw Error("unwrap_scene: width and height must be 1 to " + std::to_string(prt::kMaxLightmapSize));
        if (padding < 0 || padding > prt::kMaxUnwrapPadding)
          throw Error("unwrap_scene: padding must be 0 to " + std::to_string(prt::kMaxUnwrapPadding));
        if (!(texel_size >= 0) || !std::isfinite(texel_size)) throw Error("unwrap_scene: texel_size must be >= 0 and finite");
        if (!(max_stretch >= 1) || !(max_stretch <= 100)) throw Error("unwrap_scene: max_stretch must be 1 to 100");
        prt::UnwrapOptions o;
        o.width = width;
        o.height = height;
        o.texel_size = texel_size;
        o.padding = padding;
        o.max_stretch = max_stretch;
        prt::AtlasStats s;
        prt::Scene out;
        {
          py::gil_scoped_release release;
          out = prt::unwrap_scene(scene, o, &s);
        }
        return py::make_tuple(std::move(out), stats_dict(s));
      },
      py::arg("scene"), py::kw_only(), py::arg("width") = 1024, py::arg("height") = 1024, py::arg("texel_size") = 0.0,
      py::arg("padding") = 2, py::arg("max_stretch") = 1.05,
      "Lightmap UVs made by prt (prt unwrap; docs/LIGHTMAPS.md \"Lightmap UVs made by prt\"): returns (Scene, stats), "
      "the scene with one UV set more (its last; vertices split where charts meet) and the atlas's figures (a dict: "
      "charts, covered_texels, use, max_stretch, min_gap, ...).\n"
      "  width, height: the atlas to fill at the largest density that fits [--lightmap]; texel_size > 0: a texel's "
      "edge in scene units instead [--texel-size]; padding: empty texels between charts, 0 to 62 [--padding]; "
      "max_stretch: a triangle's largest anisotropy, 1 to 100 [--max-stretch].");
  m.def(
      "atlas_stats",
      [stats_dict](const prt::Scene& scene, int uv_set, int width, int height) {
        return stats_dict(prt::atlas_stats(scene, scene.lightmap_uv_set(uv_set_arg(uv_set, "uv_set")), width, height));
      },
      py::arg("scene"), py::arg("uv_set"), py::arg("width"), py::arg("height"),
      "The figures of the scene's UV set `uv_set` (0 to 7) as a width x height atlas (prt unwrap --measure-uv): a dict of "
      "charts, covered_texels, use, max_stretch, max_area_ratio, min_gap, shared_texels, degenerate_triangles.");
  m.def(
      "lightmap_scene",
      [](const prt::Scene& scene, const prt::LightmapTransfer& lightmap) {
        py::gil_scoped_release release;
        return prt::lightmap_scene(scene, lightmap.layout);
      },
      py::arg("scene"), py::arg("lightmap"),
      "The scene `lightmap` is laid out in: `scene` itself, or, where prt made its UVs (prt precompute --lightmap-uv "
      "auto), `scene` unwrapped again as it was then. Pass it to Lightmap.rows and Lightmap.relight.");
  m.def(
      "write_scene",
      [](const prt::Scene& scene, const py::object& path) {
        const std::string p = path_of(path, "path");
        py::gil_scoped_release release;
        prt::write_gltf_scene(p, scene, "prt (Python)");
      },
      py::arg("scene"), py::arg("path"),
      "Writes the scene to `path` as glTF 2.0 (.glb or .gltf; one node per object, world space, every UV set as "
      "TEXCOORD_n, materials and lights), as prt unwrap does: a temporary file, then renamed.");
}

// Scene, load_scene.
void bind_lightmap_scene(py::module_& m) {
  // ---- scenes and lightmaps (docs/LIGHTMAPS.md) ----
  py::class_<prt::Scene>(m, "Scene", "A scene (prt/scene.h): objects with materials and UV sets, flattened")
      .def_property_readonly("positions", [](const prt::Scene& s) { return vec3s(s.mesh.positions); },
                             "float32 (V, 3), world space")
      .def_property_readonly("normals", [](const prt::Scene& s) { return vec3s(s.mesh.normals); }, "float32 (V, 3)")
      .def_property_readonly("triangles",
                             [](const prt::Scene& s) {
                               return copy(reinterpret_cast<const std::uint32_t*>(s.mesh.triangles.data()),
                                           {py::ssize_t(s.mesh.triangles.size()), 3});
                             },
                             "uint32 (T, 3)")
      .def_property_readonly("uv_sets",
                             [](const prt::Scene& s) {
                               py::list l;
                               for (const auto& set : s.uv_sets)
                                 l.append(copy(reinterpret_cast<const float*>(set.data()), {py::ssize_t(set.size()), 2}));
                               return l;
                             },
                             "list of float32 (V, 2): TEXCOORD_0, TEXCOORD_1, ... (glTF: origin top-left, v down)")
      .def_property_readonly("objects",
                             [](const prt::Scene& s) {
                               py::list l;
                               for (const auto& o : s.objects)
                                 l.append(py::dict(py::arg("name") = o.name, py::arg("first_triangle") = o.first_triangle,
                                                   py::arg("triangle_count") = o.triangle_count,
                                                   py::arg("material") = o.material, py::arg("uv_sets") = o.uv_sets));
                               return l;
                             })
      .def_property_readonly("hash", &prt::Scene::hash, "Scene hash (a lightmap's scene_hash)")
      .def_property_readonly("lights", [](const prt::Scene& s) { return s.lights; },
                             "list of Light: the glTF's KHR_lights_punctual lights, placed by their nodes (none for "
                             "OBJ): what prt relight and prt reference light the scene with unless --lights none. "
                             "A copy: pass it (plus read_lights(path)) as lights= to light with them")
      .def(
          "lightmap_uv_set",
          [](const prt::Scene& s, int requested) { return s.lightmap_uv_set(uv_set_arg(requested, "requested")); },
          py::arg("requested") = -1,
          "The UV set a lightmap is laid out in: `requested` (0 to 7, TEXCOORD_N; every object must have it) or, "
          "with -1, TEXCOORD_1 when every object has two sets, else TEXCOORD_0 (prt precompute --uv). Raises "
          "prt.Error for any other number, and naming the objects that lack the set.")
      .def("__repr__", [](const prt::Scene& s) { return "<prt.Scene " + prt::describe(s) + ">"; });

  m.def(
      "load_scene",
      [](const py::object& path) {
        const std::string p = path_of(path, "path");
        py::gil_scoped_release release;
        return prt::load_scene(p);
      },
      py::arg("path"), "Reads the glTF 2.0 (.gltf, .glb) or OBJ scene at `path` as prt precompute --lightmap does: its objects, materials and UV sets, flattened into world space. Returns a Scene.");
}

// Lightmap, read_lightmap.
void bind_lightmap_transfer(py::module_& m) {
  py::class_<prt::LightmapTransfer>(m, "Lightmap", "An SH lightmap (prt/lightmap.h): transfer per covered texel")
      .def_property_readonly("width", [](const prt::LightmapTransfer& l) { return l.layout.width; })
      .def_property_readonly("height", [](const prt::LightmapTransfer& l) { return l.layout.height; })
      .def_property_readonly("uv_set", [](const prt::LightmapTransfer& l) { return l.layout.uv_set; })
      .def_property_readonly("scene_hash", [](const prt::LightmapTransfer& l) { return l.layout.scene_hash; })
      .def_property_readonly("bands", [](const prt::LightmapTransfer& l) { return l.transfer.bands; })
      .def_property_readonly("channels", [](const prt::LightmapTransfer& l) { return l.transfer.channels; })
      .def_property_readonly("mode", [](const prt::LightmapTransfer& l) {
        return std::string(prt::transfer_mode_name(l.transfer.mode));
      })
      .def_property_readonly("texels",
                             [](const prt::LightmapTransfer& l) {
                               return copy(l.layout.texels.data(), {py::ssize_t(l.layout.texels.size())});
                             },
                             "uint32 (N,): covered texels, y * width + x (rows from the top)")
      .def_property_readonly("analytic",
                             [](const prt::LightmapTransfer& l) {
                               py::array_t<bool> a(py::ssize_t(l.transfer.vertices));
                               for (std::size_t i = 0; i < l.transfer.vertices; ++i)
                                 a.mutable_at(i) = l.transfer.is_analytic(i);
                               return a;
                             },
                             "bool (N,): texels that store no row (nothing occludes them)")
      .def_property_readonly("interpolated_texels",
                             [](const prt::LightmapTransfer& l) { return l.transfer.interpolated_vertices(); },
                             "How many texels were interpolated from traced neighbours (adaptive sample points, prt "
                             "precompute --lightmap WxH --adaptive); 0 when every texel was traced")
      .def_property_readonly("interpolated",
                             [](py::object self) -> py::object {
                               const auto& l = self.cast<const prt::LightmapTransfer&>();
                               const std::vector<std::uint8_t>& mask = l.transfer.interpolated;
                               if (mask.empty()) return py::none();
                               return view(mask.data(), {py::ssize_t(mask.size())}, self);
                             },
                             "uint8 (N,), read-only: 1 where the texel's transfer was interpolated from traced "
                             "neighbours (precompute_lightmap(adaptive=...), prt precompute --adaptive), 0 where it "
                             "was traced; None when every texel was traced (the file has no interpolated-texel mask)")
      .def(
          "rows",
          [](const prt::LightmapTransfer& l, const prt::Scene& scene) {
            const prt::LightmapTexels tx = prt::lightmap_texels(scene, l.layout.width, l.layout.height, l.layout.uv_set,
                                                                l.transfer.vertex_colors ? nullptr : &l.transfer.albedo);
            prt::check_matches(l, tx, "lightmap");
            const std::vector<float> d = prt::dense_transfer(l.transfer, prt::texel_points(tx));
            return copy(d.data(), {py::ssize_t(l.transfer.vertices), l.transfer.channels,
                                   py::ssize_t(l.transfer.bands) * l.transfer.bands});
          },
          py::arg("scene"),
          "float32 (N, channels, bands^2): every covered texel's transfer, analytic ones evaluated from `scene`")
      .def(
          "relight",
          [](const prt::LightmapTransfer& l, const prt::Scene& scene, const py::object& lighting,
             const py::object& lights) {
            const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
            if (light.size() < std::size_t(l.transfer.bands) * l.transfer.bands)
              throw Error("lighting: fewer coefficients than the lightmap's bands^2");
            const std::vector<prt::Light> ls = lights_arg(lights);
            if (!ls.empty() && l.transfer.subsurface)  // as prt relight's --lights on a translucent lightmap
              throw Error(std::string("lights=: ") + prt::kTranslucentLightsWhy);
            std::vector<glm::vec4> img;
            {
              py::gil_scoped_release release;
              prt::LightmapTexels tx =
                  prt::lightmap_texels(scene, l.layout.width, l.layout.height, l.layout.uv_set,
                                       l.transfer.vertex_colors ? nullptr : &l.transfer.albedo);
              prt::check_matches(l, tx, "lightmap");
              std::vector<glm::vec3> rgb = prt::relight_lightmap(l, tx, light);
              if (!ls.empty()) {
                // The lights at the points prt precompute traced from: the
                // texels moved out of geometry as it moves them (prt relight's
                // add_texel_lights), so that the bits are the command's.
                prt::move_texels_out_of_geometry(scene.mesh, tx);
                add_direct_light(rgb, ls, scene.mesh, tx.positions, tx.normals, tx.albedo, std::nullopt,
                                 l.transfer.light_bounce);  // their bounce with an operator (--light-bounce)
              }
              img = prt::lightmap_image(l.layout, rgb);
            }
            return copy(reinterpret_cast<const float*>(img.data()), {l.layout.height, l.layout.width, 4});
          },
          py::arg("scene"), py::arg("lighting"), py::kw_only(), py::arg("lights") = py::none(),
          "The lightmap relit on `scene` (the Scene it was computed for), as prt relight SCENE LIGHTMAP ENV "
          "[--lights ...] -o x.exr: float32 (H, W, 4), its EXR (RGB linear radiance, A = 1 at covered texels, gutters "
          "filled).\n"
          "\n"
          "Arguments:\n"
          "  scene: the Scene.\n"
          "  lighting: coefficients (n*n, 3) (project()), at least the lightmap's bands^2.\n"
          "  lights: a list of Light (None: none): their direct light, traced against the scene at the texels' sample "
          "points, is added [--lights]. Only these: the scene's own (scene.lights) are added by passing them too. "
          "The sun split (--sun auto) takes the map, which SH lighting no longer is: split_sun(map) first, project "
          "the sky, and pass the sun in lights= (docs/LIGHTS.md).")
      .def("write", [](const prt::LightmapTransfer& l, const py::object& path) {
        prt::write_lightmap_transfer(path_of(path, "path"), l);
      }, py::arg("path"), "Writes the lightmap file to `path` (docs/FORMAT.md), atomically (a temporary file, then renamed).")
      .def("__repr__", [](const prt::LightmapTransfer& l) {
        return "<prt.Lightmap " + std::to_string(l.layout.width) + "x" + std::to_string(l.layout.height) + ", " +
               std::to_string(l.layout.texels.size()) + " covered texels, " + std::to_string(l.transfer.bands) +
               " bands>";
      });

  m.def("read_lightmap", [](const py::object& path) { return prt::read_lightmap_transfer(path_of(path, "path")); },
        py::arg("path"), "Reads the lightmap file at `path` (prt precompute SCENE --lightmap WxH). Returns a Lightmap.");
  bind_unwrap(m);  // after Lightmap: its signatures name the class
}

// precompute_lightmap, lightmap_from_rows.
void bind_lightmap_compute(py::module_& m) {
  m.def(
      "precompute_lightmap",
      [](const prt::Scene& scene, int width, int height, int uv_set, const std::string& mode, int bands, int samples,
         int bounces, std::uint64_t seed, const py::object& adaptive, double verify_adaptive, bool adaptive_any,
         bool light_bounce, double bounce_patch, double bounce_ratio, int bounce_clusters,
         const py::object& bounce_probes, const std::string& material, const py::object& sss,
         const py::object& sigma_a, const py::object& sigma_s, const py::object& eta, double length_scale) {
        // As prt precompute --lightmap: diffuse (the scene's albedo), or a
        // translucent material's (--material subsurface); not glossy.
        const bool translucent = material == "subsurface";
        if (material != "diffuse" && !translucent)
          throw Error("material: a lightmap is 'diffuse' or 'subsurface', got '" + material + "'");
        check_subsurface_given(material, sss, sigma_a, sigma_s, eta, length_scale);
        if (translucent)  // a lightmap takes no basis or albedo: those of the diffuse SH default
          check_subsurface_args("sh", mode, py::float_(0.8), false, !adaptive.is_none(), light_bounce);
        const std::optional<prt::SubsurfaceRecord> sss_record =
            translucent ? std::optional(subsurface_arg(sss, sigma_a, sigma_s, eta, length_scale)) : std::nullopt;
        prt::TransferOptions o;
        o.mode = prt::parse_transfer_mode(mode);
        o.bands = bands;
        o.samples = samples;
        o.bounces = bounces;
        o.seed = seed;
        light_bounce_args(o, light_bounce, bounce_patch, bounce_ratio, bounce_clusters, bounce_probes);
        const std::optional<prt::AdaptiveOptions> adapt = adaptive_arg(adaptive, verify_adaptive, adaptive_any, samples);
        uv_set_arg(uv_set, "uv_set");
        py::gil_scoped_release release;
        const int set = scene.lightmap_uv_set(uv_set);
        // As the command: an atlas the machine's memory cannot hold is refused
        // from its UV area, before its texels are rasterised.
        prt::TransferOptions planned = o;
        planned.memory_limit = prt::default_memory_limit();
        prt::check_lightmap_memory(scene, width, height, set, planned, adapt.has_value());
        prt::LightmapTexels tx = prt::lightmap_texels(scene, width, height, set);
        prt::move_texels_out_of_geometry(scene.mesh, tx);
        if (sss_record) {  // the texels' transmitted light summed by the profile (compute_subsurface_lightmap)
          prt::SubsurfaceScatterOptions so;
          so.length_scale = sss_record->length_scale;
          return prt::compute_subsurface_lightmap(scene, tx, o, sss_record->material, so);
        }
        return adapt ? prt::compute_adaptive_lightmap_transfer(scene, tx, o, *adapt)
                     : prt::compute_lightmap_transfer(scene, tx, o);
      },
      py::arg("scene"), py::arg("width"), py::arg("height"), py::kw_only(), py::arg("uv_set") = -1,
      py::arg("mode") = "shadowed", py::arg("bands") = 5, py::arg("samples") = 1024, py::arg("bounces") = 1,
      py::arg("seed") = 1, py::arg("adaptive") = py::none(), py::arg("verify_adaptive") = 0.0,
      py::arg("adaptive_any") = false, py::arg("light_bounce") = false, py::arg("bounce_patch") = 0.0,
      py::arg("bounce_ratio") = prt::kLightBounceRatio, py::arg("bounce_clusters") = prt::kLightBounceClusters,
      py::arg("bounce_probes") = py::none(), py::arg("material") = "diffuse", py::arg("sss") = py::none(),
      py::arg("sigma_a") = py::none(), py::arg("sigma_s") = py::none(), py::arg("eta") = py::none(),
      py::arg("length_scale") = kDefaultLengthScale,
      "The SH lightmap prt precompute SCENE --lightmap WxH computes (the same bits). Releases the GIL.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  scene: a Scene (load_scene).\n"
      "  width, height: the atlas in texels, 1 to 16384 each [--lightmap WxH].\n"
      "  uv_set: the scene's UV set the atlas is laid out in, 0 to 7 (TEXCOORD_N), or -1: TEXCOORD_1 where every object has it, else TEXCOORD_0 [--uv].\n"
      "  bands (1 to 16) [--bands], samples (rays per texel) [--samples], mode [--mode], bounces [--bounces], seed [--seed]: as precompute's.\n"
      "  adaptive [--adaptive [TOL]], verify_adaptive [--verify-adaptive], adaptive_any [--adaptive-any]: as precompute's, among the texels: None traces every texel; 0 (the default TOL) or a TOL in (0, 1) traces a subset and interpolates the rest from neighbouring texels of the same chart. The Lightmap's .interpolated marks the interpolated texels.\n"
      "  light_bounce [--light-bounce], bounce_patch [--bounce-patch] (0: a few texels), bounce_ratio [--bounce-ratio], bounce_clusters [--bounce-clusters], bounce_probes [--probes with --light-bounce]: the lights' bounce operator among the texels (and at a probe grid's probes), as precompute's.\n"
      "  material: 'diffuse' (the scene's materials' albedo); or 'subsurface': a translucent material's RGB lightmap, the light entering the surface around each texel scattered under it (shadowed or interreflected; no adaptive or light_bounce; docs/SUBSURFACE.md) [--material].\n"
      "  sss, sigma_a, sigma_s, eta, length_scale: material='subsurface': the material and millimetres per scene unit, as precompute's [--sss, --sigma-a, --sigma-s, --eta, --length-scale].\n"
      "\n"
      "Returns a Lightmap.");

  m.def(
      "lightmap_from_rows",
      [](const prt::Scene& scene, int width, int height, const py::object& rows, int uv_set, const std::string& mode) {
        FArray a = real_array<float>(rows, "rows");
        const int set = scene.lightmap_uv_set(uv_set_arg(uv_set, "uv_set"));
        const prt::LightmapTexels tx = prt::lightmap_texels(scene, width, height, set);
        const std::size_t n = tx.layout.texels.size();
        if (a.ndim() != 3 || std::size_t(a.shape(0)) != n || (a.shape(1) != 1 && a.shape(1) != 3))
          throw Error("rows: expected float32 (" + std::to_string(n) + ", 1 or 3, bands^2) for this atlas's covered texels");
        const int bands = int(std::lround(std::sqrt(double(a.shape(2)))));
        if (bands < 1 || bands * bands != a.shape(2)) throw Error("rows: the last axis must be bands^2");
        prt::LightmapTransfer l;
        l.layout = tx.layout;
        prt::Transfer& t = l.transfer;
        t.bands = bands;
        t.channels = int(a.shape(1));
        t.mode = prt::parse_transfer_mode(mode);
        t.vertices = n;
        t.vertex_colors = true;
        t.mesh_hash = tx.layout.scene_hash;
        t.shading_hash = prt::shading_hash(prt::texel_points(tx), true);
        t.coeffs.assign(a.data(), a.data() + a.size());
        if (auto p = prt::lightmap_problem(l); !p.empty()) throw Error("rows: " + p);
        return l;
      },
      py::arg("scene"), py::arg("width"), py::arg("height"), py::arg("rows"), py::kw_only(), py::arg("uv_set") = -1,
      py::arg("mode") = "shadowed",
      "A lightmap from arrays, for a Scene: every texel of the atlas stored (none analytic); .write() makes a file prt relight reads.\n"
      "\n"
      "Arguments:\n"
      "  scene: the Scene; width, height: the atlas in texels, 1 to 16384 each; uv_set: its UV set, 0 to 7 (-1: as precompute_lightmap).\n"
      "  rows: float32 (N, channels, bands^2), one per covered texel, in texel order.\n"
      "  mode: the transfer mode recorded ('shadowed', 'interreflected', ...).\n"
      "\n"
      "Returns a Lightmap.");
}

}  // namespace

void bind_lightmap(py::module_& m) {
  bind_lightmap_scene(m);
  bind_lightmap_transfer(m);
  bind_lightmap_compute(m);
}

}  // namespace prt::python
