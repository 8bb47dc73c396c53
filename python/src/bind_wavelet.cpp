// python/src/bind_wavelet.cpp - prt's Python module: all-frequency wavelet
// transfers (WaveletTransfer, read_wavelet, relight of a WaveletTransfer).
#include "module.h"

#include <prt/mesh.h>
#include <prt/transfer_io.h>
#include <prt/wavelet.h>
#include <prt/wavelet_playback.h>
#include <prt/wavelet_transfer.h>

namespace prt::python {

// WaveletTransfer, read_wavelet, relight of a WaveletTransfer.
void bind_wavelet(py::module_& m) {
  // ---- wavelet transfer (prt/wavelet_transfer.h, docs/WAVELETS.md) ----
  py::class_<PyWavelet>(m, "WaveletTransfer",
                        "An all-frequency shadowed transfer (Ng, Ramamoorthi & Hanrahan 2003): per vertex, the "
                        "largest Haar wavelet coefficients of its visibility times cosine on a cube map")
      .def_property_readonly("cube_res", [](const PyWavelet& p) { return p.t.cube_res; }, "The cube's face size r")
      .def_property_readonly("coefficient_count", [](const PyWavelet& p) { return p.t.coeff_count(); }, "6 r^2")
      .def_property_readonly("vertices", [](const PyWavelet& p) { return p.t.vertices; })
      .def_property_readonly("threshold", [](const PyWavelet& p) { return p.t.threshold; })
      .def_property_readonly("albedo", [](const PyWavelet& p) { return py::make_tuple(p.t.albedo.x, p.t.albedo.y, p.t.albedo.z); })
      .def_property_readonly("vertex_colors", [](const PyWavelet& p) { return p.t.vertex_colors; })
      .def_property_readonly("mesh_hash", [](const PyWavelet& p) { return p.t.mesh_hash; })
      .def_property_readonly("kept", [](const PyWavelet& p) { return p.t.kept(); }, "Coefficients kept, all vertices")
      .def_property_readonly("kept_fraction", [](const PyWavelet& p) { return p.t.kept_fraction(); },
                             "Kept coefficients over vertices x 6 r^2")
      .def_property_readonly("nbytes", [](const PyWavelet& p) { return p.t.bytes(); })
      .def_property_readonly("source", [](const PyWavelet& p) { return p.source; })
      .def(
          "coefficients",
          [](const PyWavelet& p, std::int64_t v) {
            if (v < 0 || std::uint64_t(v) >= p.t.vertices)
              throw Error("vertex: " + std::to_string(v) + " is out of range (" + std::to_string(p.t.vertices) +
                          " vertices)");
            const std::vector<float> c = prt::wavelet_vertex_coefficients(p.t, std::size_t(v));
            return copy(c.data(), {py::ssize_t(c.size())});
          },
          py::arg("vertex"),
          "float32 (6 r^2,): the vertex's dequantised Haar coefficients (zeros where dropped), in prt/wavelet.h's "
          "index order")
      .def("write", [](const PyWavelet& p, const py::object& path) { prt::write_wavelet_transfer(path_of(path, "path"), p.t); },
           py::arg("path"), "Writes the file to `path` (atomically) as prt precompute --basis wavelet does (docs/FORMAT.md).")
      .def("describe", [](const PyWavelet& p) { return prt::describe_transfer(p.t); }, "prt info's text")
      .def("__str__", [](const PyWavelet& p) { return prt::describe_transfer(p.t); })
      .def("__repr__", [](const PyWavelet& p) {
        return "<prt.WaveletTransfer " + p.source + ": cube " + std::to_string(p.t.cube_res) + ", " +
               std::to_string(p.t.vertices) + " vertices, " + std::to_string(p.t.kept()) + " coefficients kept>";
      });

  m.def(
      "read_wavelet",
      [](const py::object& path) {
        PyWavelet p;
        p.source = path_of(path, "path");
        p.t = prt::read_wavelet_transfer(p.source);
        return p;
      },
      py::arg("path"), "Reads the wavelet transfer file at `path` (prt precompute --basis wavelet). Returns a WaveletTransfer.");

  m.def(
      "relight",
      [](const PyWavelet& p, const prt::Mesh& mesh, const py::object& map, int terms, const std::string& selection,
         const py::object& rotate, const py::object& lights, const std::string& sun) {
        check_terms(terms);
        const prt::wavelet::Selection sel = [&] {
          try {
            return prt::wavelet::parse_selection(selection);
          } catch (const Error& e) {
            throw Error(std::string("selection: ") + e.what());
          }
        }();
        if (py::isinstance<py::array>(map) && !py::isinstance<prt::EnvMap>(map)) {
          // SH coefficients are not a map: say so rather than read them as pixels.
          const py::array a = map.cast<py::array>();
          if (a.ndim() == 2 && a.shape(1) == 3)
            throw Error("map: a wavelet transfer relights from the map itself (an EnvMap, a file name or an (H, W, "
                        "3) array), not from SH coefficients");
        }
        const glm::dmat3 R = rotate.is_none() ? glm::dmat3(1.0) : to_rotation(rotate, "rotate");
        prt::check_matches(p.t, mesh, p.source);
        std::vector<prt::Light> ls = lights_arg(lights);
        const bool split = sun_arg(sun);
        prt::EnvMap loaded;
        const prt::EnvMap* e = &map_argument(map, loaded);
        prt::require_finite(*e);
        std::vector<glm::vec3> rgb;
        {
          py::gil_scoped_release release;
          // sun='auto': the sky relit through the transfer, the sun traced
          // (prt relight --sun auto; a wavelet transfer has no bounce to give it).
          prt::EnvMap sky;
          if (split) {
            sky = *e;
            if (auto s = take_sun(sky, R)) {
              ls.push_back(std::move(*s));
              e = &sky;
            }
          }
          prt::wavelet::FrameLighting lighting(*e, p.t.cube_res);
          lighting.update(R, terms, sel);
          prt::wavelet_relight(p.t, lighting.coefficients().data(), lighting.terms(), rgb);
          if (!ls.empty()) {
            std::vector<glm::vec3> albedo(rgb.size());
            for (std::size_t v = 0; v < albedo.size(); ++v)
              albedo[v] = p.t.vertex_colors ? p.t.vertex_albedo[v] : p.t.albedo;
            add_direct_light(rgb, ls, mesh, mesh.positions, mesh.normals, albedo);
          }
        }
        return vec3s(rgb);
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("map"), py::kw_only(), py::arg("terms") = 100,
      py::arg("selection") = "area", py::arg("rotate") = py::none(), py::arg("lights") = py::none(),
      py::arg("sun") = "none",
      "A wavelet transfer's outgoing radiance under a map, as prt relight --terms K --selection S [--rotate]: the map resampled to the cube (rotated: light from d arrives from R d), Haar-transformed, its `terms` largest coefficients kept, each vertex's sum over them.\n"
      "\n"
      "Arguments:\n"
      "  transfer: a WaveletTransfer; mesh: the Mesh it was computed for.\n"
      "  map: an EnvMap, a file name or an (H, W, 3) array.\n"
      "  terms: K, the coefficients kept (100) [--terms].\n"
      "  selection: 'area' (|c| times its support's area, Ng et al. 2003) or 'magnitude' (|c|) [--selection].\n"
      "  rotate: a 3x3 rotation or (yaw, pitch, roll) degrees [--rotate].\n"
      "  lights: a list of Light (None: none): their direct light, traced against the mesh at its vertices with the transfer's albedo, is added [--lights] (docs/LIGHTS.md).\n"
      "  sun: 'none' (the map as it is) or 'auto': the map's sun split off (split_sun), the rest relit through the transfer and the sun traced as a directional light turned by rotate [--sun].\n"
      "\n"
      "Returns float32 (V, 3).");
}

}  // namespace prt::python
