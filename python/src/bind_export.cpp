// python/src/bind_export.cpp - prt's Python module: glTF export and the
// relighting web page (export_gltf, export_web).
#include "module.h"

#include <prt/gltf.h>
#include <prt/io.h>
#include <prt/lightmap.h>
#include <prt/probes.h>
#include <prt/scene.h>
#include <prt/transfer_file.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/transfer_io.h>
#include <prt/web_export.h>

#include <filesystem>

namespace prt::python {
namespace {

// The lighting of a bake (bake=, rotate=): the map's SH projection at `bands`,
// turned by (yaw, pitch, roll), as prt export --bake --rotate.
struct BakeLight {
  std::string map;
  double euler[3] = {0, 0, 0};
  std::vector<glm::dvec3> light;
};

BakeLight bake_light(const py::object& bake, const py::object& rotate, int bands) {
  if (!is_path(bake)) throw Error("bake: expected a map file (str or os.PathLike), as prt export --bake");
  BakeLight b;
  b.map = path_of(bake, "bake");
  prt::EnvMap env = prt::load_envmap(b.map);
  prt::require_finite(env);
  b.light = prt::project(env, bands);
  if (!rotate.is_none()) {
    const DArray r = real_array<double>(rotate, "rotate");
    if (r.ndim() != 1 || r.shape(0) != 3)
      throw Error("rotate: (yaw, pitch, roll) in degrees, as prt export --rotate (recorded in extras)");
    for (int k = 0; k < 3; ++k) b.euler[k] = r.data()[k];
    std::vector<glm::dvec3> turned(b.light.size());
    prt::sh::Rotation(bands, prt::sh::rotation_from_euler(b.euler[0], b.euler[1], b.euler[2])).apply(b.light, turned);
    b.light.swap(turned);
  }
  return b;
}

// A bake's exposure= : None is 0 stops, 'auto' as prt export --bake --exposure
// auto (prt render's rule over the relit vertices or texels `rgb`, each
// counted once: frame_exposure).
bool bake_auto(const py::object& exposure) {
  return py::isinstance<py::str>(exposure) && exposure.cast<std::string>() == "auto";
}
double bake_stops(const py::object& exposure, const std::vector<glm::vec3>& rgb) {
  if (exposure.is_none()) return 0.0;
  if (bake_auto(exposure)) return prt::frame_exposure({reinterpret_cast<const float*>(rgb.data()), 3 * rgb.size()});
  return exposure_arg(exposure);
}

// What prt export writes for a transfer: its rows (a compressed one's
// reconstructed) and the glTF options, COLOR_0 baked from `bake` as --bake.
struct Export {
  prt::Transfer t;
  prt::GltfOptions opts;
};

Export gltf_export(const PyTransfer& p, const prt::Mesh& mesh, const py::object& bake, const py::object& rotate,
                   const py::object& exposure) {
  prt::check_matches(p.t, mesh, p.source);
  if (bake.is_none() && (!rotate.is_none() || !exposure.is_none()))
    throw Error(std::string(rotate.is_none() ? "exposure" : "rotate") +
                ": applies to the baked colours: give bake= (a map file) too");
  // As prt export says on stderr: a glossy transfer's lobe matrices stay out.
  if (p.t.glossy &&
      PyErr_WarnEx(PyExc_UserWarning,
                   (p.source + " holds glossy matrices: exporting its diffuse transfer only (glTF attributes hold one "
                               "row per vertex; the view-dependent part needs relight(eye=...) or render)")
                       .c_str(),
                   1) != 0)
    throw py::error_already_set();  // warnings turned into errors
  Export x{p.compressed ? prt::decompress(*p.compressed) : p.t, {}};
  const prt::Transfer& t = x.t;
  prt::GltfOptions& opts = x.opts;
  opts.transfer_source = p.source == "<computed>" || p.source == "<compressed>"
                             ? std::string()
                             : std::filesystem::path(p.source).filename().string();
  opts.generator = "prt " PRT_VERSION " (prt export)";
  if (!bake.is_none()) {
    // COLOR_0 as prt export --bake: the relit radiance times 2^exposure, clamped to [0, 1].
    const BakeLight b = bake_light(bake, rotate, t.bands);
    const std::vector<glm::dvec3>& light = b.light;
    const std::string& map = b.map;
    const double* euler = b.euler;
    const std::vector<glm::vec3> rgb = prt::relight(t, mesh, light);
    prt::Display clamp{bake_stops(exposure, rgb), prt::ToneMap::Clamp};
    opts.colors.resize(rgb.size());
    for (std::size_t v = 0; v < rgb.size(); ++v)
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(rgb[v][c]))
          throw Error("bake: the relit radiance of vertex " + std::to_string(v) + " overflows float; scale "
                      "the map down");
        opts.colors[v][c] = prt::tone_map(rgb[v][c], clamp);
      }
    opts.bake.map = std::filesystem::path(map).filename().string();
    for (int k = 0; k < 3; ++k) opts.bake.rotate[k] = euler[k];
    opts.bake.exposure = clamp.exposure;
  }
  return x;
}

