// python/src/bind_lights.cpp - prt's Python module: lights inside a scene
// (Light, read_lights, split_sun, direct_light; docs/LIGHTS.md) and what the
// relighting calls' lights= and sun= arguments share (module.h).
#include "module.h"

#include <prt/direct_light.h>
#include <prt/lights.h>
#include <prt/mesh.h>
#include <prt/scene.h>
#include <prt/sun.h>

#include <glm/geometric.hpp>

#include <numbers>
#include <sstream>

namespace prt::python {

// ---- lights=, sun= (module.h) ----------------------------------------------------

std::vector<prt::Light> lights_arg(const py::object& lights, const char* what) {
  std::vector<prt::Light> out;
  if (lights.is_none()) return out;
  const std::string w = what;
  const std::string rule =
      w + ": expected a list of prt.Light (prt.Light(...), prt.read_lights(path), Scene.lights) or None";
  if (py::isinstance<prt::Light>(lights)) throw Error(rule + ", got one Light (pass [light])");
  if (py::isinstance<py::str>(lights) || is_path(lights))
    throw Error(rule + ", got the file name " + std::string(py::repr(lights)) +
                " (read a lights file with prt.read_lights(path))");
  if (!py::isinstance<py::iterable>(lights) || py::isinstance<py::bytes>(lights) || py::isinstance<py::dict>(lights))
    throw Error(rule + ", got " + std::string(py::str(py::type::of(lights).attr("__name__"))));
  std::size_t i = 0;
  for (const py::handle item : lights) {
    if (!py::isinstance<prt::Light>(item))
      throw Error(w + "[" + std::to_string(i) + "]: expected a prt.Light, got " +
                  std::string(py::str(py::type::of(item).attr("__name__"))));
    out.push_back(item.cast<prt::Light>());
    prt::check_light(out.back(), w + "[" + std::to_string(i) + "]");
    ++i;
  }
  return out;
}

bool sun_arg(const std::string& sun) {
  if (sun == "auto") return true;
  if (sun == "none") return false;
  throw Error("sun: '" + sun + "': expected 'none' (the map as it is) or 'auto' (its sun split off into a directional "
              "light: split_sun)");
}

std::optional<prt::Light> take_sun(prt::EnvMap& map, const glm::dmat3& rotation) {
  std::optional<prt::SunSplit> split = prt::split_sun(map);
  if (!split) return std::nullopt;
  prt::Light l = prt::sun_light(split->sun, rotation);
  map = std::move(split->sky);
  return l;
}

void add_direct_light(std::vector<glm::vec3>& rgb, const std::vector<prt::Light>& lights, const prt::Mesh& occluders,
                      std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                      std::span<const glm::vec3> albedo, const std::optional<prt::GlossyLobe>& lobe,
                      const prt::LightBounce& bounce) {
  if (lights.empty()) return;
  const prt::DirectLight direct(occluders);
  const std::vector<glm::vec3> d = direct.radiance(lights, positions, normals, albedo, lobe);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] += d[i];
  if (bounce.empty()) return;
  const std::vector<glm::vec3> b = prt::light_bounce(bounce, d, albedo);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] += b[i];
}

