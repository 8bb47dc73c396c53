// python/src/bind_lightmap.cpp - prt's Python module: scenes and SH lightmaps
// (Scene, load_scene, Lightmap, read_lightmap, precompute_lightmap,
// lightmap_from_rows, unwrap_scene, atlas_stats, lightmap_scene, write_scene;
// directional lightmaps: Lightmap.relight_directional, .write_directional;
// docs/LIGHTMAPS.md).
#include "module.h"

#include <prt/gltf.h>
#include <prt/lightmap.h>
#include <prt/lightmap_directional.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/subsurface_scatter.h>
#include <prt/transfer_io.h>
#include <prt/unwrap.h>

#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

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

// pages= (precompute_lightmap, lightmap_from_rows, unwrap_scene): 1 to
// kMaxLightmapPages, or 'auto' (0), as prt precompute's and prt unwrap's --pages.
int pages_arg(const py::object& pages) {
  const std::string rule = "pages: must be 1 to " + std::to_string(prt::kMaxLightmapPages) + " (UDIM tiles 1001 to " +
                           std::to_string(1000 + prt::kMaxLightmapPages) + ") or 'auto', got ";
  if (py::isinstance<py::str>(pages)) {
    const std::string text = pages.cast<std::string>();
    if (text == "auto") return 0;
    throw Error(rule + "'" + text + "'");
  }
  const int n = int_arg(pages, "pages");
  if (n < 1 || n > prt::kMaxLightmapPages) throw Error(rule + std::to_string(n));
  return n;
}

// "lightmap size WxH is outside 1..16384", as prt::lightmap_texels words it,
// checked before a size is multiplied by the pages.
void check_page_size(int width, int height) {
  if (width < 1 || height < 1 || width > prt::kMaxLightmapSize || height > prt::kMaxLightmapSize)
    throw Error("lightmap size " + std::to_string(width) + "x" + std::to_string(height) + " is outside 1.." +
                std::to_string(prt::kMaxLightmapSize));
}

// A lightmap of the scene's own UVs, as prt precompute --lightmap WxH --pages
// N|auto [--uv N] takes them (load_scene_to_bake in
// tools/prt/lightmap_inputs.cpp): width x height pages in UV set `uv_set`
// (-1: chosen), `pages` 0 ('auto': the tiles the set uses) or 1 to 10, and
// the scene with those pages stacked (prt::stack_lightmap_pages; none kept
// for one page: the scene itself). Without the GIL.
struct OwnAtlas {
  std::optional<prt::Scene> stacked;
  prt::LightmapLayout atlas;
  const prt::Scene& scene(const prt::Scene& given) const { return stacked ? *stacked : given; }
};
OwnAtlas own_atlas(const prt::Scene& scene, int width, int height, int uv_set, int pages) {
  check_page_size(width, height);
  OwnAtlas out;
  out.atlas.uv_set = scene.lightmap_uv_set(uv_set);
  if (pages == 0) pages = prt::lightmap_pages_used(scene, out.atlas.uv_set);
  out.atlas.width = width;
  out.atlas.pages = pages;
  out.atlas.height = height * pages;
  if (pages > 1) out.stacked = prt::stack_lightmap_pages(scene, out.atlas.uv_set, pages);
  return out;
}

// The lightmap's texels on `scene`, checked against its own (check_matches).
// A layout of many pages or of UVs prt made is not in the scene's UVs as
// loaded: that mistake is named, with the call that mends it.
prt::LightmapTexels texels_on(const prt::LightmapTransfer& l, const prt::Scene& scene) {
  const prt::LightmapLayout& a = l.layout;
  if ((a.pages > 1 || a.unwrap_padding >= 0) && scene.hash() != a.scene_hash)
    throw Error("scene: the lightmap was computed for another scene (scene hashes differ); its atlas (" +
                prt::lightmap_size_text(a) + ") is laid out " +
                (a.unwrap_padding >= 0 ? "in UVs prt made" : "in UV tiles stacked into one atlas") +
                ": pass lightmap_scene(scene, lightmap), the scene it was laid out in");
  prt::LightmapTexels tx = prt::lightmap_texels(scene, a, l.transfer.vertex_colors ? nullptr : &l.transfer.albedo);
  prt::check_matches(l, tx, "lightmap");
  return tx;
}

