// python/src/bind_maps.cpp - prt's Python module: maps (EnvMap, load_envmap,
// read_exr), their projection to SH, and SH evaluation and rotation.
#include "module.h"

#include <prt/filter.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <algorithm>
#include <array>
#include <span>

namespace prt::python {
namespace {

// (N, 3) or (3,) -> N rows; `what` names the argument in the message.
std::size_t rows_of3(const py::array& a, const char* what) {
  if (a.ndim() == 1 && a.shape(0) == 3) return 1;
  if (a.ndim() == 2 && a.shape(1) == 3) return std::size_t(a.shape(0));
  throw Error(std::string(what) + ": expected an array of shape (N, 3) or (3,), got " + shape_text(a));
}

py::array_t<double> from_coeffs(const std::vector<glm::dvec3>& c) {
  return copy(reinterpret_cast<const double*>(c.data()), {py::ssize_t(c.size()), 3});
}

int bands_of_count(std::size_t n, const char* what) {
  const int b = int(std::lround(std::sqrt(double(n))));
  if (b < 1 || std::size_t(b) * std::size_t(b) != n)
    throw Error(std::string(what) + ": " + std::to_string(n) + " coefficients is not a square number n*n");
  return b;
}

py::array_t<double> from_mat(const glm::dmat3& m) {
  py::array_t<double> a({3, 3});
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.mutable_at(i, j) = m[j][i];  // glm is column-major
  return a;
}

// A list or tuple of six file names (str or os.PathLike): a cube's faces
// +X, -X, +Y, -Y, +Z, -Z; anything else is not (an array's nested lists).
std::optional<std::array<std::string, 6>> face_files(const py::handle& h) {
  if (!py::isinstance<py::list>(h) && !py::isinstance<py::tuple>(h)) return std::nullopt;
  const py::sequence seq = py::reinterpret_borrow<py::sequence>(h);
  bool paths = py::len(seq) > 0;
  for (const py::handle item : seq) paths = paths && is_path(item);
  if (!paths) return std::nullopt;
  if (py::len(seq) != 6)
    throw Error("map: a list of " + std::to_string(py::len(seq)) +
                " files; a cube's faces are six files +X, -X, +Y, -Y, +Z, -Z");
  std::array<std::string, 6> f;
  for (std::size_t i = 0; i < 6; ++i) f[i] = path_of(seq[i], "map");
  return f;
}

py::dict stats_dict(const prt::MapStats& s) {
  py::dict d;
  d["min"] = s.min;
  d["max"] = s.max;
  d["mean"] = s.mean;
  d["pixels"] = s.pixels;
  d["negative"] = s.negative;
  d["nonfinite"] = s.nonfinite;
  d["first_nonfinite"] = s.first_nonfinite;
  return d;
}

// EnvMap, load_envmap, read_exr.
void bind_maps_envmap(py::module_& m) {
  // ---- maps ----
  py::class_<prt::EnvMap>(m, "EnvMap", "An environment map: linear RGB float pixels (prt/envmap.h)")
      .def_property_readonly(
          "pixels",
          [](py::object self) {
            const auto& e = self.cast<const prt::EnvMap&>();
            if (e.is_cube()) return view(e.rgb.data(), {6, e.width, e.width, 3}, self);
            return view(e.rgb.data(), {e.height, e.width, 3}, self);
          },
          "float32, (H, W, 3) for a lat-long map (row 0 at the top), (6, N, N, 3) for a cube "
          "(+X, -X, +Y, -Y, +Z, -Z); read-only")
      .def_property_readonly("mapping", [](const prt::EnvMap& e) { return std::string(e.is_cube() ? "faces" : "latlong"); },
                             "'latlong' or 'faces' (a cube)")
      .def_property_readonly("width", [](const prt::EnvMap& e) { return e.width; })
      .def_property_readonly("height", [](const prt::EnvMap& e) { return e.height; })
      .def_property_readonly("source", [](const prt::EnvMap& e) { return e.source; })
      .def_property_readonly("source_layout", [](const prt::EnvMap& e) { return e.source_layout; },
                             "How the file stored it: 'lat-long', 'horizontal cross', ...")
      .def_property_readonly("source_channels", [](const prt::EnvMap& e) { return e.source_channels; })
      .def_property_readonly("stats", [](const prt::EnvMap& e) { return stats_dict(e.stats); },
                             "min, max, mean, pixels, negative, nonfinite: what prt project prints")
      .def("__repr__", [](const prt::EnvMap& e) { return "<prt.EnvMap " + prt::describe(e) + ">"; })
      .def("__str__", [](const prt::EnvMap& e) { return prt::describe(e); });

  m.def(
      "load_envmap",
      [](const py::object& path, const std::string& mapping) {
        const prt::Mapping mp = prt::parse_mapping(mapping);
        const std::optional<std::array<std::string, 6>> files = face_files(path);
        if (files) return prt::load_cube_faces(*files);
        if (mp == prt::Mapping::Faces || py::isinstance<py::list>(path) || py::isinstance<py::tuple>(path))
          throw Error("path: mapping 'faces' needs a list of six files +X, -X, +Y, -Y, +Z, -Z");
        return prt::load_envmap(path_of(path, "path"), mp);
      },
      py::arg("path"), py::arg("mapping") = "auto",
      "Reads a map (EXR; HDR, PNG, ... through prt's OpenImageIO plugin). mapping: auto (from the shape), latlong, "
      "hcross, vcross, or faces (path: six files).");

  m.def(
      "read_exr",
      [](const py::object& path) {
        const std::string p = path_of(path, "path");
        prt::RgbaImage img;
        {
          py::gil_scoped_release release;
          img = prt::read_exr_rgba(p);
        }
        if (img.has_alpha) return copy(img.rgba.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 4});
        std::vector<float> rgb(std::size_t(img.width) * img.height * 3);
        for (std::size_t i = 0; i < rgb.size() / 3; ++i)
          std::copy_n(img.rgba.begin() + std::ptrdiff_t(i * 4), 3, rgb.begin() + std::ptrdiff_t(i * 3));
        return copy(rgb.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 3});
      },
      py::arg("path"),
      "The pixels of the EXR image at `path` as float32 (height, width, 4) when it has an alpha channel (prt render --alpha, lightmaps: A is coverage), else (height, width, 3); row 0 at the top.");
}

