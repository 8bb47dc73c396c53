// glTF 2.0 export (prt/gltf.h), written with tinygltf (Debian's
// libtinygltf-dev, header only). Its implementation is compiled in
// tinygltf.cpp, renamed (namespace prt_tinygltf) and with hidden visibility,
// so prt::scene exports none of its symbols and clashes with no copy of
// tinygltf a consumer links, shared or static (tests/gltf_reader.cpp is one).

#include <prt/gltf.h>

#include <prt/error.h>
#include <prt/io.h>
#include <prt/transfer_io.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>

#include "gltf_model.h"

#include <cmath>
#include <fstream>

namespace prt {

namespace {

using json = nlohmann::json;


bool has_all_normals(const Mesh& mesh) {
  if (mesh.normals.size() != mesh.vertex_count()) return false;
  for (const glm::vec3& n : mesh.normals)
    if (!(n.x != 0 || n.y != 0 || n.z != 0)) return false;
  return true;
}

json extras_object(const Mesh& mesh, const Transfer& t, const GltfOptions& opts) {
  const int n = gltf_transfer_attribute_count(t.bands, t.channels);
  json attributes = json::array();
  for (int i = 0; i < n; ++i) attributes.push_back(gltf_transfer_attribute(i));
  json prt = {
      {"format", 1},
      {"basis", "sh"},
      {"bands", t.bands},
      {"coefficients", t.bands * t.bands},
      {"channels", t.channels},
      {"mode", std::string(transfer_mode_name(t.mode))},
      {"attributes", attributes},
      {"layout", "row [channel][k], k = l(l+1)+m, coefficient j in attribute j/4 component j%4, zero padded"},
      {"sh_convention",
       "prt: real orthonormal SH with the Condon-Shortley phase, z polar axis, +Y up (docs/CONVENTIONS.md)"},
      {"shading",
       "radiance[c] = dot(row[c], L[c]) with L[c] the SH coefficients of channel c of the environment's radiance "
       "in prt's convention (prt project --convention prt, the default); a 1-channel row serves R, G and B"},
      // A translucent transfer's rows hold its material's profile, no albedo.
      {"albedo", t.subsurface      ? json("subsurface")
                 : t.vertex_colors ? json("vertex colours")
                                   : json::array({t.albedo.x, t.albedo.y, t.albedo.z})},
      {"vertices", t.vertices},
      {"normals", has_all_normals(mesh) ? "NORMAL" : "omitted: some vertices have none (their transfer is 0)"},
      {"material", t.glossy ? "diffuse part of a glossy transfer" : t.subsurface ? "subsurface" : "diffuse"},
      {"dense", "every vertex has its row (analytic vertices evaluated: prt::dense_transfer)"},
  };
  // The translucent material (docs/FORMAT.md "Subsurface material"): the
  // file's record, its five keys.
  if (t.subsurface) prt["subsurface"] = json::parse(subsurface_record_json(*t.subsurface));
  if (t.mode == TransferMode::Interreflected) prt["bounces"] = t.bounces;
  if (t.samples > 0) prt["samples"] = t.samples;
  if (!opts.transfer_source.empty()) prt["transfer"] = opts.transfer_source;
  if (!opts.colors.empty())
    prt["bake"] = {
        {"attribute", "COLOR_0"},
        {"map", opts.bake.map},
        {"rotate", json::array({opts.bake.rotate[0], opts.bake.rotate[1], opts.bake.rotate[2]})},
        {"exposure", opts.bake.exposure},
        {"color", "linear radiance x 2^exposure, clamped to [0, 1] (prt relight, tone map clamp, not sRGB-encoded)"},
    };
  if (!opts.colors.empty() && !opts.bake.lights.empty()) prt["bake"]["lights"] = opts.bake.lights;
  return prt;
}

}  // namespace

namespace detail {

// extras as tinygltf's Value (it serialises its own type).
tinygltf::Value to_value(const json& j) {
  switch (j.type()) {
    case json::value_t::object: {
      tinygltf::Value::Object o;
      for (auto it = j.begin(); it != j.end(); ++it) o.emplace(it.key(), to_value(it.value()));
      return tinygltf::Value(std::move(o));
    }
    case json::value_t::array: {
      tinygltf::Value::Array a;
      for (const json& e : j) a.push_back(to_value(e));
      return tinygltf::Value(std::move(a));
    }
    case json::value_t::string: return tinygltf::Value(j.get<std::string>());
    case json::value_t::boolean: return tinygltf::Value(j.get<bool>());
    case json::value_t::number_integer:
    case json::value_t::number_unsigned: {
      // tinygltf's integers are int; a count beyond that is written as a number.
      const double d = j.get<double>();
      if (d >= double(std::numeric_limits<int>::min()) && d <= double(std::numeric_limits<int>::max()))
        return tinygltf::Value(j.get<int>());
      return tinygltf::Value(d);
    }
    case json::value_t::number_float: return tinygltf::Value(j.get<double>());
    default: return tinygltf::Value();
  }
}

// Appends `bytes` to the buffer as a view of its own (4-byte aligned) and an
// accessor over it; returns the accessor's index.
int add_accessor(tinygltf::Model& model, const void* bytes, std::size_t size, int target, int component, int type,
                 std::size_t count) {
  std::vector<unsigned char>& data = model.buffers[0].data;
  while (data.size() % 4 != 0) data.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = size;
  view.target = target;
  const auto* p = static_cast<const unsigned char*>(bytes);
  data.insert(data.end(), p, p + size);
  model.bufferViews.push_back(view);
  tinygltf::Accessor a;
  a.bufferView = int(model.bufferViews.size()) - 1;
  a.byteOffset = 0;
  a.componentType = component;
  a.type = type;
  a.count = count;
  model.accessors.push_back(a);
  return int(model.accessors.size()) - 1;
}

// The unit quaternion (x, y, z, w) turning -Z onto unit `d`: the rotation
// of a light's node (KHR_lights_punctual: a light shines down its node's
// -Z). Away from +Z, the shortest arc, (-Z x d, 1 + (-Z . d)) normalised:
// (d.y, -d.x, 0, 1 - d.z). Toward +Z that vanishes and loses precision, so
// there it is a half-turn about X (-Z onto +Z) followed by the shortest arc
// from +Z onto d: (1 + d.z, 0, -d.x, d.y) normalised. Each form's norm is at
// least 1 where it is used: no cancellation.
std::vector<double> rotation_onto(const glm::dvec3& d) {
  const glm::dvec4 q = d.z <= 0 ? glm::dvec4(d.y, -d.x, 0.0, 1.0 - d.z) : glm::dvec4(1.0 + d.z, 0.0, -d.x, d.y);
  const double n = glm::length(q);
  return {q.x / n, q.y / n, q.z / n, q.w / n};
}

void add_lights(tinygltf::Model& model, tinygltf::Scene& scene, const std::vector<Light>& lights,
                const std::string& path) {
  for (std::size_t i = 0; i < lights.size(); ++i) {
    Light l = lights[i];
    check_light(l, fmt::format("{}: light {}", path, i));  // (also makes direction unit length)
    tinygltf::Light gl;
    gl.name = l.name;
    gl.type = std::string(light_type_name(l.type));
    gl.color = {l.color.x, l.color.y, l.color.z};
    gl.intensity = l.intensity;
    if (l.type != LightType::Directional && l.range) gl.range = *l.range;  // tinygltf writes it when > 0
    if (l.type == LightType::Spot) {
      gl.spot.innerConeAngle = l.inner_cone;
      gl.spot.outerConeAngle = l.outer_cone;
    }
    model.lights.push_back(gl);
    tinygltf::Node node;
    node.name = l.name;
    if (l.position != glm::dvec3(0.0)) node.translation = {l.position.x, l.position.y, l.position.z};
    if (l.type != LightType::Point) node.rotation = rotation_onto(l.direction);  // a point light shines every way
    node.extensions["KHR_lights_punctual"] =
        tinygltf::Value(tinygltf::Value::Object{{"light", tinygltf::Value(int(model.lights.size()) - 1)}});
    model.nodes.push_back(std::move(node));
    scene.nodes.push_back(int(model.nodes.size()) - 1);
  }
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

void write_model(const std::string& path, const tinygltf::Model& model, bool binary) {
  // A GLB's header and chunk lengths are 32-bit (the JSON chunk adds a few KB).
  constexpr std::size_t kMaxGlbBuffer = std::numeric_limits<std::uint32_t>::max() - (std::size_t(1) << 20);
  if (binary && !model.buffers.empty() && model.buffers[0].data.size() > kMaxGlbBuffer)
    throw Error(fmt::format("{}: {} bytes of data do not fit a .glb (at most 4 GiB): write fewer bands, or a .gltf",
                            path, model.buffers[0].data.size()));
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(path + ": cannot be written (cannot create " + tmp + ")");
    tinygltf::TinyGLTF writer;
    tinygltf::Model copy = model;  // (tinygltf's writer takes a non-const model)
    if (!writer.WriteGltfSceneToStream(&copy, out, /*prettyPrint=*/false, binary))
      throw Error(path + ": cannot be written (tinygltf failed)");
    out.flush();
    if (!out) throw Error(path + ": cannot be written (I/O error; disk full?)");
  });
}

}  // namespace detail