// unwrap_scene, atlas_stats, lightmap_scene, write_scene (prt/unwrap.h).
void bind_unwrap(py::module_& m) {
  const auto stats_dict = [](const prt::AtlasStats& s) {
    return py::dict(py::arg("width") = s.width, py::arg("height") = s.height, py::arg("pages") = s.pages,
                    py::arg("texel_size") = s.texel_size,
                    py::arg("charts") = s.charts, py::arg("covered_texels") = s.covered, py::arg("use") = s.use,
                    py::arg("max_stretch") = s.max_stretch, py::arg("max_area_ratio") = s.max_area_ratio,
                    py::arg("min_gap") = s.min_gap, py::arg("shared_texels") = s.shared_texels,
                    py::arg("degenerate_triangles") = s.degenerate, py::arg("seconds") = s.seconds);
  };
  m.def(
      "unwrap_scene",
      [stats_dict](const prt::Scene& scene, int width, int height, double texel_size, int padding, double max_stretch,
                   const py::object& pages) {
        if (width < 1 || height < 1 || width > prt::kMaxLightmapSize || height > prt::kMaxLightmapSize)
          throw Error("unwrap_scene: width and height must be 1 to " + std::to_string(prt::kMaxLightmapSize));
        // As prt unwrap --pages: N pages filled at the largest density, or
        // 'auto' (0): as many width x height pages as texel_size takes.
        const int n = pages_arg(pages);
        if (n == 0 && texel_size == 0)
          throw Error("pages: 'auto' takes texel_size > 0: the density that decides how many pages the charts take");
        if (n > 1 && texel_size > 0)
          throw Error("pages: " + std::to_string(n) + " pages are filled at the largest density that fits: it takes "
                      "no texel_size (pages='auto' does: width x height pages at that density)");
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
        o.pages = n;
        prt::AtlasStats s;
        prt::Scene out;
        {
          py::gil_scoped_release release;
          out = prt::unwrap_scene(scene, o, &s);
        }
        return py::make_tuple(std::move(out), stats_dict(s));
      },
      py::arg("scene"), py::kw_only(), py::arg("width") = 1024, py::arg("height") = 1024, py::arg("texel_size") = 0.0,
      py::arg("padding") = 2, py::arg("max_stretch") = 1.05, py::arg("pages") = 1,
      "Lightmap UVs made by prt (prt unwrap; docs/LIGHTMAPS.md \"Lightmap UVs made by prt\"): returns (Scene, stats), "
      "the scene with one UV set more (its last; vertices split where charts meet) and the atlas's figures (a dict: "
      "width, height (pages stacked: pages x a page's height), pages, charts, covered_texels, use, max_stretch, "
      "min_gap, ...).\n"
      "  width, height: the atlas (a page) to fill at the largest density that fits [--lightmap]; texel_size > 0: a "
      "texel's edge in scene units instead [--texel-size]; padding: empty texels between charts, 0 to 62 "
      "[--padding]; max_stretch: a triangle's largest anisotropy, 1 to 100 [--max-stretch].\n"
      "  pages: a lightmap of many pages [--pages], page p in UV tile u in [p, p + 1] (UDIM tile 1001 + p): 1 to 10 "
      "width x height pages filled at the largest density that fits (texel_size 0), or 'auto' with texel_size > 0: as "
      "many width x height pages as the charts take at that density. 1 (the default): one atlas, UVs in [0, 1].");
  m.def(
      "atlas_stats",
      [stats_dict](const prt::Scene& scene, int uv_set, int width, int height) {
        const int set = scene.lightmap_uv_set(uv_set_arg(uv_set, "uv_set"));
        check_page_size(width, height);
        prt::AtlasStats s;
        {
          py::gil_scoped_release release;
          // As --measure-uv: a set on many UV tiles is measured as its pages stacked.
          const int pages = prt::lightmap_pages_used(scene, set);
          s = pages == 1 ? prt::atlas_stats(scene, set, width, height)
                         : prt::atlas_stats(prt::stack_lightmap_pages(scene, set, pages), set, width, height * pages);
          s.pages = pages;
        }
        return stats_dict(s);
      },
      py::arg("scene"), py::arg("uv_set"), py::arg("width"), py::arg("height"),
      "The figures of the scene's UV set `uv_set` (0 to 7) as a width x height atlas (prt unwrap --measure-uv): a dict of "
      "width, height, pages, charts, covered_texels, use, max_stretch, max_area_ratio, min_gap, shared_texels, "
      "degenerate_triangles. A set whose UVs lie on many UV tiles (u in [p, p + 1]: page p, UDIM 1001 + p) is "
      "measured as that many width x height pages, stacked (height: pages x height).");
  m.def(
      "lightmap_scene",
      [](const prt::Scene& scene, const prt::LightmapTransfer& lightmap) {
        py::gil_scoped_release release;
        return prt::lightmap_scene(scene, lightmap.layout);
      },
      py::arg("scene"), py::arg("lightmap"),
      "The scene `lightmap` is laid out in: `scene` itself, or, where prt made its UVs (prt precompute --lightmap-uv "
      "auto), `scene` unwrapped again as it was then; for a lightmap of many pages, with the UV set's tiles (page p: "
      "u in [p, p + 1]) stacked into one atlas (page p's rows p * page_height onwards). Pass it to Lightmap.rows, "
      "Lightmap.relight and render.");
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
      .def_property_readonly("width", [](const prt::LightmapTransfer& l) { return l.layout.width; },
                             "The atlas's width in texels (a page's)")
      .def_property_readonly("height", [](const prt::LightmapTransfer& l) { return l.layout.height; },
                             "The atlas's rows: every page's stacked, pages x page_height (page_height for one page)")
      .def_property_readonly("pages", [](const prt::LightmapTransfer& l) { return l.layout.pages; },
                             "Pages, 1 to 10: page p is UV tile u in [p, p + 1] (UDIM tile 1001 + p), rows "
                             "p * page_height to (p + 1) * page_height - 1 of the stacked atlas")
      .def_property_readonly("page_height", [](const prt::LightmapTransfer& l) { return l.layout.page_height(); },
                             "A page's height in texels (prt precompute --lightmap WxH's H)")
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
                             "uint32 (N,): covered texels, y * width + x (rows from the top, of the pages "
                             "stacked: page y // page_height)")
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
            const prt::LightmapTexels tx = texels_on(l, scene);
            const std::vector<float> d = prt::dense_transfer(l.transfer, prt::texel_points(tx));
            return copy(d.data(), {py::ssize_t(l.transfer.vertices), l.transfer.channels,
                                   py::ssize_t(l.transfer.bands) * l.transfer.bands});
          },
          py::arg("scene"),
          "float32 (N, channels, bands^2): every covered texel's transfer, analytic ones evaluated from `scene` "
          "(the Scene it was laid out in: lightmap_scene(scene, lightmap) for UVs prt made or many pages)")
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
              prt::LightmapTexels tx = texels_on(l, scene);
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
          "[--lights ...] -o x.exr: float32 (height, width, 4), its EXR (RGB linear radiance, A = 1 at covered texels, "
          "gutters filled). A lightmap of many pages gives them stacked, (pages * page_height, width, 4), page p's "
          "rows from p * page_height (gutters never filled from another page): split_pages(image) gives the images "
          "prt relight writes as OUT.1001.exr, OUT.1002.exr, ...\n"
          "\n"
          "Arguments:\n"
          "  scene: the Scene (lightmap_scene(scene, lightmap) for UVs prt made or many pages).\n"
          "  lighting: coefficients (n*n, 3) (project()), at least the lightmap's bands^2.\n"
          "  lights: a list of Light (None: none): their direct light, traced against the scene at the texels' sample "
          "points, is added [--lights]. Only these: the scene's own (scene.lights) are added by passing them too. "
          "The sun split (--sun auto) takes the map, which SH lighting no longer is: split_sun(map) first, project "
          "the sky, and pass the sun in lights= (docs/LIGHTS.md).")
      .def(
          "split_pages",
          [](const prt::LightmapTransfer& l, const py::object& image) {
            const py::object a = py::module_::import("numpy").attr("asarray")(image);
            const py::tuple shape = a.attr("shape");
            if (shape.empty() || shape[0].cast<py::ssize_t>() != l.layout.height)
              throw Error("image: expected an array of the lightmap's " + std::to_string(l.layout.height) +
                          " rows first (pages x page_height, as relight gives), got shape " +
                          py::repr(shape).cast<std::string>());
            const py::ssize_t rows = l.layout.page_height();
            py::list out;
            for (py::ssize_t p = 0; p < l.layout.pages; ++p)
              out.append(a[py::slice(p * rows, (p + 1) * rows, 1)]);
            return out;
          },
          py::arg("image"),
          "The pages of `image`, an array whose first axis is the stacked atlas's rows (height = pages x "
          "page_height; relight's image): a list of `pages` views of it, page p (UDIM tile 1001 + p) its rows p * "
          "page_height to (p + 1) * page_height - 1, as prt relight writes OUT.1001.exr, OUT.1002.exr, ... ([image] "
          "for one page).")
      .def("write", [](const prt::LightmapTransfer& l, const py::object& path) {
        prt::write_lightmap_transfer(path_of(path, "path"), l);
      }, py::arg("path"), "Writes the lightmap file to `path` (docs/FORMAT.md), atomically (a temporary file, then renamed).")
      .def("__repr__", [](const prt::LightmapTransfer& l) {
        return "<prt.Lightmap " + prt::lightmap_size_text(l.layout) + ", " +
               std::to_string(l.layout.texels.size()) + " covered texels, " + std::to_string(l.transfer.bands) +
               " bands>";
      });

  m.def("read_lightmap", [](const py::object& path) { return prt::read_lightmap_transfer(path_of(path, "path")); },
        py::arg("path"), "Reads the lightmap file at `path` (prt precompute SCENE --lightmap WxH). Returns a Lightmap.");
  bind_unwrap(m);  // after Lightmap: its signatures name the class
}