// project, sh_eval, rotation_from_euler, rotate_sh.
void bind_maps_sh(py::module_& m) {
  m.def(
      "project",
      [](const py::object& map, int bands, const std::string& mapping, const std::string& quadrature,
         bool irradiance, const std::string& window, double window_width, const py::object& rotate) {
        const prt::Quadrature q = prt::parse_quadrature(quadrature);
        const prt::sh::Window w = prt::sh::parse_window(window);
        if (window_width < 0)  // prt project --window-width: a positive number of bands
          throw Error("window_width: the window's width in bands, > 0 (0: the band count), got " +
                      number_text(window_width));
        std::optional<glm::dmat3> R;
        if (!rotate.is_none()) R = to_rotation(rotate, "rotate");
        std::vector<glm::dvec3> c;
        if (py::isinstance<prt::EnvMap>(map)) {
          const auto& e = map.cast<const prt::EnvMap&>();
          py::gil_scoped_release release;
          c = prt::project(e, bands, q);
        } else if (const auto f = face_files(map)) {  // six face files
          const prt::EnvMap e = prt::load_cube_faces(*f);
          py::gil_scoped_release release;
          c = prt::project(e, bands, q);
        } else if (is_path(map)) {
          const std::string path = path_of(map, "map");
          py::gil_scoped_release release;
          c = prt::project_file(path, bands, q, prt::parse_mapping(mapping)).coeffs;  // as prt project
        } else {
          const prt::EnvMap e = map_from_array(map);
          py::gil_scoped_release release;
          c = prt::project(e, bands, q);
        }
        if (irradiance) prt::sh::scale_bands(std::span<glm::dvec3>(c), prt::sh::clamped_cosine_factors(bands));
        prt::sh::apply_window(std::span<glm::dvec3>(c), w, window_width > 0 ? window_width : bands);
        if (R) {
          std::vector<glm::dvec3> r(c.size());
          prt::sh::Rotation(bands, *R).apply(c, r);
          c.swap(r);
        }
        return from_coeffs(c);
      },
      py::arg("map"), py::arg("bands") = 3, py::kw_only(), py::arg("mapping") = "auto",
      py::arg("quadrature") = "box", py::arg("irradiance") = false, py::arg("window") = "none",
      py::arg("window_width") = 0.0, py::arg("rotate") = py::none(),
      "SH coefficients of a map, as prt project computes them: projection, then irradiance, window and rotation.\n"
      "\n"
      "Arguments (prt project's option in brackets):\n"
      "  map: an EnvMap, a file name, a list of six face files, or an array (H, W, 3) (lat-long) or (6, N, N, 3) (cube faces +X, -X, +Y, -Y, +Z, -Z).\n"
      "  bands: SH bands n, 1 to 64 (MAX_BANDS) [--bands].\n"
      "  mapping: how to read a file: 'auto' (from the shape), 'latlong', 'hcross', 'vcross' or 'faces' [--mapping].\n"
      "  quadrature: 'box' (texels are area averages, integrated exactly) or 'point' (point samples; lat-long only) [--quadrature].\n"
      "  irradiance: convolve with the clamped cosine (Ramamoorthi & Hanrahan's A_l) [--irradiance].\n"
      "  window: 'none', 'hanning', 'lanczos' or 'auto' ringing suppression [--window]; window_width: its width in bands, > 0 (0: the band count) [--window-width].\n"
      "  rotate: a 3x3 rotation R or (yaw, pitch, roll) degrees; light from d arrives from R d [--rotate].\n"
      "\n"
      "Returns float64 (bands*bands, 3), index k = l(l+1)+m (docs/CONVENTIONS.md).");

  m.def(
      "sh_eval",
      [](int bands, const py::object& dirs) {
        prt::sh::check_bands(bands, "bands");
        DArray d = real_array<double>(dirs, "dirs");
        const std::size_t n = rows_of3(d, "dirs");
        const std::size_t nc = std::size_t(bands) * bands;
        std::vector<double> unit(3 * n);
        for (std::size_t i = 0; i < n; ++i) {
          const double* p = d.data() + 3 * i;
          const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
          if (!(len > 0) || !std::isfinite(len))
            throw Error("dirs: direction " + std::to_string(i) + " has length " + std::to_string(len) +
                        "; give non-zero finite directions");
          for (int k = 0; k < 3; ++k) unit[3 * i + k] = p[k] / len;
        }
        py::array_t<double> out(d.ndim() == 1 ? std::vector<py::ssize_t>{py::ssize_t(nc)}
                                              : std::vector<py::ssize_t>{py::ssize_t(n), py::ssize_t(nc)});
        prt::sh::eval_batch(bands, unit.data(), n, out.mutable_data());
        return out;
      },
      py::arg("bands"), py::arg("dirs"),
      "The real SH basis functions at directions.\n"
      "\n"
      "Arguments:\n"
      "  bands: n, 1 to 64 (MAX_BANDS); dirs: (N, 3) directions (normalised first).\n"
      "\n"
      "Returns float64 (N, bands*bands), index k = l(l+1)+m (docs/CONVENTIONS.md).");

  m.def("rotation_from_euler",
        [](double yaw, double pitch, double roll) {
          for (const auto& [name, x] : {std::pair{"yaw", yaw}, std::pair{"pitch", pitch}, std::pair{"roll", roll}})
            if (!std::isfinite(x)) throw Error(std::string(name) + ": " + number_text(x) + " degrees; must be finite");
          return from_mat(prt::sh::rotation_from_euler(yaw, pitch, roll));
        },
        py::arg("yaw"), py::arg("pitch"), py::arg("roll"),
        "The 3x3 matrix --rotate yaw,pitch,roll (degrees) means: R = Ry(yaw) Rx(pitch) Rz(roll).");

  m.def(
      "rotate_sh",
      [](const py::object& coeffs, const py::object& rotation) {
        DArray c = real_array<double>(coeffs, "coeffs");
        if (c.ndim() < 1 || c.ndim() > 2 || c.shape(0) < 1)
          throw Error("coeffs: expected an array of shape (n*n,) or (n*n, C), got " + shape_text(c));
        const std::size_t nc = std::size_t(c.shape(0));
        const int bands = bands_of_count(nc, "coeffs");
        const std::size_t cols = c.ndim() == 2 ? std::size_t(c.shape(1)) : 1;
        const prt::sh::Rotation rot(bands, to_rotation(rotation, "rotation"));
        py::array_t<double> out(c.request().shape);
        std::vector<double> in(nc), res(nc);
        for (std::size_t j = 0; j < cols; ++j) {
          for (std::size_t k = 0; k < nc; ++k) in[k] = c.data()[k * cols + j];
          rot.apply(std::span<const double>(in), std::span<double>(res));
          for (std::size_t k = 0; k < nc; ++k) out.mutable_data()[k * cols + j] = res[k];
        }
        return out;
      },
      py::arg("coeffs"), py::arg("rotation"),
      "Rotates SH coefficients: the lighting turned so that light from d arrives from R d (prt's --rotate).\n"
      "\n"
      "Arguments:\n"
      "  coeffs: (n*n,) or (n*n, C).\n"
      "  rotation: a 3x3 rotation matrix R, or (yaw, pitch, roll) degrees as --rotate.\n"
      "\n"
      "Returns float64 of coeffs' shape.");
}

}  // namespace

void bind_maps(py::module_& m) {
  bind_maps_envmap(m);
  bind_maps_sh(m);
}

}  // namespace prt::python