// A lightmap's glTF as prt export SCENE LIGHTMAP -o FILE writes it: the
// scene with its coefficient textures, and with bake= the baked lightmap
// (relit radiance times 2^exposure, default 0 stops, as --bake).
struct LightmapExport {
  prt::LightmapTexels texels;
  prt::GltfLightmapOptions opts;
};

LightmapExport lightmap_export(const prt::LightmapTransfer& l, const prt::Scene& scene, const py::object& bake,
                               const py::object& rotate, const py::object& exposure) {
  if (bake.is_none() && (!rotate.is_none() || !exposure.is_none()))
    throw Error(std::string(rotate.is_none() ? "exposure" : "rotate") +
                ": applies to the baked lightmap: give bake= (a map file) too");
  LightmapExport x{prt::lightmap_texels(scene, l.layout, l.transfer.vertex_colors ? nullptr : &l.transfer.albedo), {}};
  prt::check_matches(l, x.texels, "the lightmap");
  x.opts.generator = "prt " PRT_VERSION " (prt export)";
  if (!bake.is_none()) {
    const BakeLight b = bake_light(bake, rotate, l.transfer.bands);
    prt::bake_lightmap(x.opts, l, x.texels, b.light, std::filesystem::path(b.map).filename().string(), b.euler,
                       bake_auto(exposure) ? 0.0 : bake_stops(exposure, {}));
    if (bake_auto(exposure)) {
      const double stops = bake_stops(exposure, x.opts.baked);
      for (glm::vec3& c : x.opts.baked) c *= float(std::exp2(stops));
      x.opts.bake.exposure = stops;
    }
  }
  return x;
}

// export_gltf and export_web of the kinds Python does not export: overloads
// that take only those types (so a Transfer's or a Lightmap's call never
// lands here, even one pybind11 must convert, fov=35 as an int) and refuse with
// the sentence of prt's table (prt::support, Consumer::PythonExport).
template <class T>
void refuse_export(py::module_& m, prt::TransferKind kind) {
  for (const char* function : {"export_gltf", "export_web"})
    m.def(
        function,
        [kind](const T&, const py::args&, const py::kwargs&) {
          prt::require_support(kind, prt::Consumer::PythonExport, "transfer");
        },
        py::arg("transfer"), "Refused, saying why and what to do (prt info --kinds).");
}

