// python/src/bind_export.cpp - prt's Python module: glTF export and the
// relighting web page (export_gltf, export_web).
#include "module.h"

#include <prt/gltf.h>
#include <prt/io.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/transfer_io.h>
#include <prt/web_export.h>

#include <filesystem>

namespace prt::python {
namespace {

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
    if (!is_path(bake)) throw Error("bake: expected a map file (str or os.PathLike), as prt export --bake");
    const std::string map = path_of(bake, "bake");
    prt::EnvMap env = prt::load_envmap(map);
    prt::require_finite(env);
    std::vector<glm::dvec3> light = prt::project(env, t.bands);
    double euler[3] = {0, 0, 0};
    if (!rotate.is_none()) {
      const DArray r = real_array<double>(rotate, "rotate");
      if (r.ndim() != 1 || r.shape(0) != 3)
        throw Error("rotate: (yaw, pitch, roll) in degrees, as prt export --rotate (recorded in extras)");
      for (int k = 0; k < 3; ++k) euler[k] = r.data()[k];
      std::vector<glm::dvec3> turned(light.size());
      prt::sh::Rotation(t.bands, prt::sh::rotation_from_euler(euler[0], euler[1], euler[2])).apply(light, turned);
      light.swap(turned);
    }
    const std::vector<glm::vec3> rgb = prt::relight(t, mesh, light);
    prt::Display clamp{0.0, prt::ToneMap::Clamp};
    if (!exposure.is_none()) {
      if (py::isinstance<py::str>(exposure) && exposure.cast<std::string>() == "auto") {
        clamp.exposure = prt::auto_exposure(light);
      } else {
        clamp.exposure = exposure_arg(exposure);
      }
    }
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
      "export_web",
      [](const PyTransfer& p, const prt::Mesh& mesh, const py::object& dir, const py::object& env,
         const py::object& camera, double fov, const py::object& rotate, const py::object& exposure,
         const std::string& tone_map, bool turn, bool force, const py::object& bake) {
        // The model: the glTF prt export writes (its bake recorded with the page's rotate and exposure, as the
        // command's --bake, --rotate and --exposure serve both).
        const Export x = gltf_export(p, mesh, bake, bake.is_none() ? py::none() : rotate,
                                     bake.is_none() ? py::none() : exposure);
        prt::WebPage w;
        w.dir = path_of(dir, "dir");
        check_not_input("dir", w.dir, {{"transfer", p.source}, {"mesh", mesh.source},
                                       {"bake", is_path(bake) ? path_of(bake, "bake") : std::string()},
                                       {"env", is_path(env) ? path_of(env, "env") : std::string()}});
        w.force = force;
        w.turn = turn;
        w.maps = prt::web_maps(env.is_none() ? std::string() : path_of(env, "env"), w.initial);
        check_fov(fov);
        w.camera = prt::framing_camera(mesh, fov, 1.0);
        if (!camera.is_none()) {
          const DArray c = real_array<double>(camera, "camera");
          if (!(c.ndim() == 2 && (c.shape(0) == 2 || c.shape(0) == 3) && c.shape(1) == 3))
            throw Error("camera: expected (eye, target) or (eye, target, up), 3 numbers each; got shape " + shape_text(c));
          w.camera.eye = {c.at(0, 0), c.at(0, 1), c.at(0, 2)};
          w.camera.target = {c.at(1, 0), c.at(1, 1), c.at(1, 2)};
          w.camera.up = c.shape(0) == 3 ? glm::dvec3(c.at(2, 0), c.at(2, 1), c.at(2, 2)) : glm::dvec3(0, 1, 0);
        }
        w.camera.fov_deg = fov;
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
          w.display.exposure = prt::auto_exposure(prt::project(prt::load_envmap(w.initial), 3));
        } else {
          w.display.exposure = exposure_arg(exposure);
        }
        py::gil_scoped_release release;
        std::unique_ptr<prt::StagedPage> page = prt::stage_web_page(
            w, x.t.bands, [&](const std::string& path) { prt::write_gltf(path, mesh, x.t, x.opts); }, {}, true);
        page->commit();
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("dir"), py::kw_only(), py::arg("env") = py::none(),
      py::arg("camera") = py::none(), py::arg("fov") = 40.0, py::arg("rotate") = py::none(),
      py::arg("exposure") = py::none(), py::arg("tone_map") = "clamp", py::arg("turn") = false, py::arg("force") = false,
      py::arg("bake") = py::none(),
      "Writes the relighting web page (docs/WEB.md) into `dir`, as prt export MESH T --web DIR does (the same files): index.html and its scripts, model.glb, lighting.json (every map's SH), maps/. Written whole or not at all.\n"
      "\n"
      "Arguments (prt export's option in brackets):\n"
      "  transfer: a Transfer; mesh: its Mesh; dir: the directory [--web].\n"
      "  env: the map shown first, a file or a bundled map's name (None: the bundled maps only) [--env].\n"
      "  camera: None (the framing camera) or (eye, target[, up]) [--camera]; fov: vertical degrees [--fov].\n"
      "  rotate: (yaw, pitch, roll) degrees [--rotate]; exposure: stops or 'auto' (None: 'auto' for the page, 0 for a bake) [--exposure].\n"
      "  tone_map: 'clamp', 'reinhard' or 'aces' [--tonemap]; turn: start with the environment turning [--turn].\n"
      "  force: replace an existing non-empty dir [--force]; bake: a map file: COLOR_0 in the model, as export_gltf [--bake].");
}

}  // namespace prt::python