using detail::add_accessor;
using detail::to_value;
using detail::lower_extension;

std::string gltf_transfer_attribute(int index) { return "_PRT_T" + std::to_string(index); }

int gltf_transfer_attribute_count(int bands, int channels) { return (channels * bands * bands + 3) / 4; }

std::string gltf_extras(const Mesh& mesh, const Transfer& t, const GltfOptions& opts) {
  return extras_object(mesh, t, opts).dump();
}

void write_gltf(const std::string& path, const Mesh& mesh, const Transfer& t, const GltfOptions& opts) {
  const std::string ext = lower_extension(path);
  if (ext != ".glb" && ext != ".gltf")
    throw Error(path + ": expected a .glb (binary glTF) or .gltf (JSON glTF) file name");
  if (const std::string p = transfer_problem(t); !p.empty()) throw Error(path + ": cannot write this transfer: " + p);
  if (t.vertices != mesh.vertex_count())
    throw Error(fmt::format("{}: the transfer has {} vertices, the mesh {} ({})", path, t.vertices,
                            mesh.vertex_count(), mesh.source));
  if (mesh.triangles.empty()) throw Error(path + ": the mesh has no triangles");
  if (!opts.colors.empty()) {
    if (opts.colors.size() != mesh.vertex_count())
      throw Error(fmt::format("{}: {} baked colours for {} vertices", path, opts.colors.size(), mesh.vertex_count()));
    for (std::size_t v = 0; v < opts.colors.size(); ++v)
      for (int c = 0; c < 3; ++c)
        if (!(opts.colors[v][c] >= 0.0f && opts.colors[v][c] <= 1.0f))
          throw Error(fmt::format("{}: baked colour of vertex {} is {} ({} channel): glTF's COLOR_0 must lie in [0, 1]",
                                  path, v, opts.colors[v][c], "rgb"[c]));
  }

  const std::size_t nv = mesh.vertex_count();
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = opts.generator;
  model.asset.extras = tinygltf::Value(tinygltf::Value::Object{{"prt", to_value(extras_object(mesh, t, opts))}});
  model.buffers.emplace_back();

  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.indices = add_accessor(model, mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3),
                              TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                              TINYGLTF_TYPE_SCALAR, mesh.triangles.size() * 3);
  const int pos = add_accessor(model, mesh.positions.data(), nv * sizeof(glm::vec3), TINYGLTF_TARGET_ARRAY_BUFFER,
                               TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  const glm::vec3 lo = mesh.bounds_min(), hi = mesh.bounds_max();
  model.accessors[pos].minValues = {lo.x, lo.y, lo.z};
  model.accessors[pos].maxValues = {hi.x, hi.y, hi.z};
  prim.attributes["POSITION"] = pos;
  if (has_all_normals(mesh))
    prim.attributes["NORMAL"] = add_accessor(model, mesh.normals.data(), nv * sizeof(glm::vec3),
                                             TINYGLTF_TARGET_ARRAY_BUFFER, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                             TINYGLTF_TYPE_VEC3, nv);
  if (!opts.colors.empty())
    prim.attributes["COLOR_0"] = add_accessor(model, opts.colors.data(), nv * sizeof(glm::vec3),
                                              TINYGLTF_TARGET_ARRAY_BUFFER, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                              TINYGLTF_TYPE_VEC3, nv);

  // The dense rows, attribute by attribute (each a VEC4 array over the vertices).
  const std::vector<float> dense = dense_transfer(t, mesh);
  const std::size_t stride = t.stride();
  const int na = gltf_transfer_attribute_count(t.bands, t.channels);
  std::vector<float> column(nv * 4);
  for (int a = 0; a < na; ++a) {
    for (std::size_t v = 0; v < nv; ++v)
      for (std::size_t c = 0; c < 4; ++c) {
        const std::size_t j = std::size_t(a) * 4 + c;
        column[v * 4 + c] = j < stride ? dense[v * stride + j] : 0.0f;
      }
    prim.attributes[gltf_transfer_attribute(a)] =
        add_accessor(model, column.data(), column.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER,
                     TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, nv);
  }

  // A bake shows as it is in any viewer: unlit, base colour 1, so the colour
  // drawn is COLOR_0 (glTF: unlit = baseColor x COLOR_0). Without a
  // material glTF's default one is fully metallic and draws the bake black
  // where there is no environment. Without a bake: no material, as before.
  if (!opts.colors.empty()) {
    prim.material = detail::add_material(model, "prt_bake", glm::vec4(1.0f), -1, 0, /*unlit=*/true);
    model.extensionsUsed.push_back("KHR_materials_unlit");
  }

  tinygltf::Mesh gmesh;
  gmesh.name = std::filesystem::path(mesh.source).stem().string();
  gmesh.primitives.push_back(std::move(prim));
  model.meshes.push_back(std::move(gmesh));
  tinygltf::Node node;
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes = {0};
  detail::add_lights(model, scene, opts.lights, path);
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  detail::write_model(path, model, ext == ".glb");
}

}  // namespace prt