// ---- directional lightmaps (prt/lightmap_directional.h) ----

static_assert(sizeof(prt::L1Radiance) == 12 * sizeof(float), "L1Radiance: four packed RGB float triples");

// The lights' direct light as L1, added to `l1` as prt relight --directional
// adds it: at the texels moved out of geometry (a copy: the packing takes
// the texels' own normals), DirectLight::incident_l1.
void add_lights_l1(std::vector<prt::L1Radiance>& l1, const std::vector<prt::Light>& lights, const prt::Mesh& mesh,
                   prt::LightmapTexels moved) {
  prt::move_texels_out_of_geometry(mesh, moved);
  const std::vector<prt::L1Radiance> direct = prt::DirectLight(mesh).incident_l1(lights, moved.positions, moved.normals);
  for (std::size_t i = 0; i < l1.size(); ++i)
    for (std::size_t k = 0; k < 4; ++k) l1[i][k] += direct[i][k];
}

// l1= of write_directional: float32 (N, 4, 3), N the covered texels.
std::vector<prt::L1Radiance> l1_arg(const py::object& l1, std::size_t texels) {
  const FArray a = real_array<float>(l1, "l1");
  if (a.ndim() != 3 || std::size_t(a.shape(0)) != texels || a.shape(1) != 4 || a.shape(2) != 3)
    throw Error("l1: expected float32 (" + std::to_string(texels) + ", 4, 3), the L1 radiance of the lightmap's " +
                std::to_string(texels) + " covered texels (relight_directional's), got shape " + shape_text(a));
  std::vector<prt::L1Radiance> out(texels);
  if (texels) std::memcpy(out.data(), a.data(), texels * sizeof(prt::L1Radiance));
  return out;
}