// The page's settings from export_web's arguments, as prt export --web takes
// them from its options: `inputs` (the transfer and model files) must not be dir.
prt::WebPage web_page(const prt::Mesh& mesh, const std::vector<NamedInput>& inputs, const py::object& dir,
                      const py::object& env, const py::object& camera, const py::object& fov_obj, const py::object& rotate,
                      const py::object& exposure, const std::string& tone_map, bool turn, bool force,
                      const py::object& bake) {
  prt::WebPage w;
  w.dir = path_of(dir, "dir");
  std::vector<NamedInput> in = inputs;
  in.push_back({"bake", is_path(bake) ? path_of(bake, "bake") : std::string()});
  in.push_back({"env", is_path(env) ? path_of(env, "env") : std::string()});
  check_not_input("dir", w.dir, in);
  w.force = force;
  w.turn = turn;
  w.maps = prt::web_maps(env.is_none() ? std::string() : path_of(env, "env"), w.initial);
  // The default camera as prt export --web's: scene_camera for a square
  // canvas (a wider one still fits), from outside or inside a room.
  const std::optional<double> fov = fov_arg(fov_obj);
  w.camera = prt::scene_camera(mesh, 1.0, fov);
  if (!camera.is_none()) {
    const DArray c = real_array<double>(camera, "camera");
    if (!(c.ndim() == 2 && (c.shape(0) == 2 || c.shape(0) == 3) && c.shape(1) == 3))
      throw Error("camera: expected (eye, target) or (eye, target, up), 3 numbers each; got shape " + shape_text(c));
    w.camera.eye = {c.at(0, 0), c.at(0, 1), c.at(0, 2)};
    w.camera.target = {c.at(1, 0), c.at(1, 1), c.at(1, 2)};
    w.camera.up = c.shape(0) == 3 ? glm::dvec3(c.at(2, 0), c.at(2, 1), c.at(2, 2)) : glm::dvec3(0, 1, 0);
    w.camera.fov_deg = fov.value_or(prt::kDefaultFov);
  }
  if (!rotate.is_none()) {
    const DArray r = real_array<double>(rotate, "rotate");
    if (r.ndim() != 1 || r.shape(0) != 3) throw Error("rotate: (yaw, pitch, roll) in degrees");
    for (int k = 0; k < 3; ++k) w.rotate[k] = r.data()[k];
  }
  try {
    w.display.tone_map = prt::parse_tone_map(tone_map);
  } catch (const Error& e) {
    throw Error(std::string("tone_map: ") + e.what());
  }
  if (exposure.is_none() || (py::isinstance<py::str>(exposure) && exposure.cast<std::string>() == "auto")) {
    // As prt export --web: the page measures its first frame; this is its fallback.
    w.display.exposure = prt::auto_exposure(prt::project(prt::load_envmap(w.initial), 3));
    w.auto_exposure = true;
  } else {
    w.display.exposure = exposure_arg(exposure);
  }
  return w;
}

}  // namespace

