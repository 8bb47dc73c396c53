#include "inputs.h"
#include "lightmap_inputs.h"

#include <prt/error.h>
#include <prt/rotation.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace prt::cli {

namespace {

// The header fields of `t` without its arrays: what commands read of a
// compressed transfer's uncompressed part (mode, bands, glossy, albedo),
// without a second copy of its per-vertex slots, occlusion and bent normals.
Transfer header_only(const Transfer& t) {
  Transfer h;
  h.header() = t.header();
  h.shading_hash = t.shading_hash;
  h.glossy = t.glossy && t.glossy_rows == 0;  // a directional lightmap's rows are no glossy material
  h.direct_energy = t.direct_energy;
  return h;
}

bool is_lightmap(TransferKind k) { return k == TransferKind::Lightmap || k == TransferKind::WaveletLightmap; }

// Each kind's match check against what it was computed for, and its SH header.
void check_loaded(Scene& s, const std::string& transfer, int max_bands, const char* command) {
  s.header = Transfer{};
  dispatch(
      s.transfer,
      [&](const Transfer& t) {
        check_matches(t, s.mesh, transfer);
        s.header = header_only(t);
      },
      [&](const CompressedTransfer& c) {
        check_matches(c, s.mesh, transfer);
        s.header = header_only(c.transfer);
      },
      [&](const WaveletTransfer& w) { check_matches(w, s.mesh, transfer); },
      [&](const ZhTransfer& z) {
        check_matches(z, s.mesh, transfer);
        s.header.header() = z.header();
      },
      [&](const LightmapTransfer& l) { s.header = header_only(l.transfer); },  // the renderer checks the scene
      [&](const WaveletLightmap&) {},
      [&](const ProbeTransfer&) {});
  if (max_bands > 0 && s.header.bands > max_bands)
    throw Error(fmt::format("{}: {} bands; prt {} takes at most {} (what the renderer's lighting block holds; "
                            "prt relight takes any)",
                            transfer, s.header.bands, command, max_bands));
}

}  // namespace

void load_transfer(Scene& s, const std::string& transfer, Consumer consumer, int max_bands, const char* command) {
  s.transfer = read_transfer_file(transfer);
  require_support(s.kind(), consumer, transfer);
  check_loaded(s, transfer, max_bands, command);
}

void upload(Renderer& renderer, const Scene& scene, const std::string& transfer_path) {
  try {  // refused (exit 1) when it does not fit the scene or exceeds this OpenGL's limits: name the file
    dispatch(
        scene.transfer, [&](const Transfer& t) { renderer.set_mesh(scene.mesh, t); },
        // per-cluster products each frame, N weights per vertex
        [&](const CompressedTransfer& c) { renderer.set_mesh(scene.mesh, c); },
        // the wavelet playback relights on the CPU and uploads colours
        [&](const WaveletTransfer& w) { renderer.set_mesh(scene.mesh, w.albedo, w.vertex_colors); },
        [&](const ZhTransfer& z) { renderer.set_mesh(scene.mesh, z); },  // the rest pose; set_pose moves it
        [&](const LightmapTransfer& l) { renderer.set_scene(*scene.world, l); },
        [&](const WaveletLightmap&) { PRT_CHECK(false && "refused by the kind table (Consumer::Render, View)"); },
        [&](const ProbeTransfer&) { PRT_CHECK(false && "refused by the kind table (Consumer::Render, View)"); });
  } catch (const NoGlContext&) {
    throw;
  } catch (const Error& e) {
    throw Error(transfer_path + ": " + e.what());
  }
}

void release_uploaded(Scene& s) {
  PRT_CHECK(s.kind() != TransferKind::Wavelet && !s.second);
  s.mesh.positions = {};
  s.mesh.normals = {};
  s.mesh.triangles = {};
  s.mesh.colors = {};
  s.transfer = Transfer{};
  s.world.reset();
}

void check_direct(const Transfer& t, const std::string& path, const std::string& option) {
  if (t.mode != TransferMode::Interreflected)
    throw Error(fmt::format("{}: {} needs an interreflected transfer (its direct part is the shadowed, 0-bounce "
                            "light); this one is {}, not interreflected",
                            path, option, transfer_mode_name(t.mode)));
}

Scene load_scene(const std::string& mesh, AnyTransfer loaded, const std::string& transfer, const std::string& env,
                 Consumer consumer, int max_bands, const char* command) {
  Scene s;
  s.transfer = std::move(loaded);
  require_support(s.kind(), consumer, transfer);
  // The kind says whether MESH is a mesh or a scene (a lightmap's, docs/LIGHTMAPS.md).
  if (is_lightmap(s.kind())) {
    const LightmapTransfer* lt = s.get<LightmapTransfer>();
    s.world = load_lightmap_scene(mesh, lt ? lt->layout : s.get<WaveletLightmap>()->layout);
    s.mesh = s.world->mesh;
  } else {
    s.mesh = load_mesh(mesh);
  }
  check_loaded(s, transfer, max_bands, command);
  s.env = load_envmap(env);
  require_finite(s.env);
  return s;
}

