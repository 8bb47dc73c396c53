// python/src/bind_reference.cpp - prt's Python module: the Monte Carlo
// reference (reference) and vertex CSV files (read_vertex_csv,
// write_vertex_csv).
#include "module.h"

#include <prt/mesh.h>
#include <prt/reference.h>
#include <prt/vertex_csv.h>

#include <tbb/global_control.h>

namespace prt::python {
namespace {

// threads= of reference: at most that many worker threads while it lives (0: no limit, every core).
std::unique_ptr<tbb::global_control> limit_threads(int threads) {
  if (threads_arg(threads) == 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

}  // namespace

// reference, read_vertex_csv, write_vertex_csv.
void bind_reference(py::module_& m) {
  // ---- the reference ----
  m.def(
      "reference",
      [](const prt::Mesh& mesh, const py::object& map, const std::string& mode, int bounces, const py::object& albedo,
         bool vertex_colors, int samples, std::uint64_t seed, double offset, const py::object& rotate, int threads,
         py::object progress, const py::object& lights, const std::string& sun) {
        prt::ReferenceOptions o;
        o.mode = prt::parse_transfer_mode(mode);
        o.bounces = bounces;
        o.albedo = to_albedo(albedo);
        o.vertex_colors = vertex_colors;
        o.samples = samples;
        o.seed = seed;
        o.offset = offset;
        if (!rotate.is_none()) o.rotation = to_rotation(rotate, "rotate");
        o.lights = lights_arg(lights);
        const bool split = sun_arg(sun);
        // map=None: no light from afar (prt reference's ENV `none`): black.
        prt::EnvMap loaded;
        if (map.is_none()) loaded = prt::make_latlong(2, 1, std::vector<float>(6, 0.0f), "none (no environment)");
        const prt::EnvMap* e = map.is_none() ? &loaded : &map_argument(map, loaded);
        prt::require_finite(*e);
        if (e->is_cube()) throw Error(e->source + ": the reference needs a lat-long (2:1) map, not " + e->source_layout);
        // sun='auto': the map's sun taken out into the lights, as the command
        // does (reference_map in tools/prt/cmd_reference.cpp).
        if (split) {
          if (e != &loaded) {
            loaded = *e;
            e = &loaded;
          }
          if (auto s = take_sun(loaded, o.rotation)) o.lights.push_back(std::move(*s));
        }
        const auto limit = limit_threads(threads);
        const prt::ReferenceResult r = run_released(
            std::move(progress), [&](const prt::Progress& pr) { return prt::render_reference(mesh, *e, o, pr); });
        return py::make_tuple(vec3s(r.radiance), vec3s(r.std_error));
      },
      py::arg("mesh"), py::arg("map"), py::kw_only(), py::arg("mode") = "shadowed", py::arg("bounces") = 1,
      py::arg("albedo") = 0.8, py::arg("vertex_colors") = false, py::arg("samples") = 4096, py::arg("seed") = 1,
      py::arg("offset") = 0.0, py::arg("rotate") = py::none(), py::arg("threads") = 0,
      py::arg("progress") = py::none(), py::arg("lights") = py::none(), py::arg("sun") = "none",
      "Monte Carlo ground truth, as prt reference computes it (the same defaults, the same bits): every vertex's outgoing radiance traced against the map itself, no SH. Releases the GIL.\n"
      "\n"
      "Arguments (prt reference's option in brackets):\n"
      "  mesh: the Mesh.\n"
      "  map: an EnvMap, a file name or an (H, W, 3) lat-long array of linear radiance; None: no light from afar (black; the lights alone) [ENV none].\n"
      "  samples: paths per vertex (4096) [--samples].\n"
      "  mode: 'unshadowed', 'shadowed' or 'interreflected' [--mode]; bounces: of 'interreflected' [--bounces].\n"
      "  albedo: a number or (r, g, b) in [0, 1] (0.8) [--albedo]; vertex_colors: the mesh's colours as albedo.\n"
      "  seed [--seed], threads [--threads], offset (mesh units; 0: 1e-4 x the diagonal) [--offset].\n"
      "  rotate: the map turned by a 3x3 rotation R or (yaw, pitch, roll) degrees (light from d arrives from R d) [--rotate].\n"
      "  lights: a list of Light (None: none), in world space (not turned by rotate): each light's delta, estimated exactly at every vertex of every path with its shadow ray (in 'interreflected' mode the lights' light bounces too) [--lights]. Only these: a glTF's own lights (load_scene(path).lights) are added by passing them too (docs/LIGHTS.md).\n"
      "  sun: 'none' (the map as it is) or 'auto': the map's sun split off (split_sun) and added to the lights as a directional light turned by rotate [--sun].\n"
      "  progress: as precompute's.\n"
      "\n"
      "Returns (radiance, std_error): float32 (V, 3) each, linear RGB.");

  m.def(
      "read_vertex_csv",
      [](const py::object& path) {
        std::vector<glm::vec3> se;
        const std::vector<glm::vec3> rgb = prt::read_vertex_csv(path_of(path, "path"), &se);
        return py::make_tuple(vec3s(rgb), se.empty() ? py::object(py::none()) : py::object(vec3s(se)));
      },
      py::arg("path"),
      "Reads the vertex CSV at `path` (prt relight -o x.csv, prt reference): (rgb, std_error or None), float32 (V, 3).");

  m.def(
      "write_vertex_csv",
      [](const py::object& path, const py::object& rgb, const py::object& std_error) {
        const std::vector<glm::vec3> v = to_vec3s(rgb, "rgb");
        std::vector<glm::vec3> se;
        if (!std_error.is_none()) {
          se = to_vec3s(std_error, "std_error");
          if (se.size() != v.size()) throw Error("std_error: expected as many rows as rgb");
        }
        prt::write_vertex_csv(path_of(path, "path"), v, std_error.is_none() ? nullptr : &se);
      },
      py::arg("path"), py::arg("rgb"), py::arg("std_error") = py::none(),
      "Writes a vertex CSV that prt compare reads.\n"
      "\n"
      "Arguments:\n"
      "  path: the file; rgb: float (V, 3) per vertex; std_error: (V, 3) standard errors, or None.");
}

}  // namespace prt::python
