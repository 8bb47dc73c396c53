// python/src/bind_transfer.cpp - prt's Python module: SH transfers (Transfer:
// its arrays, dense rows and write), read_transfer, and relight of a
// Transfer.
#include "module.h"

#include <prt/compressed_transfer.h>
#include <prt/hash.h>
#include <prt/mesh.h>
#include <prt/render.h>
#include <prt/subsurface.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

namespace prt::python {
namespace {

// Any prt file, as the Python object of its kind (the kind table's
// Consumer::PythonRead refuses the kinds Python does not hold).
py::object read_transfer(const std::string& path) {
  prt::AnyTransfer any = prt::read_transfer_file(path);
  const prt::TransferKind kind = prt::kind_of(any);
  prt::require_support(kind, prt::Consumer::PythonRead, path);
  return prt::dispatch(
      any,
      [&](prt::Transfer& t) -> py::object {
        PyTransfer p;
        p.source = path;
        p.t = std::move(t);
        return py::cast(std::move(p));
      },
      [&](prt::CompressedTransfer& c) -> py::object {  // the rows reconstructed; relight uses the compressed form
        PyTransfer p;
        p.source = path;
        p.t = prt::decompress(c);
        p.compressed = std::move(c);
        return py::cast(std::move(p));
      },
      [&](prt::WaveletTransfer& w) -> py::object {
        PyWavelet p;
        p.source = path;
        p.t = std::move(w);
        return py::cast(std::move(p));
      },
      [&](prt::ZhTransfer& z) -> py::object {
        PyZhTransfer p;
        p.source = path;
        p.z = std::move(z);
        return py::cast(std::move(p));
      },
      [&](prt::LightmapTransfer& l) -> py::object { return py::cast(std::move(l)); },
      [&](prt::ProbeTransfer& v) -> py::object { return py::cast(std::move(v)); },
      [&](prt::WaveletLightmap&) -> py::object {
        prt::require_support(kind, prt::Consumer::PythonRead, path);  // refused by the table (above)
        return py::none();
      });
}

// prt::check_matches(p.t, mesh) for a Mesh held by Python, whose hashes are
// kept on the object: a prt.Mesh never changes after it is made (its arrays
// are read-only views, and every function returns a new mesh), so the mesh
// and shading hashes of the same object stay right. The fast path only
// passes what check_matches would pass; anything else goes to check_matches
// for its error. (Hashing 10k vertices costs ~25 us, a third of a 3-band
// relight: bench/python_relight_overhead.py.)
void check_matches_cached(const PyTransfer& p, const py::object& mesh_obj) {
  const auto& mesh = mesh_obj.cast<const prt::Mesh&>();  // mesh_arg checked the type
  py::dict cache = mesh_obj.attr("__dict__");
  const auto cached = [&](const char* key, auto compute) {
    if (!cache.contains(key)) cache[key] = compute();
    return cache[key].cast<std::uint64_t>();
  };
  const bool ok =
      mesh.vertex_count() == p.t.vertices &&
      cached("_prt_mesh_hash", [&] { return mesh.hash(); }) == p.t.mesh_hash &&
      (!p.t.vertex_colors || mesh.colors.size() == mesh.vertex_count()) &&
      (p.t.analytic_vertices() == 0 ||
       (p.t.vertex_colors ? cached("_prt_shading_hash_colors", [&] { return prt::shading_hash(mesh, true); })
                          : cached("_prt_shading_hash", [&] { return prt::shading_hash(mesh, false); })) ==
           p.t.shading_hash);
  if (!ok) prt::check_matches(p.t, mesh, p.source);
}

py::object rows_view(const PyTransfer& p, const std::vector<float>& a, py::handle self) {
  if (a.empty() && &a != &p.t.coeffs) return py::none();  // no direct part
  const std::size_t nc = std::size_t(p.t.bands) * p.t.bands;
  return view(a.data(), {py::ssize_t(p.t.stored_vertices()), p.t.channels, py::ssize_t(nc)}, self);
}

}  // namespace

// Transfer, read_transfer.
void bind_transfer(py::module_& m) {
  // ---- transfers ----
  py::class_<PyTransfer>(m, "Transfer", "An SH transfer (prt/transfer.h): per-vertex transfer vectors")
      .def_property_readonly("bands", [](const PyTransfer& p) { return p.t.bands; })
      .def_property_readonly("channels", [](const PyTransfer& p) { return p.t.channels; })
      .def_property_readonly("mode", [](const PyTransfer& p) { return std::string(prt::transfer_mode_name(p.t.mode)); })
      .def_property_readonly("bounces", [](const PyTransfer& p) { return p.t.bounces; })
      .def_property_readonly("samples", [](const PyTransfer& p) { return p.t.samples; })
      .def_property_readonly("albedo", [](const PyTransfer& p) { return py::make_tuple(p.t.albedo.x, p.t.albedo.y, p.t.albedo.z); })
      .def_property_readonly("vertex_colors", [](const PyTransfer& p) { return p.t.vertex_colors; })
      .def_property_readonly("seed", [](const PyTransfer& p) { return p.t.seed; })
      .def_property_readonly("vertices", [](const PyTransfer& p) { return p.t.vertices; })
      .def_property_readonly("mesh_hash", [](const PyTransfer& p) { return p.t.mesh_hash; })
      .def_property_readonly("glossy", [](const PyTransfer& p) { return p.t.glossy; },
                             "Whether it holds glossy matrices (relight() uses the diffuse part)")
      .def_property_readonly(
          "subsurface",
          [](const PyTransfer& p) -> py::object {
            if (!p.t.subsurface) return py::none();
            const prt::SubsurfaceRecord& r = *p.t.subsurface;
            const auto rgb = [](const glm::dvec3& v) { return py::make_tuple(v.x, v.y, v.z); };
            py::dict d;
            d["name"] = r.material.name;
            d["sigma_a"] = rgb(r.material.sigma_a);
            d["sigma_s"] = rgb(r.material.sigma_s);
            d["eta"] = r.material.eta;
            d["length_scale"] = r.length_scale;
            return d;
          },
          "A translucent transfer's material (prt precompute --material subsurface; the file's 'subsurface "
          "material', docs/FORMAT.md): a new dict of name, sigma_a and sigma_s ((r, g, b) in 1/mm; sigma_s the "
          "reduced scattering coefficient), eta and length_scale (mm per mesh unit); None for any other transfer")
      .def_property_readonly("compressed", [](const PyTransfer& p) { return p.compressed.has_value(); },
                             "Read from a compressed file (prt compress): rows are reconstructed")
      .def_property_readonly("source", [](const PyTransfer& p) { return p.source; })
      .def_property_readonly("analytic_vertices", [](const PyTransfer& p) { return p.t.analytic_vertices(); })
      .def_property_readonly("stored_vertices", [](const PyTransfer& p) { return p.t.stored_vertices(); })
      .def_property_readonly(
          "analytic",
          [](const PyTransfer& p) {
            py::array_t<bool> a(py::ssize_t(p.t.vertices));
            for (std::size_t v = 0; v < p.t.vertices; ++v) a.mutable_at(v) = p.t.is_analytic(v);
            return a;
          },
          "bool (V,): vertices that store no row (unoccluded: transfer evaluated from the mesh's normal)")
      .def_property_readonly(
          "slots",
          [](const PyTransfer& p) {
            py::array_t<std::int64_t> a(py::ssize_t(p.t.vertices));
            for (std::size_t v = 0; v < p.t.vertices; ++v)
              a.mutable_at(v) = p.t.slots.empty() ? std::int64_t(v)
                                : p.t.slots[v] == prt::Transfer::kAnalytic ? -1
                                                                           : std::int64_t(p.t.slots[v]);
            return a;
          },
          "int64 (V,): each vertex's row in rows, or -1 when analytic")
      .def_property_readonly("interpolated_vertices", [](const PyTransfer& p) { return p.t.interpolated_vertices(); },
                             "How many vertices were interpolated from traced neighbours (prt precompute --adaptive); "
                             "0 when every vertex was traced")
      .def_property_readonly("interpolated",
                             [](py::object self) -> py::object {
                               const auto& p = self.cast<const PyTransfer&>();
                               if (p.t.interpolated.empty()) return py::none();
                               return view(p.t.interpolated.data(), {py::ssize_t(p.t.interpolated.size())}, self);
                             },
                             "uint8 (V,), read-only: 1 where the vertex's transfer was interpolated from traced "
                             "neighbours (adaptive sample points, prt precompute --adaptive), 0 where it was traced; "
                             "None when every vertex was traced (the file has no 'interpolated vertices' mask)")
      .def_property_readonly("rows", [](py::object self) { const auto& p = self.cast<const PyTransfer&>(); return rows_view(p, p.t.coeffs, self); },
                             "float32 (stored vertices, channels, bands^2): the stored rows, read-only")
      .def_property_readonly("direct_rows", [](py::object self) { const auto& p = self.cast<const PyTransfer&>(); return rows_view(p, p.t.direct, self); },
                             "Interreflected: the direct (shadowed) part's rows, or None")
      .def_property_readonly("ao",
                             [](py::object self) -> py::object {
                               const auto& p = self.cast<const PyTransfer&>();
                               if (p.t.ao.empty()) return py::none();
                               return view(p.t.ao.data(), {py::ssize_t(p.t.ao.size())}, self);
                             },
                             "float32 (V,) ambient occlusion, or None")
      .def_property_readonly("bent_normals",
                             [](py::object self) -> py::object {
                               const auto& p = self.cast<const PyTransfer&>();
                               if (p.t.bent_normals.empty()) return py::none();
                               return view3(p.t.bent_normals, self);
                             },
                             "float32 (V, 3), or None")
      .def_property_readonly("bounce_energy", [](const PyTransfer& p) { return p.t.bounce_energy; })
      .def(
          "dense",
          [](const PyTransfer& p, const prt::Mesh& mesh, bool direct) {
            prt::check_matches(p.t, mesh, p.source);
            const std::vector<float> d = prt::dense_transfer(p.t, mesh, direct);
            return copy(d.data(), {py::ssize_t(p.t.vertices), p.t.channels, py::ssize_t(p.t.bands) * p.t.bands});
          },
          py::arg("mesh"), py::arg("direct") = false,
          "float32 (V, channels, bands^2): every vertex's transfer, analytic ones evaluated from `mesh` "
          "(the mesh it was computed for); direct=True: an interreflected transfer's direct (0-bounce) part")
      .def(
          "write",
          [](const PyTransfer& p, const py::object& path) {
            const std::string f = path_of(path, "path");
            if (p.compressed)
              prt::write_compressed_transfer(f, *p.compressed);
            else
              prt::write_transfer(f, p.t);
          },
          py::arg("path"), "Writes the file to `path` (atomically) as prt precompute does (docs/FORMAT.md); a compressed transfer as prt compress does.")
      .def("__repr__",
           [](const PyTransfer& p) {
             return "<prt.Transfer " + p.source + ": " + std::string(prt::transfer_mode_name(p.t.mode)) + ", " +
                    std::to_string(p.t.bands) + " bands, " + std::to_string(p.t.channels) + " channel(s), " +
                    std::to_string(p.t.vertices) + " vertices>";
           })
      .def("__str__", [](const PyTransfer& p) {
        return p.compressed ? prt::describe_transfer(*p.compressed) : prt::describe_transfer(p.t);
      });

  m.def("read_transfer", [](const py::object& path) { return read_transfer(path_of(path, "path")); }, py::arg("path"),
        "Reads any prt transfer file at `path` (validating all of it) and returns the object of its kind: a Transfer "
        "(an SH transfer; a compressed one with its rows reconstructed, relit by per-cluster products), a "
        "WaveletTransfer, a ZhTransfer, a Lightmap or a ProbeVolume. A wavelet lightmap is refused with what to do "
        "instead (prt info --kinds lists which kind goes where).");
}

// relight of a Transfer, registered after precompute (the first of
// relight()'s overloads: module.h).
void bind_transfer_relight(py::module_& m) {
  m.def(
      "relight",
      [](const PyTransfer& p, const py::object& mesh_obj, const py::object& lighting, bool direct,
         const py::object& eye, double gloss, double specular, const py::object& diffuse,
         const py::object& lights) -> py::object {
        if (!py::isinstance<prt::Mesh>(mesh_obj))
          throw Error("mesh: expected a prt.Mesh (load_mesh, make_mesh), got " +
                      std::string(py::str(py::type::of(mesh_obj).attr("__name__"))));
        const auto& mesh = mesh_obj.cast<const prt::Mesh&>();
        const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
        const std::size_t need = std::size_t(p.t.bands) * p.t.bands;
        if (light.size() < need)
          throw Error("lighting: " + std::to_string(light.size()) + " coefficients; " + p.source + " has " +
                      std::to_string(p.t.bands) + " bands and needs " + std::to_string(need));
        check_matches_cached(p, mesh_obj);
        if (direct && p.t.mode != prt::TransferMode::Interreflected)
          throw Error(p.source + ": direct=True needs an interreflected transfer; this one is " +
                      std::string(prt::transfer_mode_name(p.t.mode)));
        if (direct && p.compressed)
          throw Error(p.source + ": direct=True: a compressed transfer keeps no direct part");
        const std::vector<prt::Light> ls = lights_arg(lights);
        if (!ls.empty() && p.t.subsurface)
          throw Error(p.source + ": lights=: " + prt::kTranslucentLightsWhy);
        // The albedo the lights' direct light takes: the one the transfer's
        // relighting used (prt relight's add_lights; diffuse= replaces it for
        // a glossy transfer seen from an eye).
        const prt::Transfer& own = p.compressed ? p.compressed->transfer : p.t;
        const auto albedo = [&](const std::optional<glm::dvec3>& rho_d) {
          std::vector<glm::vec3> a(mesh.vertex_count());
          for (std::size_t v = 0; v < a.size(); ++v)
            a[v] = rho_d ? glm::vec3(*rho_d) : prt::vertex_albedo(own, mesh, v);
          return a;
        };
        if (eye.is_none()) {
          for (const auto& [name, given] : {std::pair{"gloss", gloss != 16.0}, std::pair{"specular", specular != 0.5},
                                            std::pair{"diffuse", !diffuse.is_none()}})
            if (given)
              throw Error(std::string(name) + ": shapes the glossy part, which needs eye= (the point the vertices are "
                          "seen from)");
          std::vector<glm::vec3> rgb;
          {
            py::gil_scoped_release release;
            rgb = p.compressed ? prt::relight(*p.compressed, mesh, light)
                  : direct     ? prt::relight_direct(p.t, mesh, light)
                               : prt::relight(p.t, mesh, light);
            if (!ls.empty())  // with an operator (--light-bounce) their bounce too, unless direct=True
              add_direct_light(rgb, ls, mesh, mesh.positions, mesh.normals, albedo(std::nullopt), std::nullopt,
                               p.compressed || direct ? prt::LightBounce{} : p.t.light_bounce);
          }
          return vec3s(rgb);
        }
        // Glossy: toward one eye (3,) -> (V, 3), or many (E, 3) -> (E, V, 3).
        if (direct) throw Error("direct: the glossy part (eye=) has no direct-only form");
        const DArray eyes = real_array<double>(eye, "eye");
        if (!(eyes.ndim() == 1 && eyes.shape(0) == 3) && !(eyes.ndim() == 2 && eyes.shape(1) == 3 && eyes.shape(0) >= 1))
          throw Error("eye: expected a point (3,) or points (E, 3), E >= 1, got shape " + shape_text(eyes));
        prt::GlossyShading shading;
        shading.gloss = gloss;
        shading.specular = specular;
        if (!diffuse.is_none()) shading.diffuse = diffuse_arg(diffuse);
        const std::size_t E = eyes.ndim() == 1 ? 1 : std::size_t(eyes.shape(0));
        const std::vector<glm::vec3> rho =
            ls.empty() ? std::vector<glm::vec3>()
                       : albedo(diffuse.is_none() ? std::nullopt : std::optional<glm::dvec3>(shading.diffuse));
        std::unique_ptr<prt::DirectLight> traced;  // the occluders' BVH, built once for all the eyes
        std::vector<glm::vec3> rgb;
        rgb.reserve(E * mesh.vertex_count());
        for (std::size_t e = 0; e < E; ++e) {
          shading.eye = {eyes.data()[3 * e], eyes.data()[3 * e + 1], eyes.data()[3 * e + 2]};
          if (auto problem = prt::glossy_shading_problem(p.t, shading); !problem.empty())
            throw Error(p.source + ": " + problem);
          py::gil_scoped_release release;
          std::vector<glm::vec3> one = p.compressed ? prt::relight_glossy(*p.compressed, mesh, light, shading)
                                                    : prt::relight_glossy(p.t, mesh, light, shading);
          if (!ls.empty()) {
            if (!traced) traced = std::make_unique<prt::DirectLight>(mesh);
            const std::vector<glm::vec3> d = traced->radiance(
                ls, mesh.positions, mesh.normals, rho, prt::GlossyLobe{shading.eye, shading.gloss, shading.specular});
            for (std::size_t v = 0; v < one.size(); ++v) one[v] += d[v];
          }
          rgb.insert(rgb.end(), one.begin(), one.end());
        }
        if (eyes.ndim() == 1) return vec3s(rgb);
        return copy(reinterpret_cast<const float*>(rgb.data()),
                    {py::ssize_t(E), py::ssize_t(mesh.vertex_count()), 3});
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("lighting"), py::kw_only(), py::arg("direct") = false,
      py::arg("eye") = py::none(), py::arg("gloss") = 16.0, py::arg("specular") = 0.5,
      py::arg("diffuse") = py::none(), py::arg("lights") = py::none(),
      "Outgoing radiance under SH lighting, as prt relight computes it (a glossy transfer's diffuse part without eye=).\n"
      "\n"
      "Arguments (prt relight's option in brackets):\n"
      "  transfer: a Transfer (precompute, read_transfer, compress).\n"
      "  mesh: the Mesh it was computed for (checked).\n"
      "  lighting: coefficients (n*n, 3) or (n*n,) (project()); at least the transfer's bands.\n"
      "  direct: an interreflected transfer's direct (0-bounce) part only [--direct].\n"
      "  eye: a glossy transfer's eye point (3,) in mesh units, or (E, 3) for E eyes [--eye].\n"
      "  gloss: the Phong exponent e, 0 to 4096 (16) [--gloss]; specular: the lobe's strength rho_s in [0, 1] (0.5) [--specular].\n"
      "  diffuse: rho_d, a number or (r, g, b) in [0, 1] (None: the transfer's own albedo) [--diffuse]. docs/GLOSSY.md.\n"
      "  lights: a list of Light (None: none): their direct light, traced against the mesh at its vertices with the transfer's albedo (and, with eye, their glossy lobe), is added [--lights] (docs/LIGHTS.md). The sun split (--sun auto) needs the map: split_sun(map) first, project the sky, and pass the sun in lights=.\n"
      "\n"
      "Returns float32 (V, 3) linear RGB radiance; with eye (E, 3): (E, V, 3).");
}

}  // namespace prt::python