namespace {

constexpr double kDefaultOuterCone = std::numbers::pi / 4;  // KHR_lights_punctual's default (prt::Light's)

prt::LightType type_arg(const std::string& type) {
  if (type == "point") return prt::LightType::Point;
  if (type == "spot") return prt::LightType::Spot;
  if (type == "directional") return prt::LightType::Directional;
  throw Error("type: '" + type + "': expected 'point', 'spot' or 'directional' (KHR_lights_punctual's types)");
}

// Three finite numbers (x, y, z).
glm::dvec3 triple_arg(const py::handle& obj, const std::string& what) {
  const DArray a = real_array<double>(obj, what);
  if (a.ndim() != 1 || a.shape(0) != 3) throw Error(what + ": expected 3 numbers, got shape " + shape_text(a));
  return {a.data()[0], a.data()[1], a.data()[2]};
}

// One finite real number (a property's new value).
double number_arg(const py::handle& obj, const std::string& what) {
  const DArray a = real_array<double>(obj, what);
  if (a.ndim() != 0) throw Error(what + ": expected a number, got shape " + shape_text(a));
  return a.data()[0];
}

py::tuple tuple3(const glm::dvec3& v) { return py::make_tuple(v.x, v.y, v.z); }

// Changes `light` through `set` only if the result is a valid light
// (check_light): a refused value leaves the light as it was.
template <typename F>
void update(prt::Light& light, F set) {
  prt::Light changed = light;
  set(changed);
  prt::check_light(changed, "Light");
  light = std::move(changed);
}

std::string number(double x) {
  std::ostringstream s;
  s.precision(6);
  s << x;
  return s.str();
}

std::string triple_text(const glm::dvec3& v) {
  return "(" + number(v.x) + ", " + number(v.y) + ", " + number(v.z) + ")";
}

std::string light_repr(const prt::Light& l) {
  std::string s = "<prt.Light " + std::string(prt::light_type_name(l.type));
  if (!l.name.empty()) s += " '" + l.name + "'";
  s += ": intensity " + number(l.intensity) + ", color " + triple_text(l.color);
  if (l.type != prt::LightType::Directional) s += ", position " + triple_text(l.position);
  if (l.type != prt::LightType::Point) s += ", direction " + triple_text(l.direction);
  if (l.type == prt::LightType::Spot) s += ", cone " + number(l.inner_cone) + " to " + number(l.outer_cone) + " rad";
  if (l.range) s += ", range " + number(*l.range);
  return s + ">";
}

bool same_light(const prt::Light& a, const prt::Light& b) {
  return a.type == b.type && a.name == b.name && a.color == b.color && a.intensity == b.intensity &&
         a.range == b.range && a.position == b.position && a.direction == b.direction &&
         a.inner_cone == b.inner_cone && a.outer_cone == b.outer_cone;
}

// The Light class.
void bind_light_class(py::module_& m) {
  py::class_<prt::Light>(m, "Light",
                         "A light inside the scene (prt/lights.h, docs/LIGHTS.md): a point, spot or directional light "
                         "as glTF's KHR_lights_punctual defines it, in world space, in the map's radiance unit (a "
                         "point light of intensity I gives irradiance I / d^2 facing it; a directional one I)")
      .def(py::init([](const std::string& type, const py::object& color, double intensity, const py::object& range,
                       const py::object& position, const py::object& direction, double inner_cone_angle,
                       double outer_cone_angle, const std::string& name) {
             prt::Light l;
             l.type = type_arg(type);
             l.name = name;
             l.color = triple_arg(color, "color");
             l.intensity = intensity;
             if (!range.is_none()) {
               if (l.type == prt::LightType::Directional)
                 throw Error("range: a directional light has no range (it is infinitely far)");
               l.range = number_arg(range, "range");
             }
             l.position = triple_arg(position, "position");
             if (l.type == prt::LightType::Directional && l.position != glm::dvec3(0.0))
               throw Error("position: a directional light has no position (it is infinitely far: give its direction)");
             if (l.type == prt::LightType::Point) {
               if (!direction.is_none())
                 throw Error("direction: a point light shines every way (a light with a direction is a 'spot')");
             } else {
               if (direction.is_none())
                 throw Error("direction: a " + type + " light needs its direction (the way its light travels)");
               l.direction = triple_arg(direction, "direction");
             }
             // Cone angles given to another type are refused, as in a lights file.
             if (l.type != prt::LightType::Spot && (inner_cone_angle != 0.0 || outer_cone_angle != kDefaultOuterCone))
               throw Error("inner_cone_angle, outer_cone_angle: cone angles apply to spot lights, not " + type +
                           " ones");
             l.inner_cone = inner_cone_angle;
             l.outer_cone = outer_cone_angle;
             prt::check_light(l, "Light");
             return l;
           }),
           py::arg("type") = "point", py::kw_only(), py::arg("color") = py::make_tuple(1.0, 1.0, 1.0),
           py::arg("intensity") = 1.0, py::arg("range") = py::none(),
           py::arg("position") = py::make_tuple(0.0, 0.0, 0.0),
           py::arg("direction") = py::none(), py::arg("inner_cone_angle") = 0.0,
           py::arg("outer_cone_angle") = kDefaultOuterCone, py::arg("name") = "",
           "A light, checked as a --lights file's (a prt.Error names what is out of range).\n"
           "\n"
           "Arguments (the lights file's key in brackets):\n"
           "  type: 'point', 'spot' or 'directional' [type].\n"
           "  color: linear RGB (r, g, b), each >= 0 ((1, 1, 1)) [color].\n"
           "  intensity: >= 0: candela for point and spot lights, lux for directional ones, in the map's radiance unit (1) [intensity].\n"
           "  range: point and spot: > 0, the distance past which the light gives nothing (KHR's window), or None [range].\n"
           "  position: point and spot: (x, y, z) in world space ((0, 0, 0)) [position].\n"
           "  direction: spot and directional (required): (x, y, z), the way the light travels (normalised) [direction].\n"
           "  inner_cone_angle, outer_cone_angle: spot: radians, 0 <= inner < outer <= pi/2 (0 and pi/4) [innerConeAngle, outerConeAngle].\n"
           "  name: a name for messages ('') [name].")
      .def_property(
          "type", [](const prt::Light& l) { return std::string(prt::light_type_name(l.type)); },
          [](prt::Light& l, const std::string& t) { update(l, [&](prt::Light& c) { c.type = type_arg(t); }); },
          "'point', 'spot' or 'directional'")
      .def_property(
          "name", [](const prt::Light& l) { return l.name; },
          [](prt::Light& l, const std::string& n) { l.name = n; },
          "The light's name (a glTF light's name, or 'light N')")
      .def_property(
          "color", [](const prt::Light& l) { return tuple3(l.color); },
          [](prt::Light& l, const py::object& v) {
            update(l, [&](prt::Light& c) { c.color = triple_arg(v, "color"); });
          },
          "(r, g, b), linear, each >= 0")
      .def_property(
          "intensity", [](const prt::Light& l) { return l.intensity; },
          [](prt::Light& l, const py::object& v) {
            update(l, [&](prt::Light& c) { c.intensity = number_arg(v, "intensity"); });
          },
          "Candela (point, spot) or lux (directional), >= 0, in the map's radiance unit")
      .def_property(
          "range",
          [](const prt::Light& l) -> py::object {
            return l.range ? py::object(py::float_(*l.range)) : py::object(py::none());
          },
          [](prt::Light& l, const py::object& v) {
            update(l, [&](prt::Light& c) {
              if (v.is_none()) c.range.reset();
              else c.range = number_arg(v, "range");
            });
          },
          "Point and spot: the distance past which the light gives nothing (> 0), or None")
      .def_property(
          "position", [](const prt::Light& l) { return tuple3(l.position); },
          [](prt::Light& l, const py::object& v) {
            update(l, [&](prt::Light& c) { c.position = triple_arg(v, "position"); });
          },
          "Point and spot: (x, y, z), world space")
      .def_property(
          "direction", [](const prt::Light& l) { return tuple3(l.direction); },
          [](prt::Light& l, const py::object& v) {
            update(l, [&](prt::Light& c) { c.direction = triple_arg(v, "direction"); });
          },
          "Spot and directional: the unit direction the light travels (a value set is normalised)")
      .def_property(
          "inner_cone_angle", [](const prt::Light& l) { return l.inner_cone; },
          [](prt::Light& l, const py::object& v) {
            update(l, [&](prt::Light& c) { c.inner_cone = number_arg(v, "inner_cone_angle"); });
          },
          "Spot: radians, 0 <= inner < outer")
      .def_property(
          "outer_cone_angle", [](const prt::Light& l) { return l.outer_cone; },
          [](prt::Light& l, const py::object& v) {
            update(l, [&](prt::Light& c) { c.outer_cone = number_arg(v, "outer_cone_angle"); });
          },
          "Spot: radians, inner < outer <= pi/2")
      .def("__eq__", [](const prt::Light& a, const py::object& b) {
        return py::isinstance<prt::Light>(b) && same_light(a, b.cast<const prt::Light&>());
      })
      .def("__copy__", [](const prt::Light& l) { return l; })
      .def("__deepcopy__", [](const prt::Light& l, const py::object&) { return l; }, py::arg("memo"))
      .def("__repr__", &light_repr);
  // __eq__ without __hash__: a Light can change, so it is not hashable.
  m.attr("Light").attr("__hash__") = py::none();
}

// read_lights, split_sun, direct_light.
void bind_light_functions(py::module_& m) {
  m.def(
      "read_lights",
      [](const py::object& path) {
        py::list out;  // (a list, not List[Light]: the stubs name no typing generics)
        for (prt::Light& l : prt::read_lights_json(path_of(path, "path"))) out.append(py::cast(std::move(l)));
        return out;
      },
      py::arg("path"),
      "Reads the lights file at `path` (prt relight --lights FILE.json): a JSON array of point, spot and directional lights in world "
      "space (docs/LIGHTS.md). Returns a list of Light, each named by its \"name\" or 'light N'. Raises prt.Error "
      "naming the file, the light's index and the problem (an unknown key, a field out of range).");

  m.def(
      "split_sun",
      [](const py::object& map, const py::object& rotate) -> py::object {
        prt::EnvMap loaded;
        const prt::EnvMap* e = &map_argument(map, loaded);
        const glm::dmat3 R = rotate.is_none() ? glm::dmat3(1.0) : to_rotation(rotate, "rotate");
        std::optional<prt::SunSplit> split;
        {
          py::gil_scoped_release release;
          split = prt::split_sun(*e);
        }
        if (!split) return py::none();
        const prt::Sun& s = split->sun;
        prt::Light light = prt::sun_light(s, R);
        py::dict info;
        info["direction"] = tuple3(glm::normalize(R * s.direction));
        info["irradiance"] = tuple3(s.irradiance);
        info["solid_angle"] = s.solid_angle;
        info["pixels"] = s.pixels;
        info["power_fraction"] = s.power_fraction;
        return py::make_tuple(py::cast(std::move(split->sky)), py::cast(std::move(light)), info);
      },
      py::arg("map"), py::kw_only(), py::arg("rotate") = py::none(),
      "The sun split of prt relight --sun auto (docs/LIGHTS.md, prt/sun.h): the map's brightest compact source taken "
      "out of it as a directional light of the same irradiance, with sharp shadows.\n"
      "\n"
      "Arguments:\n"
      "  map: an EnvMap, a file name or an array (H, W, 3) or (6, N, N, 3).\n"
      "  rotate: the rotation the map will be lit with, a 3x3 matrix or (yaw, pitch, roll) degrees (light from d arrives from R d) [--rotate]: it turns the sun's light and info's direction, not the sky (pass the same rotate= to the call that takes the sky).\n"
      "\n"
      "Returns None when the map has no compact bright source (overcast, studio lamps), else (sky, sun, info): sky an "
      "EnvMap, the map less the sun's excess over its rim (same layout; sky + sun hold the map's power); sun a "
      "directional Light named 'sun'; info a dict: direction (unit, toward the sun, turned by rotate), irradiance "
      "(r, g, b) on a surface facing it, solid_angle (sr), pixels, power_fraction (its share of the map's luminance "
      "x solid angle).\n"
      "\n"
      "For calls that take SH lighting (relight of a Transfer, ZhTransfer or Lightmap): project the sky and pass the "
      "sun in lights=.");

  m.def(
      "direct_light",
      [](const py::object& geometry, const py::object& lights, const py::object& positions, const py::object& normals,
         const py::object& albedo, double offset) {
        const prt::Mesh* mesh = nullptr;
        if (py::isinstance<prt::Mesh>(geometry)) mesh = &geometry.cast<const prt::Mesh&>();
        else if (py::isinstance<prt::Scene>(geometry)) mesh = &geometry.cast<const prt::Scene&>().mesh;
        else
          throw Error("mesh: expected a prt.Mesh or a prt.Scene (the occluders), got " +
                      std::string(py::str(py::type::of(geometry).attr("__name__"))));
        const std::vector<prt::Light> ls = lights_arg(lights);
        if (positions.is_none() != normals.is_none())
          throw Error(std::string(positions.is_none() ? "positions" : "normals") +
                      ": missing: positions and normals go together (None for both: the mesh's vertices)");
        std::vector<glm::vec3> p, n;
        if (!positions.is_none()) {
          p = to_vec3s(positions, "positions");
          n = to_vec3s(normals, "normals", p.size(), "point");
        }
        const std::span<const glm::vec3> ps = positions.is_none() ? std::span<const glm::vec3>(mesh->positions) : p;
        const std::span<const glm::vec3> ns = positions.is_none() ? std::span<const glm::vec3>(mesh->normals) : n;
        std::vector<glm::vec3> rho;
        const DArray a = real_array<double>(albedo, "albedo");
        if (a.ndim() == 2) {
          rho = to_vec3s(albedo, "albedo", ps.size(), "point");
        } else {
          rho.assign(ps.size(), to_albedo(albedo));
        }
        for (std::size_t i = 0; i < rho.size(); ++i)
          for (int c = 0; c < 3; ++c)
            if (!(rho[i][c] >= prt::kMinAlbedo && rho[i][c] <= prt::kMaxAlbedo))
              throw Error("albedo: " + number_text(rho[i][c]) +
                          (a.ndim() == 2 ? " (row " + std::to_string(i) + ")" : "") + " is outside [0, 1]");
        if (!(offset >= 0)) throw Error("offset: must be >= 0 (0: 1e-4 x the bounding-box diagonal)");
        std::vector<glm::vec3> rgb(ps.size(), glm::vec3(0.0f));
        {
          py::gil_scoped_release release;
          const prt::DirectLight direct(*mesh, offset);
          rgb = direct.radiance(ls, ps, ns, rho);
        }
        return vec3s(rgb);
      },
      py::arg("mesh"), py::arg("lights"), py::arg("positions") = py::none(), py::arg("normals") = py::none(),
      py::kw_only(), py::arg("albedo") = 0.8, py::arg("offset") = 0.0,
      "The lights' direct light at points on the surfaces (prt/direct_light.h): B = albedo / pi x sum over lights of "
      "E_l max(n . l, 0) V, each light's visibility V traced (sharp shadows). What prt relight adds to the PRT "
      "relighting and the noise-free part of prt reference with lights. Releases the GIL.\n"
      "\n"
      "Arguments:\n"
      "  mesh: a Mesh or a Scene: the occluders (and, without positions, the points: its vertices).\n"
      "  lights: a list of Light (None: none).\n"
      "  positions, normals: float (N, 3) each, the points and their normals (normalised; a zero normal gives 0), or None for both: the mesh's vertices and normals.\n"
      "  albedo: a number, (r, g, b) or (N, 3) per point, in [0, 1] (0.8, reference()'s default).\n"
      "  offset: the shadow rays' origin offset, mesh units (0: 1e-4 x the bounding-box diagonal) [--offset].\n"
      "\n"
      "Returns float32 (N, 3) linear RGB radiance.");
}

}  // namespace

void bind_lights(py::module_& m) {
  bind_light_class(m);
  bind_light_functions(m);
}

}  // namespace prt::python
