// python/src/bind_probes.cpp - prt's Python module: relightable probe volumes
// (ProbeVolume, read_probes, export_probes, precompute_probes;
// docs/PROBES.md).
#include "module.h"

#include <prt/io.h>
#include <prt/probes.h>
#include <prt/scene.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <filesystem>
#include <memory>

namespace prt::python {
namespace {


// ProbeVolume, read_probes.
void bind_probes_volume(py::module_& m) {
  // ---- probe volumes (prt/probes.h, docs/PROBES.md) -------------------------------
  py::class_<prt::ProbeTransfer>(m, "ProbeVolume", "A relightable probe volume (prt precompute SCENE --probes)")
      .def_property_readonly("dims", [](const prt::ProbeTransfer& t) { return py::make_tuple(t.grid.dims[0], t.grid.dims[1], t.grid.dims[2]); })
      .def_property_readonly("min", [](const prt::ProbeTransfer& t) { return py::make_tuple(t.grid.min.x, t.grid.min.y, t.grid.min.z); })
      .def_property_readonly("max", [](const prt::ProbeTransfer& t) { return py::make_tuple(t.grid.max.x, t.grid.max.y, t.grid.max.z); })
      .def_property_readonly("bands", [](const prt::ProbeTransfer& t) { return t.bands; })
      .def_property_readonly("mode", [](const prt::ProbeTransfer& t) { return std::string(prt::transfer_mode_name(t.mode)); })
      .def_property_readonly("scene_hash", [](const prt::ProbeTransfer& t) { return t.scene_hash; })
      .def_property_readonly("states",
                             [](const prt::ProbeTransfer& t) {
                               py::array_t<std::uint8_t> a(py::ssize_t(t.state.size()));
                               for (std::size_t i = 0; i < t.state.size(); ++i) a.mutable_at(i) = std::uint8_t(t.state[i]);
                               return a;
                             },
                             "uint8 (P,): 0 sky (stores nothing), 1 stored, 2 invalid (inside geometry); probe i + NX (j + NY k)")
      .def_property_readonly("positions",
                             [](const prt::ProbeTransfer& t) {
                               return copy(reinterpret_cast<const float*>(t.positions.data()), {py::ssize_t(t.positions.size()), 3});
                             },
                             "float32 (P, 3): where each probe is (grid points moved off surfaces)")
      .def_property_readonly("nbytes", &prt::ProbeTransfer::bytes)
      .def(
          "relight",
          [](const prt::ProbeTransfer& t, const py::object& map, const py::object& rotate) {
            prt::EnvMap loaded;
            const prt::EnvMap* e = &map_argument(map, loaded);
            const glm::dmat3 R = rotate.is_none() ? glm::dmat3(1.0) : to_rotation(rotate, "rotate");
            std::vector<glm::vec3> lit;
            {
              py::gil_scoped_release release;
              prt::ProbeRelighter r(t, *e);
              r.set_rotation(R);
              r.relight(lit);
            }
            const py::ssize_t nc = py::ssize_t(t.bands) * t.bands;
            return copy(reinterpret_cast<const float*>(lit.data()), {py::ssize_t(t.probes()), nc, 3});
          },
          py::arg("map"), py::kw_only(), py::arg("rotate") = py::none(),
          "float32 (P, bands^2, 3): every probe's incident light's SH under the map (a file, an EnvMap or an array), "
          "rotated as prt relight --rotate")
      .def(
          "at",
          [](const prt::ProbeTransfer& t, const prt::Scene& scene, const py::object& points, const py::object& normals,
             const py::object& sh, const py::object& lights) {
            DArray p = real_array<double>(points, "points"), n = real_array<double>(normals, "normals");
            FArray l = real_array<float>(sh, "sh");
            const py::ssize_t nc = py::ssize_t(t.bands) * t.bands;
            if (p.ndim() != 2 || p.shape(1) != 3 || n.ndim() != 2 || n.shape(0) != p.shape(0) || n.shape(1) != 3)
              throw Error("points and normals: float (N, 3) each, as many normals as points; got " + shape_text(p) +
                          " and " + shape_text(n));
            if (l.ndim() != 3 || l.shape(0) != py::ssize_t(t.probes()) || l.shape(1) != nc || l.shape(2) != 3)
              throw Error("sh: float32 (P, bands^2, 3), what relight() returns");
            if (scene.hash() != t.scene_hash) throw Error("scene: not the scene the probe volume was computed for");
            const std::vector<prt::Light> ls = lights_arg(lights);
            const std::size_t N = std::size_t(p.shape(0));
            // Every normal non-zero, and used as a unit normal: prt relight --at's rule for its points' normals.
            std::vector<glm::dvec3> unit(N);
            for (std::size_t i = 0; i < N; ++i) {
              const glm::dvec3 nn(n.at(i, 0), n.at(i, 1), n.at(i, 2));
              const double big = std::max({std::abs(nn.x), std::abs(nn.y), std::abs(nn.z)});  // finite (real_array)
              if (!(big > 0))
                throw Error("normals: row " + std::to_string(i) + " is (" + number_text(nn.x) + ", " +
                            number_text(nn.y) + ", " + number_text(nn.z) +
                            "); each normal must be non-zero (it is normalised)");
              const double len = std::sqrt(nn.x * nn.x + nn.y * nn.y + nn.z * nn.z);  // as read_points_csv
              unit[i] = len > 0 && std::isfinite(len) ? nn / len : glm::normalize(nn / big);
            }
            std::vector<float> out(N * 3);
            {
              py::gil_scoped_release release;
              const std::vector<std::uint32_t> slots = t.stored_slots();
              const prt::ProbeOcclusion occlusion(scene.mesh, t.grid);
              const prt::ProbeVisibility visible = [&](const glm::dvec3& a, const glm::dvec3& b) { return occlusion(a, b); };
              const float* L = l.data();
              for (std::size_t i = 0; i < N; ++i) {
                const glm::dvec3 q(p.at(i, 0), p.at(i, 1), p.at(i, 2)), nn = unit[i];
                const prt::ProbeWeights w = prt::probe_weights(t, slots, q, nn, visible);
                std::vector<glm::vec3> mix(std::size_t(nc), glm::vec3(0.0f));
                for (int c = 0; c < w.count; ++c)
                  for (py::ssize_t k = 0; k < nc; ++k) {
                    const float* src = L + (std::size_t(w.probe[std::size_t(c)]) * std::size_t(nc) + std::size_t(k)) * 3;
                    mix[std::size_t(k)] += w.weight[std::size_t(c)] * glm::vec3(src[0], src[1], src[2]);
                  }
                const glm::dvec3 e = prt::lambert_from_sh(mix, t.bands, nn);
                for (int c = 0; c < 3; ++c) out[i * 3 + std::size_t(c)] = float(e[c]);
              }
              if (!ls.empty()) {
                // The lights at the points themselves (a white surface facing
                // the normal), traced there, not interpolated from the probes:
                // prt relight --at's.
                std::vector<glm::vec3> rgb(N), pos(N), nrm(N);
                for (std::size_t i = 0; i < N; ++i) {
                  rgb[i] = {out[i * 3], out[i * 3 + 1], out[i * 3 + 2]};
                  pos[i] = glm::vec3(glm::dvec3(p.at(i, 0), p.at(i, 1), p.at(i, 2)));
                  nrm[i] = glm::vec3(unit[i]);
                }
                add_direct_light(rgb, ls, scene.mesh, pos, nrm, std::vector<glm::vec3>(N, glm::vec3(1.0f)));
                std::memcpy(out.data(), rgb.data(), N * sizeof(glm::vec3));
              }
            }
            return copy(out.data(), {py::ssize_t(N), 3});
          },
          py::arg("scene"), py::arg("points"), py::arg("normals"), py::arg("sh"), py::kw_only(),
          py::arg("lights") = py::none(),
          "float32 (N, 3): E(p, n)/pi at `points` (N, 3) with `normals` (N, 3; each non-zero, normalised) in `scene` "
          "(the Scene the volume was computed for) from the relit probes `sh` (relight()'s), as prt relight --at "
          "(traced visibility). Points and normals must be finite. `lights`: a list of Light (None: none), their "
          "direct light E/pi traced at the points themselves and added, as prt relight --at --lights (only these: "
          "pass scene.lights too for the scene's own). The sun split (--sun auto): split_sun(map) first, relight() "
          "the sky and pass the sun in lights= (docs/LIGHTS.md).")
      .def(
          "matrices",
          [](const prt::ProbeTransfer& t, int in_bands) {
            if (in_bands < 1 || in_bands > prt::kMaxProbeMatrixBands)
              throw Error("in_bands: 1 to " + std::to_string(prt::kMaxProbeMatrixBands) + ", got " +
                          std::to_string(in_bands));
            int channels = 1;
            const std::vector<float> mm = prt::probe_sh_matrices(t, in_bands, channels);
            return copy(mm.data(), {py::ssize_t(t.probes()), channels, py::ssize_t(t.bands) * t.bands,
                                    py::ssize_t(in_bands) * in_bands});
          },
          py::arg("in_bands") = 3,
          "float32 (P, channels, bands^2, in_bands^2): the SH transfer matrices prt export --matrices writes (in_bands "
          "1 to 16, --matrix-bands)")
      .def("write", [](const prt::ProbeTransfer& t, const py::object& path) { prt::write_probe_transfer(path_of(path, "path"), t); },
           py::arg("path"), "Writes the probe file to `path` (docs/FORMAT.md \"Probe volume\"), atomically.")
      .def("__repr__", [](const prt::ProbeTransfer& t) {
        return "<prt.ProbeVolume " + std::to_string(t.grid.dims[0]) + "x" + std::to_string(t.grid.dims[1]) + "x" +
               std::to_string(t.grid.dims[2]) + ", " + std::to_string(t.stored()) + " stored, " +
               std::string(prt::transfer_mode_name(t.mode)) + ">";
      });

  m.def("read_probes", [](const py::object& path) { return prt::read_probe_transfer(path_of(path, "path")); }, py::arg("path"),
        "Reads the probe volume at `path` (prt precompute SCENE --probes NXxNYxNZ). Returns a ProbeVolume.");
}

// export_probes.
void bind_probes_export(py::module_& m) {
  m.def(
      "export_probes",
      [](const py::object& probes, const prt::Scene& scene, const py::object& bake, const py::object& path,
         const py::object& rotate, const py::object& matrices, int matrix_bands) {
        const std::string out = path_of(path, "path");
        // A ProbeVolume, or its file (named in the JSON as prt export names it).
        std::optional<prt::ProbeTransfer> read;
        std::string probes_file = "<computed>", probes_path;
        if (is_path(probes)) {
          probes_path = path_of(probes, "probes");
          read = prt::read_probe_transfer(probes_path);
          probes_file = std::filesystem::path(probes_path).filename().string();
        } else if (!py::isinstance<prt::ProbeTransfer>(probes)) {
          throw Error("probes: expected a ProbeVolume (read_probes, precompute_probes) or its file");
        }
        const prt::ProbeTransfer& t = read ? *read : probes.cast<const prt::ProbeTransfer&>();
        if (!is_path(bake)) throw Error("bake: expected a map file (str or os.PathLike), as prt export --bake");
        const std::string map = path_of(bake, "bake");
        if (scene.hash() != t.scene_hash)
          throw Error("probes: computed for another scene than `scene` (scene hashes differ)");
        std::string ext = std::filesystem::path(out).extension().string();
        for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
        if (ext != ".json") throw Error("path: " + out + ": a probe volume exports as .json");
        std::array<double, 3> euler = {0, 0, 0};
        if (!rotate.is_none()) {
          const DArray r = real_array<double>(rotate, "rotate");
          if (r.ndim() != 1 || r.shape(0) != 3)
            throw Error("rotate: (yaw, pitch, roll) in degrees, as prt export --rotate (recorded in the file)");
          for (int k = 0; k < 3; ++k) euler[std::size_t(k)] = r.data()[k];
        }
        if (matrix_bands < 1 || matrix_bands > prt::kMaxProbeMatrixBands)  // prt export --matrix-bands's range
          throw Error("matrix_bands: 1 to " + std::to_string(prt::kMaxProbeMatrixBands) + ", got " +
                      std::to_string(matrix_bands));
        if (matrices.is_none() && matrix_bands != 3) throw Error("matrix_bands: applies with matrices= (a file)");
        const std::string matrices_path = matrices.is_none() ? std::string() : path_of(matrices, "matrices");
        // No output over an input (prt export's rule), nor the matrices over the JSON.
        const std::vector<NamedInput> inputs = {{"probes", probes_path}, {"bake", map}, {"scene", scene.mesh.source}};
        check_not_input("path", out, inputs);
        if (!matrices_path.empty()) {
          check_not_input("matrices", matrices_path, inputs);
          if (prt::same_file(matrices_path, out))
            throw Error("matrices: " + matrices_path + ": is also path" + (matrices_path == out ? "" : " (" + out + ")") +
                        ", the JSON; the two outputs need two files (choose another name for one)");
        }
        py::gil_scoped_release release;
        prt::EnvMap env = prt::load_envmap(map);
        prt::require_finite(env);
        prt::ProbeExportNames names;
        names.scene = std::filesystem::path(scene.mesh.source).filename().string();
        names.probes_file = probes_file;
        names.map = std::filesystem::path(map).filename().string();
        names.generator = "prt " PRT_VERSION " (prt export)";
        const std::string text = prt::probe_engine_json(t, env, euler, names);
        int channels = 1;
        const std::vector<float> mats =
            matrices_path.empty() ? std::vector<float>() : prt::probe_sh_matrices(t, matrix_bands, channels);
        // Both files or neither (prt export's outputs are staged alike).
        prt::StagedWrites staged;
        {
          prt::StagedWrites::Scope scope(staged);
          prt::write_text_file(out, text);
          if (!matrices_path.empty()) prt::write_probe_matrices(matrices_path, t, mats, matrix_bands, channels);
        }
        staged.commit();
      },
      py::arg("probes"), py::arg("scene"), py::arg("bake"), py::arg("path"), py::kw_only(),
      py::arg("rotate") = py::none(), py::arg("matrices") = py::none(), py::arg("matrix_bands") = 3,
      "Writes to `path` what prt export SCENE --probes PROBES --bake MAP -o PATH writes for the volume of `scene` (the same bytes): every probe relit "
      "under the map (bake: a map file, turned by rotate, yaw, pitch, roll degrees) as three.js LightProbe and "
      "Unity SphericalHarmonicsL2 coefficients, with positions in both engines' axes (docs/PROBES.md \"Export\"). "
      "PATH ends in .json. probes: a ProbeVolume or its file (the file's name is recorded, as the command records "
      "it). matrices: also write each probe's SH transfer matrix (--matrices FILE.bin), taking matrix_bands bands "
      "of lighting, 1 to 16 (--matrix-bands). Neither output may be an input (the probes file, the map, the "
      "scene's file) or the other output; both are written, or neither.");
}

// precompute_probes.
void bind_probes_precompute(py::module_& m) {
  m.def(
      "precompute_probes",
      [](const prt::Scene& scene, const py::object& dims, const std::string& mode, int bands, int bounce_bands,
         int bounces, std::uint64_t seed, const std::string& device) {
        const std::array<int, 3> dd = probe_dims_arg(dims);
        check_device_arg(device, prt::TransferKind::Probes, "diffuse");
        prt::ProbeOptions o;
        o.mode = prt::parse_transfer_mode(mode);
        o.bands = bands;
        o.bounce_bands = bounce_bands;
        o.bounces = bounces;
        o.seed = seed;
        if (scene.materials.empty()) {  // a bare mesh: prt precompute's --albedo default
          o.override_albedo = true;
          o.albedo = glm::vec3(0.8f);
        }
        py::gil_scoped_release release;
        const std::unique_ptr<prt::PointTracer> gpu = device_tracer(device, scene.mesh);  // kept while it traces
        o.tracer = gpu.get();
        return prt::compute_probe_transfer(scene, prt::probe_grid(scene.mesh, dd), o);
      },
      py::arg("scene"), py::arg("dims"), py::kw_only(), py::arg("mode") = "shadowed", py::arg("bands") = 3,
      py::arg("bounce_bands") = 6, py::arg("bounces") = 1, py::arg("seed") = 1, py::arg("device") = "cpu",
      "The relightable probe volume prt precompute SCENE --probes NXxNYxNZ computes (the same bits). Releases the GIL.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  scene: a Scene (load_scene).\n"
      "  dims: (NX, NY, NZ) probes, three whole numbers, each 2 to 1024 and at most 16777216 in all, spanning the scene's bounding box, corners included [--probes].\n"
      "  mode: 'shadowed' or 'interreflected' [--mode]; bands: of each probe's SH, 1 to 8 (3) [--bands].\n"
      "  bounce_bands: the environment bands the bounce light takes, 1 to 16 (6) [--bounce-bands]; bounces: 1 to 8, interreflected [--bounces]; seed [--seed].\n"
      "  device: 'cpu' (Embree) or 'gpu': the probes' rays in OpenGL compute, as precompute's [--device].\n"
      "\n"
      "Returns a ProbeVolume.");
}

}  // namespace

void bind_probes(py::module_& m) {
  bind_probes_volume(m);
  bind_probes_export(m);
  bind_probes_precompute(m);
}

}  // namespace prt::python