// Lightmap.directional, .relight_directional, .write_directional.
void bind_lightmap_directional(py::module_& m) {
  auto lightmap = py::reinterpret_borrow<py::class_<prt::LightmapTransfer>>(m.attr("Lightmap"));
  lightmap.def_property_readonly(
      "directional",
      [](const prt::LightmapTransfer& l) {
        return l.transfer.glossy && l.transfer.glossy_rows == prt::kDirectionalRows;
      },
      "True when the lightmap has directional rows (precompute_lightmap(directional=True), prt precompute --lightmap "
      "WxH --directional): relight_directional relights them");
  lightmap.def(
      "relight_directional",
      [](const prt::LightmapTransfer& l, const prt::Scene& scene, const py::object& lighting, const py::object& lights) {
        const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
        const std::vector<prt::Light> ls = lights_arg(lights);
        std::vector<prt::L1Radiance> l1;
        {
          py::gil_scoped_release release;
          const prt::LightmapTexels tx = texels_on(l, scene);
          l1 = prt::relight_directional(l, tx, light);
          if (!ls.empty()) add_lights_l1(l1, ls, scene.mesh, tx);
        }
        return copy(reinterpret_cast<const float*>(l1.data()), {py::ssize_t(l1.size()), 4, 3});
      },
      py::arg("scene"), py::arg("lighting"), py::kw_only(), py::arg("lights") = py::none(),
      "Each covered texel's L1 incident radiance under `lighting`, as prt relight SCENE LIGHTMAP ENV --directional "
      "PACKING [--lights ...] computes it before packing it: float32 (N, 4, 3), N the covered texels in texel order "
      "(.texels), coefficient k = 0..3 in prt's basis (c0 = L_00, c1 = L_1-1 (y), c2 = L_10 (z), c3 = L_11 (x)), RGB. "
      "Incident light: the texel's albedo is not in it. Raises prt.Error for a lightmap without directional rows "
      "(.directional False). Releases the GIL.\n"
      "\n"
      "Arguments:\n"
      "  scene: the Scene it was computed for (lightmap_scene(scene, lightmap) for UVs prt made).\n"
      "  lighting: coefficients (n*n, 3) (project()), at least the lightmap's bands^2, as relight's.\n"
      "  lights: a list of Light (None: none): their direct light as L1, traced against the scene from the texels "
      "moved out of geometry, is added [--lights]; a light at or below a texel's horizon adds nothing. Only these: "
      "pass scene.lights too for the scene's own.");
  lightmap.def(
      "write_directional",
      [](const prt::LightmapTransfer& l, const py::object& path, const prt::Scene& scene, const py::object& l1,
         const std::string& packing) {
        const prt::DirectionalPacking p = prt::parse_directional_packing(packing);
        const std::string out = path_of(path, "path");
        if (l.layout.pages > 1)  // as prt relight --directional
          throw Error("write_directional writes one page; the lightmap has " + prt::lightmap_size_text(l.layout));
        const std::vector<prt::L1Radiance> c = l1_arg(l1, l.layout.texels.size());
        std::vector<std::string> written;
        {
          py::gil_scoped_release release;
          const prt::LightmapTexels tx = texels_on(l, scene);
          written = prt::write_directional(out, prt::pack_directional(l.layout, c, tx.normals, p));
        }
        return py::list(py::cast(written));  // a list (the stub's `list`)
      },
      py::arg("path"), py::arg("scene"), py::arg("l1"), py::arg("packing"),
      "Packs `l1` for an engine and writes its files, as prt relight SCENE LIGHTMAP ENV -o PATH --directional PACKING "
      "writes them (the same bytes for the same L1): PATH holds the float layers stacked vertically (layer i in rows "
      "i * height onwards); 'monosh' and 'dominant' also write their 8-bit direction layer beside it (PATH with "
      "-dir.png for .exr), first. Each file written atomically. Returns the paths written, in that order (list of "
      "str). A lightmap of one page only.\n"
      "\n"
      "Arguments:\n"
      "  path: the .exr to write [-o].\n"
      "  scene: the Scene the lightmap was computed for: its texels' normals (Unity's dominant direction is "
      "rebalanced at them).\n"
      "  l1: float32 (N, 4, 3), each covered texel's L1 incident radiance, as relight_directional returns it.\n"
      "  packing [--directional]: 'godot' (Godot 4's SH lightmap: four half layers L0, L1 y, z, x), 'monosh' "
      "(Bakery's MonoSH: L0 in the EXR, one direction in the PNG), 'dominant' (Unity's directional mode: the colour "
      "at the texel's normal in the EXR, the dominant direction and its rebalancing in the PNG) or 'sh' (prt's own "
      "four float coefficient layers). docs/LIGHTMAPS.md \"Directional lightmaps\".");
}

