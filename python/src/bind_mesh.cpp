// python/src/bind_mesh.cpp - prt's Python module: meshes (Mesh, load_mesh,
// make_mesh).
#include "module.h"

#include <prt/mesh.h>

namespace prt::python {
namespace {

py::dict mesh_report(const prt::MeshReport& r) {
  py::dict d;
  d["degenerate_triangles"] = r.degenerate_triangles;
  d["unreferenced_vertices"] = r.unreferenced_vertices;
  d["normals_computed"] = r.normals_computed;
  d["zero_normals"] = r.zero_normals;
  d["welded"] = r.welded;
  d["nonmanifold_edges"] = r.nonmanifold_edges;
  d["inconsistent_edges"] = r.inconsistent_edges;
  d["file_had_normals"] = r.file_had_normals;
  d["file_had_colors"] = r.file_had_colors;
  return d;
}

prt::MeshOptions mesh_options(bool weld, bool file_normals, const std::string& weighting) {
  prt::MeshOptions o;
  o.weld = weld;
  o.file_normals = file_normals;
  if (weighting == "area")
    o.weighting = prt::NormalWeighting::Area;
  else if (weighting == "angle")
    o.weighting = prt::NormalWeighting::Angle;
  else
    throw Error("weighting: expected 'area' or 'angle', got '" + weighting + "'");
  return o;
}

}  // namespace

// Mesh, load_mesh, make_mesh.
void bind_mesh(py::module_& m) {
  // ---- meshes ----
  py::class_<prt::Mesh>(m, "Mesh", "A triangle mesh as prt loads it (prt/mesh.h)", py::dynamic_attr())
      .def_property_readonly("positions",
                             [](py::object self) {
                               const auto& x = self.cast<const prt::Mesh&>();
                               return view3(x.positions, self);
                             },
                             "float32 (V, 3), read-only")
      .def_property_readonly("normals",
                             [](py::object self) {
                               const auto& x = self.cast<const prt::Mesh&>();
                               return view3(x.normals, self);
                             },
                             "float32 (V, 3), unit or zero, read-only")
      .def_property_readonly("triangles",
                             [](py::object self) {
                               const auto& x = self.cast<const prt::Mesh&>();
                               return view3(x.triangles, self);
                             },
                             "uint32 (T, 3) vertex indices, counter-clockwise seen from the front, read-only")
      .def_property_readonly("colors",
                             [](py::object self) -> py::object {
                               const auto& x = self.cast<const prt::Mesh&>();
                               if (x.colors.empty()) return py::none();
                               return view3(x.colors, self);
                             },
                             "float32 (V, 3) linear RGB from the file, or None")
      .def_property_readonly("corner_uvs",
                             [](py::object self) -> py::object {
                               const auto& x = self.cast<const prt::Mesh&>();
                               if (x.corner_uvs.empty()) return py::none();
                               return view(&x.corner_uvs[0].x, {py::ssize_t(x.triangles.size()), 3, 2}, self);
                             },
                             "float32 (T, 3, 2) texture coordinates per triangle corner (load_mesh(uvs=True)), or None")
      .def_property_readonly("vertex_count", &prt::Mesh::vertex_count)
      .def_property_readonly("source", [](const prt::Mesh& x) { return x.source; })
      .def_property_readonly("hash", &prt::Mesh::hash, "XXH3-64 of positions and triangles (a transfer's mesh_hash)")
      .def_property_readonly("report", [](const prt::Mesh& x) { return mesh_report(x.report); })
      .def("__len__", &prt::Mesh::vertex_count)
      .def("__repr__", [](const prt::Mesh& x) { return "<prt.Mesh " + prt::describe(x) + ">"; })
      .def("__str__", [](const prt::Mesh& x) { return prt::describe(x); });

  m.def(
      "load_mesh",
      [](const py::object& path, bool weld, bool file_normals, const std::string& weighting, bool uvs) {
        prt::MeshOptions o = mesh_options(weld, file_normals, weighting);
        o.uvs = uvs;
        const std::string p = path_of(path, "path");
        py::gil_scoped_release release;
        return prt::load_mesh(p, o);
      },
      py::arg("path"), py::kw_only(), py::arg("weld") = false, py::arg("file_normals") = true,
      py::arg("weighting") = "area", py::arg("uvs") = false,
      "Reads a mesh file as every prt command does.\n"
      "\n"
      "Arguments:\n"
      "  path: OBJ, PLY, OFF, STL, glTF/GLB.\n"
      "  weld: merge vertices that share a position [--weld].\n"
      "  weighting: how vertex normals are averaged where they are computed: 'area' (the default) or 'angle' (corner angles).\n"
      "  file_normals: keep the file's normals where it has them (True; False: compute them).\n"
      "  uvs: also read the first texture coordinates per triangle corner (Mesh.corner_uvs): fit_zh's vertex frames take their tangent from them, as prt precompute --basis zh (--tangent uv, the default).\n"
      "\n"
      "Returns a Mesh (immutable).");

  m.def(
      "make_mesh",
      [](const py::object& positions, const py::object& triangles, const py::object& normals,
         const py::object& colors, bool weld) {
        std::vector<glm::vec3> pos = to_vec3s(positions, "positions");
        if (pos.empty()) throw Error("positions: no vertices (an array of shape (0, 3))");
        UArray t = index_array(triangles, "triangles");
        if (t.ndim() != 2 || t.shape(1) != 3 || t.shape(0) < 1)
          throw Error("triangles: expected an integer array of shape (T, 3), T >= 1, got " + shape_text(t));
        for (std::size_t k = 0; k < std::size_t(t.size()); ++k)
          if (t.data()[k] >= pos.size())
            throw Error("triangles: element " + index_text(k, t) + " is " + std::to_string(t.data()[k]) +
                        ", out of range: positions holds " + std::to_string(pos.size()) + " vertices");
        std::vector<glm::uvec3> tri(std::size_t(t.shape(0)));
        if (!tri.empty()) std::memcpy(&tri[0].x, t.data(), tri.size() * sizeof(glm::uvec3));
        const std::size_t V = pos.size();
        std::vector<glm::vec3> n =
            normals.is_none() ? std::vector<glm::vec3>{} : to_vec3s(normals, "normals", V, "position");
        std::vector<glm::vec3> c = colors.is_none() ? std::vector<glm::vec3>{} : to_vec3s(colors, "colors", V, "position");
        prt::MeshOptions o;
        o.weld = weld;
        return prt::make_mesh(std::move(pos), std::move(tri), std::move(n), std::move(c), o, "<arrays>");
      },
      py::arg("positions"), py::arg("triangles"), py::arg("normals") = py::none(), py::arg("colors") = py::none(),
      py::kw_only(), py::arg("weld") = false,
      "A mesh from arrays, checked as a loaded one.\n"
      "\n"
      "Arguments:\n"
      "  positions: (V, 3) finite, float32 range; triangles: (T, 3) vertex indices (whole numbers).\n"
      "  normals: (V, 3), or None to compute them (angle-weighted); colors: (V, 3) linear RGB in [0, 1], or None.\n"
      "  weld: merge vertices that share a position.\n"
      "\n"
      "Returns a Mesh.");
}

}  // namespace prt::python