// export_gltf, export_web.
void bind_export(py::module_& m) {
  // ---- glTF export (prt/gltf.h; docs/FORMAT.md "glTF export") ----
  m.def(
      "export_gltf",
      [](const PyTransfer& p, const prt::Mesh& mesh, const py::object& path, const py::object& bake,
         const py::object& rotate, const py::object& exposure) {
        const std::string out = path_of(path, "path");
        check_not_input("path", out, {{"transfer", p.source}, {"mesh", mesh.source},
                                      {"bake", is_path(bake) ? path_of(bake, "bake") : std::string()}});
        const Export x = gltf_export(p, mesh, bake, rotate, exposure);
        py::gil_scoped_release release;
        prt::write_gltf(out, mesh, x.t, x.opts);
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("path"), py::kw_only(), py::arg("bake") = py::none(),
      py::arg("rotate") = py::none(), py::arg("exposure") = py::none(),
      "Writes the mesh and its SH transfer as glTF 2.0 (.glb binary, .gltf JSON; docs/FORMAT.md \"glTF "
      "export\") to `path`, as prt export MESH T -o FILE does, the same bytes: the transfer rows as vertex attributes "
      "_PRT_T0, ... (a compressed transfer's reconstructed rows; a glossy one's diffuse part), described in "
      "asset.extras.prt. bake: a map file whose relit radiance becomes COLOR_0 (turned by rotate, yaw, pitch, "
      "roll degrees; times 2^exposure, stops or 'auto', default 0; clamped to [0, 1]), as --bake.");
  m.def(
      "export_gltf",
      [](const prt::LightmapTransfer& l, const prt::Scene& scene, const py::object& path, const py::object& bake,
         const py::object& rotate, const py::object& exposure, const py::object& bake_material) {
        const std::string out = path_of(path, "path");
        check_not_input("path", out, {{"scene", scene.mesh.source},
                                      {"bake", is_path(bake) ? path_of(bake, "bake") : std::string()}});
        std::string material = "unlit";
        if (!bake_material.is_none()) {
          if (bake.is_none()) throw Error("bake_material: applies to the baked lightmap: give bake= (a map file) too");
          material = py::cast<std::string>(bake_material);
          if (material != "unlit" && material != "lit")
            throw Error("bake_material: '" + material + "': expected 'unlit' or 'lit'");
        }
        LightmapExport x = lightmap_export(l, scene, bake, rotate, exposure);
        x.opts.moz_lightmap = material == "lit";
        py::gil_scoped_release release;
        prt::write_gltf_lightmap(out, scene, l, x.texels, x.opts);
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("path"), py::kw_only(), py::arg("bake") = py::none(),
      py::arg("rotate") = py::none(), py::arg("exposure") = py::none(), py::arg("bake_material") = py::none(),
      "For a Lightmap and its Scene: writes the scene (one node per object) with the lightmap's coefficient "
      "textures as glTF 2.0 (docs/FORMAT.md \"Lightmap export\"), as prt export SCENE LIGHTMAP -o FILE does "
      "(extras name no transfer file: a Lightmap does not know its file); bake: a map file whose relit radiance "
      "becomes the baked lightmap (unlit, TEXCOORD_1; turned by rotate; times 2^exposure, stops or 'auto', "
      "default 0), as --bake; bake_material: 'unlit' (default) or 'lit' (the scene's materials with the "
      "irradiance as MOZ_lightmap, three.js's lightMap), as --bake-material. A lightmap of many pages (its Scene from lightmap_scene: the pages stacked) is "
      "written as pages: images of a page's size and a primitive per page, as prt export writes it.");

  m.def(
      "export_web",
      [](const PyTransfer& p, const prt::Mesh& mesh, const py::object& dir, const py::object& env,
         const py::object& camera, const py::object& fov, const py::object& rotate, const py::object& exposure,
         const std::string& tone_map, bool turn, bool force, const py::object& bake, bool three) {
        if (three)
          throw Error("three=True: the transfer is a vertex transfer; the three.js page relights a lightmap "
                      "(precompute_lightmap) into three's lightMap: leave three=False for a vertex transfer's page");
        // The model: the glTF prt export writes (its bake recorded with the page's rotate and exposure, as the
        // command's --bake, --rotate and --exposure serve both).
        const Export x = gltf_export(p, mesh, bake, bake.is_none() ? py::none() : rotate,
                                     bake.is_none() ? py::none() : exposure);
        prt::WebPage w = web_page(mesh, {{"transfer", p.source}, {"mesh", mesh.source}}, dir, env, camera, fov,
                                  rotate, exposure, tone_map, turn, force, bake);
        py::gil_scoped_release release;
        std::unique_ptr<prt::StagedPage> page = prt::stage_web_page(
            w, x.t.bands, [&](const std::string& path) { prt::write_gltf(path, mesh, x.t, x.opts); }, {}, true);
        page->commit();
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("dir"), py::kw_only(), py::arg("env") = py::none(),
      py::arg("camera") = py::none(), py::arg("fov") = py::none(), py::arg("rotate") = py::none(),
      py::arg("exposure") = py::none(), py::arg("tone_map") = "clamp", py::arg("turn") = false, py::arg("force") = false,
      py::arg("bake") = py::none(), py::arg("three") = false,
      "Writes the relighting web page (docs/WEB.md) into `dir`, as prt export MESH T --web DIR does (the same files): index.html and its scripts, model.glb, lighting.json (every map's SH), maps/. Written whole or not at all.\n"
      "\n"
      "Arguments (prt export's option in brackets):\n"
      "  transfer: a Transfer; mesh: its Mesh; dir: the directory [--web].\n"
      "  env: the map shown first, a file or a bundled map's name (None: the bundled maps only) [--env].\n"
      "  camera: None (prt render's default camera: from outside, or inside a room) or (eye, target[, up]) [--camera]; fov: vertical degrees (None: 40, or 70 inside a room) [--fov].\n"
      "  rotate: (yaw, pitch, roll) degrees [--rotate]; exposure: stops or 'auto' (None: 'auto' for the page, 0 for a bake) [--exposure].\n"
      "  tone_map: 'clamp', 'reinhard' or 'aces' [--tonemap]; turn: start with the environment turning [--turn].\n"
      "  force: replace an existing non-empty dir [--force]; bake: a map file: COLOR_0 in the model, as export_gltf [--bake].");
  m.def(
      "export_web",
      [](const prt::LightmapTransfer& l, const prt::Scene& scene, const py::object& dir, const py::object& env,
         const py::object& camera, const py::object& fov, const py::object& rotate, const py::object& exposure,
         const std::string& tone_map, bool turn, bool force, const py::object& bake, bool three) {
        if (!bake.is_none())
          throw Error("bake: a lightmap's baked texture goes into the glTF of export_gltf(bake=); the page relights "
                      "the coefficient textures (as prt export --web)");
        // The page's model: the scene's own materials and the coefficient textures, as prt export --web.
        const LightmapExport x = lightmap_export(l, scene, py::none(), py::none(), py::none());
        prt::WebPage w = web_page(scene.mesh, {{"scene", scene.mesh.source}}, dir, env, camera, fov, rotate, exposure,
                                  tone_map, turn, force, bake);
        w.lightmap_albedo = prt::lightmap_image(l.layout, x.texels.albedo);
        w.lightmap_width = l.layout.width;
        w.lightmap_height = l.layout.page_height();
        w.lightmap_pages = l.layout.pages;
        w.three = three;
        py::gil_scoped_release release;
        std::unique_ptr<prt::StagedPage> page = prt::stage_web_page(
            w, l.transfer.bands,
            [&](const std::string& path) { prt::write_gltf_lightmap(path, scene, l, x.texels, x.opts); }, {}, true);
        page->commit();
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("dir"), py::kw_only(), py::arg("env") = py::none(),
      py::arg("camera") = py::none(), py::arg("fov") = py::none(), py::arg("rotate") = py::none(),
      py::arg("exposure") = py::none(), py::arg("tone_map") = "clamp", py::arg("turn") = false, py::arg("force") = false,
      py::arg("bake") = py::none(), py::arg("three") = false,
      "For a Lightmap and its Scene: the page that relights the lightmap per pixel (docs/WEB.md \"Lightmaps\"), "
      "as prt export SCENE LIGHTMAP --web DIR does; the other arguments as for a Transfer (bake= is refused: "
      "the page relights). three=True: the three.js page instead, as prt export SCENE LIGHTMAP --three DIR "
      "(docs/WEB.md \"The three.js page\"; its probes, --three --probes, are the command's only).");
  // The other kinds: refused with the table's sentence.
  refuse_export<PyWavelet>(m, prt::TransferKind::Wavelet);
  refuse_export<PyZhTransfer>(m, prt::TransferKind::ZH);
  refuse_export<prt::ProbeTransfer>(m, prt::TransferKind::Probes);
}

}  // namespace prt::python