// precompute_lightmap, lightmap_from_rows.
void bind_lightmap_compute(py::module_& m) {
  m.def(
      "precompute_lightmap",
      [](const prt::Scene& scene, int width, int height, int uv_set, const std::string& mode, int bands, int samples,
         int bounces, std::uint64_t seed, const py::object& adaptive, double verify_adaptive, bool adaptive_any,
         bool light_bounce, double bounce_patch, double bounce_ratio, int bounce_clusters,
         const py::object& bounce_probes, const std::string& material, const py::object& sss,
         const py::object& sigma_a, const py::object& sigma_s, const py::object& eta, double length_scale,
         const py::object& pages, bool directional, const std::string& device) {
        // As prt precompute --lightmap: diffuse (the scene's albedo), or a
        // translucent material's (--material subsurface); not glossy.
        const bool translucent = material == "subsurface";
        check_device_arg(device, prt::TransferKind::Lightmap, material);
        if (material != "diffuse" && !translucent)
          throw Error("material: a lightmap is 'diffuse' or 'subsurface', got '" + material + "'");
        check_subsurface_given(material, sss, sigma_a, sigma_s, eta, length_scale);
        if (directional && translucent)  // as prt precompute's; the library refuses the rest (adaptive, ...)
          throw Error("directional: a translucent lightmap's light is diffuse, with no directional rows");
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
        o.directional = directional;
        light_bounce_args(o, light_bounce, bounce_patch, bounce_ratio, bounce_clusters, bounce_probes);
        const std::optional<prt::AdaptiveOptions> adapt = adaptive_arg(adaptive, verify_adaptive, adaptive_any, samples);
        uv_set_arg(uv_set, "uv_set");
        const int page_count = pages_arg(pages);
        py::gil_scoped_release release;
        // The scene's own UVs, their pages stacked, as the command takes them.
        const OwnAtlas own = own_atlas(scene, width, height, uv_set, page_count);
        const prt::Scene& baked = own.scene(scene);
        // As the command: an atlas the machine's memory cannot hold is refused
        // from its UV area, before its texels are rasterised.
        prt::TransferOptions planned = o;
        planned.memory_limit = prt::default_memory_limit();
        prt::check_lightmap_memory(baked, width, own.atlas.height, own.atlas.uv_set, planned, adapt.has_value());
        prt::LightmapTexels tx = prt::lightmap_texels(baked, own.atlas);
        prt::move_texels_out_of_geometry(baked.mesh, tx);
        if (sss_record) {  // the texels' transmitted light summed by the profile (compute_subsurface_lightmap)
          prt::SubsurfaceScatterOptions so;
          so.length_scale = sss_record->length_scale;
          return prt::compute_subsurface_lightmap(baked, tx, o, sss_record->material, so);
        }
        const std::unique_ptr<prt::PointTracer> gpu = device_tracer(device, baked.mesh);  // kept while it traces
        o.tracer = gpu.get();
        return adapt ? prt::compute_adaptive_lightmap_transfer(baked, tx, o, *adapt)
                     : prt::compute_lightmap_transfer(baked, tx, o);
      },
      py::arg("scene"), py::arg("width"), py::arg("height"), py::kw_only(), py::arg("uv_set") = -1,
      py::arg("mode") = "shadowed", py::arg("bands") = 5, py::arg("samples") = 1024, py::arg("bounces") = 1,
      py::arg("seed") = 1, py::arg("adaptive") = py::none(), py::arg("verify_adaptive") = 0.0,
      py::arg("adaptive_any") = false, py::arg("light_bounce") = false, py::arg("bounce_patch") = 0.0,
      py::arg("bounce_ratio") = prt::kLightBounceRatio, py::arg("bounce_clusters") = prt::kLightBounceClusters,
      py::arg("bounce_probes") = py::none(), py::arg("material") = "diffuse", py::arg("sss") = py::none(),
      py::arg("sigma_a") = py::none(), py::arg("sigma_s") = py::none(), py::arg("eta") = py::none(),
      py::arg("length_scale") = kDefaultLengthScale, py::arg("pages") = 1, py::arg("directional") = false,
      py::arg("device") = "cpu",
      "The SH lightmap prt precompute SCENE --lightmap WxH computes (the same bits). Releases the GIL.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  scene: a Scene (load_scene).\n"
      "  width, height: the atlas (a page) in texels, 1 to 16384 each [--lightmap WxH].\n"
      "  uv_set: the scene's UV set the atlas is laid out in, 0 to 7 (TEXCOORD_N), or -1: TEXCOORD_1 where every object has it, else TEXCOORD_0 [--uv].\n"
      "  pages: a lightmap of many pages [--pages]: 1 to 10 width x height pages, page p in UV tile u in [p, p + 1] (UDIM tile 1001 + p; unwrap_scene(pages=...) makes such UVs), or 'auto': the tiles the UV set uses. The Lightmap holds them stacked (height = pages x height; relight it on lightmap_scene(scene, lightmap)). 1 (the default): one atlas, UVs in [0, 1].\n"
      "  bands (1 to 16) [--bands], samples (rays per texel) [--samples], mode [--mode], bounces [--bounces], seed [--seed]: as precompute's.\n"
      "  adaptive [--adaptive [TOL]], verify_adaptive [--verify-adaptive], adaptive_any [--adaptive-any]: as precompute's, among the texels: None traces every texel; 0 (the default TOL) or a TOL in (0, 1) traces a subset and interpolates the rest from neighbouring texels of the same chart. The Lightmap's .interpolated marks the interpolated texels.\n"
      "  light_bounce [--light-bounce], bounce_patch [--bounce-patch] (0: a few texels), bounce_ratio [--bounce-ratio], bounce_clusters [--bounce-clusters], bounce_probes [--probes with --light-bounce]: the lights' bounce operator among the texels (and at a probe grid's probes), as precompute's.\n"
      "  material: 'diffuse' (the scene's materials' albedo); or 'subsurface': a translucent material's RGB lightmap, the light entering the surface around each texel scattered under it (shadowed or interreflected; no adaptive or light_bounce; docs/SUBSURFACE.md) [--material].\n"
      "  sss, sigma_a, sigma_s, eta, length_scale: material='subsurface': the material and millimetres per scene unit, as precompute's [--sss, --sigma-a, --sigma-s, --eta, --length-scale].\n"
      "  directional: also each texel's directional rows, the L1 of its incident light, for normal-mapped surfaces (Lightmap.relight_directional, write_directional; docs/LIGHTMAPS.md \"Directional lightmaps\"): a shadowed or interreflected lightmap of 2 bands or more, without adaptive, light_bounce or material='subsurface' [--directional].\n"
      "  device: 'cpu' or 'gpu', as precompute's (shadowed or interreflected, directional and adaptive too; not material='subsurface') [--device].\n"
      "\n"
      "Returns a Lightmap.");

  m.def(
      "lightmap_from_rows",
      [](const prt::Scene& scene, int width, int height, const py::object& rows, int uv_set, const std::string& mode,
         const py::object& pages) {
        FArray a = real_array<float>(rows, "rows");
        uv_set_arg(uv_set, "uv_set");
        const OwnAtlas own = own_atlas(scene, width, height, uv_set, pages_arg(pages));
        const prt::Scene& laid = own.scene(scene);
        const prt::LightmapTexels tx = prt::lightmap_texels(laid, own.atlas);
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
      py::arg("mode") = "shadowed", py::arg("pages") = 1,
      "A lightmap from arrays, for a Scene: every texel of the atlas stored (none analytic); .write() makes a file prt relight reads.\n"
      "\n"
      "Arguments:\n"
      "  scene: the Scene; width, height: the atlas (a page) in texels, 1 to 16384 each; uv_set: its UV set, 0 to 7 (-1: as precompute_lightmap); pages: 1 to 10 or 'auto', as precompute_lightmap's (the texels in the order of the pages stacked).\n"
      "  rows: float32 (N, channels, bands^2), one per covered texel, in texel order.\n"
      "  mode: the transfer mode recorded ('shadowed', 'interreflected', ...).\n"
      "\n"
      "Returns a Lightmap.");
}

}  // namespace

void bind_lightmap(py::module_& m) {
  bind_lightmap_scene(m);
  bind_lightmap_transfer(m);
  bind_lightmap_directional(m);
  bind_lightmap_compute(m);
}

}  // namespace prt::python
