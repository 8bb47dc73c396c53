// python/src/bind_ldprt.cpp - prt's Python module: local deformable PRT
// (ZhTransfer, read_zh, fit_zh, deform, pose, relight of a ZhTransfer).
#include "module.h"

#include <prt/deform.h>
#include <prt/mesh.h>
#include <prt/transfer_io.h>
#include <prt/zh_transfer.h>

namespace prt::python {
namespace {

py::dict pose_report(const prt::PoseReport& r) {
  py::dict d;
  d["no_frame"] = r.no_frame;
  d["normal_only"] = r.normal_only;
  d["uv"] = r.uv;
  return d;
}

// ZhTransfer, read_zh.
void bind_ldprt_transfer(py::module_& m) {
  // ---- local deformable PRT (prt/zh_transfer.h, docs/LDPRT.md) ----
  py::class_<PyZhTransfer>(m, "ZhTransfer",
                           "A local deformable transfer (prt/zh_transfer.h): per stored vertex, K zonal-harmonic "
                           "lobes with axes in the vertex's rest frame, which turn with the surface in a pose")
      .def_property_readonly("bands", [](const PyZhTransfer& p) { return p.z.bands; }, "SH bands of each lobe (posed: bands^2 coefficients)")
      .def_property_readonly("lobes", [](const PyZhTransfer& p) { return p.z.lobes; })
      .def_property_readonly("channels", [](const PyZhTransfer& p) { return p.z.channels; })
      .def_property_readonly("mode", [](const PyZhTransfer& p) { return std::string(prt::transfer_mode_name(p.z.mode)); })
      .def_property_readonly("bounces", [](const PyZhTransfer& p) { return p.z.bounces; })
      .def_property_readonly("samples", [](const PyZhTransfer& p) { return p.z.samples; })
      .def_property_readonly("albedo", [](const PyZhTransfer& p) { return py::make_tuple(p.z.albedo.x, p.z.albedo.y, p.z.albedo.z); })
      .def_property_readonly("vertex_colors", [](const PyZhTransfer& p) { return p.z.vertex_colors; })
      .def_property_readonly("seed", [](const PyZhTransfer& p) { return p.z.seed; })
      .def_property_readonly("vertices", [](const PyZhTransfer& p) { return p.z.vertices; })
      .def_property_readonly("fit_error", [](const PyZhTransfer& p) { return p.z.fit_error; },
                             "Relative error of the fit over the stored rows, in the SH transfer's space")
      .def_property_readonly("analytic_vertices", [](const PyZhTransfer& p) { return p.z.analytic_vertices(); })
      .def_property_readonly("stored_vertices", [](const PyZhTransfer& p) { return p.z.stored_vertices(); })
      .def_property_readonly("mesh_hash", [](const PyZhTransfer& p) { return p.z.mesh_hash; },
                             "Mesh.hash of the rest pose")
      .def_property_readonly("topology_hash", [](const PyZhTransfer& p) { return p.z.topology_hash; },
                             "XXH3-64 of the vertex count and triangles: what a pose must share with the rest pose")
      .def_property_readonly("source", [](const PyZhTransfer& p) { return p.source; })
      .def_property_readonly(
          "analytic",
          [](const PyZhTransfer& p) {
            py::array_t<bool> a(py::ssize_t(p.z.vertices));
            for (std::size_t v = 0; v < p.z.vertices; ++v) a.mutable_at(v) = p.z.is_analytic(v);
            return a;
          },
          "bool (V,): vertices that store no lobes (unoccluded: the clamped cosine about the posed normal)")
      .def_property_readonly(
          "slots",
          [](const PyZhTransfer& p) {
            py::array_t<std::int64_t> a(py::ssize_t(p.z.vertices));
            for (std::size_t v = 0; v < p.z.vertices; ++v)
              a.mutable_at(v) = p.z.is_analytic(v) ? -1 : std::int64_t(p.z.row(v));
            return a;
          },
          "int64 (V,): each vertex's row in axes and coeffs, or -1 when analytic")
      .def_property_readonly(
          "axes",
          [](py::object self) {
            const auto& p = self.cast<const PyZhTransfer&>();
            return view(p.z.axes.empty() ? nullptr : p.z.axes.data(),
                        {py::ssize_t(p.z.stored_vertices()), p.z.lobes, 3}, self);
          },
          "float32 (stored vertices, lobes, 3): unit lobe axes in each vertex's rest frame (x tangent, y "
          "bitangent, z normal), shared by the channels; read-only")
      .def_property_readonly(
          "coeffs",
          [](py::object self) {
            const auto& p = self.cast<const PyZhTransfer&>();
            return view(p.z.coeffs.empty() ? nullptr : p.z.coeffs.data(),
                        {py::ssize_t(p.z.stored_vertices()), p.z.channels, p.z.lobes, p.z.bands}, self);
          },
          "float32 (stored vertices, channels, lobes, bands): each lobe's zonal coefficients g_il; read-only")
      .def_property_readonly(
          "tangent_rules",
          [](const PyZhTransfer& p) {
            const std::size_t V = p.z.tangents.size();
            py::array_t<std::uint32_t> vertices({py::ssize_t(V), py::ssize_t(2)});
            py::array_t<float> weights({py::ssize_t(V), py::ssize_t(2)});
            for (std::size_t v = 0; v < V; ++v) {
              vertices.mutable_at(v, 0) = p.z.tangents[v].a, vertices.mutable_at(v, 1) = p.z.tangents[v].b;
              weights.mutable_at(v, 0) = p.z.tangents[v].wa, weights.mutable_at(v, 1) = p.z.tangents[v].wb;
            }
            return py::make_tuple(vertices, weights);
          },
          "(uint32 (V, 2) neighbours a, b; float32 (V, 2) weights wa, wb): each vertex's tangent in any pose is the "
          "part of wa (p_a - p) + wb (p_b - p) perpendicular to its normal (docs/CONVENTIONS.md, \"Vertex frames\": "
          "a = b the edge rule, a != b the UV tangent, a = b = the vertex none)")
      .def("write", [](const PyZhTransfer& p, const py::object& path) { prt::write_zh_transfer(path_of(path, "path"), p.z); },
           py::arg("path"), "Writes the file to `path` (atomically) as prt precompute --basis zh does (docs/FORMAT.md).")
      .def("describe", [](const PyZhTransfer& p) { return prt::describe_transfer(p.z); },
           "prt info's text: lobes, bands, channels, mode, vertices, fit error, sizes, hashes")
      .def("__str__", [](const PyZhTransfer& p) { return prt::describe_transfer(p.z); })
      .def("__repr__", [](const PyZhTransfer& p) {
        return "<prt.ZhTransfer " + p.source + ": " + std::to_string(p.z.lobes) + " lobes x " +
               std::to_string(p.z.bands) + " bands, " + std::string(prt::transfer_mode_name(p.z.mode)) + ", " +
               std::to_string(p.z.channels) + " channel(s), " + std::to_string(p.z.vertices) + " vertices>";
      });

  m.def(
      "read_zh",
      [](const py::object& path) {
        PyZhTransfer p;
        p.source = path_of(path, "path");
        p.z = prt::read_zh_transfer(p.source);
        return p;
      },
      py::arg("path"), "Reads the zonal-harmonic (local deformable) transfer file at `path` (prt precompute --basis zh). Returns a ZhTransfer.");
}

// fit_zh, deform, pose, relight of a ZhTransfer.
void bind_ldprt_pose(py::module_& m) {
  m.def(
      "fit_zh",
      [](const PyTransfer& p, const prt::Mesh& mesh, int lobes, int rounds, int threads, py::object progress) {
        prt::check_matches(p.t, mesh, p.source);
        prt::ZhFitOptions o;
        o.lobes = lobes;
        o.rounds = rounds;
        o.threads = threads_arg(threads);
        PyZhTransfer z;
        z.z = run_released(std::move(progress),
                           [&](const prt::Progress& pr) { return prt::fit_zh_transfer(p.t, mesh, o, pr); });
        return z;
      },
      py::arg("transfer"), py::arg("mesh"), py::kw_only(), py::arg("lobes") = 4, py::arg("rounds") = 12,
      py::arg("threads") = 0, py::arg("progress") = py::none(),
      "Fits zonal-harmonic lobes to every stored row of an SH transfer computed for `mesh` (the rest pose), as prt precompute --basis zh --lobes K does after its SH pass (the same bits, for any `threads`). Refuses a glossy transfer and more than 16 bands. Releases the GIL.\n"
      "\n"
      "Arguments (prt precompute's option in brackets):\n"
      "  transfer: a Transfer; mesh: its Mesh (with uvs=True for UV tangents).\n"
      "  lobes: K, 1 to 8 (4) [--lobes]; rounds: the fit's refinement rounds (12).\n"
      "  threads; progress: as precompute's. The frames' tangent: the UV rule where the mesh has corner UVs, else the edge rule (--tangent).\n"
      "\n"
      "Returns a ZhTransfer.");

  m.def(
      "deform",
      [](const prt::Mesh& mesh, const std::string& deformation, double amount) {
        const prt::Deform d = prt::parse_deform(deformation);
        if (!std::isfinite(amount)) throw Error("amount: must be finite (0: the rest pose, 1: the whole angle)");
        py::gil_scoped_release release;
        return prt::deform_mesh(mesh, d, amount);
      },
      py::arg("mesh"), py::arg("deformation"), py::arg("amount") = 1.0,
      "A pose of `mesh`, as prt relight --deform makes it. Same vertices and triangles; new positions and normals.\n"
      "\n"
      "Arguments:\n"
      "  mesh: the rest Mesh.\n"
      "  deformation: 'bend:ANGLE' (its y extent bent into an arc of ANGLE degrees towards +x) or 'twist:ANGLE' (about y) [--deform].\n"
      "  amount: the fraction of the angle (1: all of it).\n"
      "\n"
      "Returns a Mesh.");

  m.def(
      "pose",
      [](const PyZhTransfer& p, const prt::Mesh& posed, bool report) -> py::object {
        prt::check_pose(p.z, posed, p.source);
        prt::PoseReport r;
        std::vector<float> rows;
        {
          py::gil_scoped_release release;
          rows = prt::posed_transfer(p.z, posed, &r);
        }
        py::object a = copy(rows.data(), {py::ssize_t(p.z.vertices), p.z.channels, py::ssize_t(p.z.bands) * p.z.bands});
        if (report) return py::make_tuple(a, pose_report(r));
        return a;
      },
      py::arg("transfer"), py::arg("mesh"), py::kw_only(), py::arg("report") = false,
      "float32 (V, channels, bands^2): every vertex's SH transfer in the pose `mesh` (the rest mesh's "
      "vertices and triangles, moved: deform(), or any mesh with the same topology), each vertex's lobes turned "
      "into its posed frame. report=True: (rows, {'no_frame': n, 'normal_only': n, 'uv': n}), the vertices "
      "without a frame in the pose (zero transfer), those whose frame came from the normal alone, and those whose "
      "tangent is the UV tangent.");

  m.def(
      "relight",
      [](const PyZhTransfer& p, const prt::Mesh& posed, const py::object& lighting, bool direct,
         const py::object& lights) {
        const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
        const std::size_t need = std::size_t(p.z.bands) * p.z.bands;
        if (light.size() < need)
          throw Error("lighting: " + std::to_string(light.size()) + " coefficients; " + p.source + " has " +
                      std::to_string(p.z.bands) + " bands and needs " + std::to_string(need));
        if (direct) throw Error(p.source + ": direct=True: a zonal-harmonic transfer holds lobes of one transfer (no direct part)");
        prt::check_pose(p.z, posed, p.source);
        const std::vector<prt::Light> ls = lights_arg(lights);
        std::vector<glm::vec3> rgb;
        {
          py::gil_scoped_release release;
          const prt::Transfer t = prt::posed_as_transfer(p.z, posed);
          rgb = prt::relight(t, posed, light);
          if (!ls.empty()) {
            // The pose's own shadows, with the albedo the transfer relit with (prt relight's add_lights).
            std::vector<glm::vec3> albedo(rgb.size());
            for (std::size_t v = 0; v < albedo.size(); ++v) albedo[v] = prt::vertex_albedo(t, posed, v);
            add_direct_light(rgb, ls, posed, posed.positions, posed.normals, albedo);
          }
        }
        return vec3s(rgb);
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("lighting"), py::kw_only(), py::arg("direct") = false,
      py::arg("lights") = py::none(),
      "A zonal-harmonic transfer's outgoing radiance in the pose `mesh`, as prt relight POSED f.prt ENV [--deform ...].\n"
      "\n"
      "Arguments:\n"
      "  transfer: a ZhTransfer (fit_zh, read_zh); mesh: the rest mesh or any pose of it (deform, pose).\n"
      "  lighting: coefficients (n*n, 3) (project()); direct: the direct part only [--direct].\n"
      "  lights: a list of Light (None: none): their direct light, traced against the pose at its vertices, is added [--lights] (docs/LIGHTS.md). The sun split (--sun auto) needs the map: split_sun(map) first, project the sky, and pass the sun in lights=.\n"
      "\n"
      "Returns float32 (V, 3).");
}

}  // namespace

void bind_ldprt(py::module_& m) {
  bind_ldprt_transfer(m);
  bind_ldprt_pose(m);
}

}  // namespace prt::python