Scene load_scene(const std::string& mesh, const std::string& transfer, const std::string& env, Consumer consumer,
                 int max_bands, const char* command) {
  return load_scene(mesh, read_transfer_file(transfer), transfer, env, consumer, max_bands, command);
}

void rotate_lighting(std::vector<glm::dvec3>& light, int bands, const double euler[3]) {
  std::vector<glm::dvec3> r(light.size());
  sh::Rotation(bands, sh::rotation_from_euler(euler[0], euler[1], euler[2])).apply(light, r);
  light.swap(r);
}

namespace {

// Poses of the animation, evenly spaced over one loop, that the camera
// frames with the rest pose (animation_extent): 8 come within cos(pi/8) =
// 92% of a sinusoidal swing's reach wherever its extremes fall (the framing's
// 5% margin takes up much of the rest), for 8 skinnings on the CPU.
constexpr int kFramingPoses = 8;

// Whether the glTF 2.0 file `path` (.glb when `binary`) lists a skin: its
// JSON's "skins" is present and not an empty array. A file whose JSON cannot
// be read this way counts as having one, so that load_skin names its fault.
bool gltf_lists_skins(const std::string& path, bool binary) {
  std::ifstream f(path, std::ios::binary);
  std::string text;
  if (binary) {
    // GLB: the header (magic, version, length), then the first chunk, JSON:
    // its length, its type 'JSON', its text (little-endian words).
    unsigned char h[20];
    if (!f.read(reinterpret_cast<char*>(h), sizeof h)) return true;
    const auto word = [&](int o) {
      return std::uint32_t(h[o]) | std::uint32_t(h[o + 1]) << 8 | std::uint32_t(h[o + 2]) << 16 |
             std::uint32_t(h[o + 3]) << 24;
    };
    std::error_code ec;
    const std::uintmax_t size = std::filesystem::file_size(path, ec);
    if (ec || word(16) != 0x4E4F534Au || word(12) > size) return true;
    text.resize(word(12));
    if (!f.read(text.data(), std::streamsize(text.size()))) return true;
  } else {
    text.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return true;
  const auto skins = j.find("skins");
  return skins != j.end() && !(skins->is_array() && skins->empty());
}

}  // namespace

// MESH's skin when MESH is a glTF 2.0 file (.gltf, .glb) that lists one
// (load_skin, whose errors surface: a skin prt cannot pose is refused, not
// left still); nullopt for any other file, and a glTF without skins.
std::optional<Skin> load_mesh_skin(const std::string& path, const Mesh& mesh) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if ((ext != ".gltf" && ext != ".glb") || !gltf_lists_skins(path, ext == ".glb")) return std::nullopt;
  return load_skin(path, mesh);
}

// Seconds of one loop of `animation` (0 for a skin without animations: the
// rest pose). Throws prt::Error, naming the file, for an animation it lacks.
double animation_duration(const Skin& skin, int animation) {
  joint_matrices(skin, 0.0, animation);  // its refusal of an animation number
  return skin.animations.empty() ? 0.0 : skin.animations[std::size_t(animation)].duration;
}

// The points the camera frames: the rest positions, then those of
// kFramingPoses poses evenly spaced over the animation's loop.
std::vector<glm::vec3> animation_extent(const Mesh& rest, const Skin& skin, int animation) {
  std::vector<glm::vec3> out = rest.positions;
  const double duration = animation_duration(skin, animation);
  for (int k = 0; k < (duration > 0 ? kFramingPoses : 1); ++k) {
    const Mesh posed = skin_mesh(rest, skin, joint_matrices(skin, duration * k / kFramingPoses, animation));
    out.insert(out.end(), posed.positions.begin(), posed.positions.end());
  }
  return out;
}

// The refusals (prt::Error, exit 1, naming the file that does not fit): the
// given ones of `options` (--time, --animation) without a zonal-harmonic
// transfer or without a skin; --deform (`deform`) with a skin (one pose source).
void check_skin_options(const std::optional<Skin>& skin, bool zh, bool deform,
                        const std::vector<const CLI::Option*>& options, const std::string& mesh,
                        const std::string& transfer) {
  for (const CLI::Option* o : options) {
    if (o->count() == 0) continue;
    if (!zh)
      throw Error(transfer + ": " + o->get_name() +
                  " needs a transfer that can follow a skin's animation (prt precompute --basis zh; docs/LDPRT.md); "
                  "this one is baked for one pose");
    if (!skin)
      throw Error(mesh + ": " + o->get_name() +
                  ": the mesh has no skin to animate (a skinned glTF 2.0 file: JOINTS_0, WEIGHTS_0, joints and their "
                  "animations; prt/skin.h)");
  }
  if (skin && deform)
    throw Error(mesh + ": --deform: the mesh is skinned and its animation poses it; give one pose source (--deform "
                "bends or twists a mesh without a skin)");
}

}  // namespace prt::cli
