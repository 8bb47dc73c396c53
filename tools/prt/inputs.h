// What relight, render and view all load: a mesh, its transfer (checked to
// belong to it) and an environment map (checked to be finite).
#pragma once

#include <prt/envmap.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/render.h>
#include <prt/scene.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>
#include <prt/skin.h>

#include <CLI/CLI.hpp>

#include <glm/vec3.hpp>

#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace prt::cli {

struct Scene {
  Mesh mesh;  // the mesh; for a lightmap, its scene's (`world`) mesh
  // What TRANSFER holds (prt/transfer_file.h), checked to belong to `mesh`.
  AnyTransfer transfer;
  // The SH header fields (bands, channels, mode, glossy, albedo, ...) of the
  // kinds with SH rows: an SH, compressed or lightmap transfer's, a
  // zonal-harmonic one's (its lobes' bands); bands 0 for the others.
  Transfer header;
  std::optional<prt::Scene> world;        // a lightmap's scene (glTF or OBJ with its materials)
  std::optional<WaveletTransfer> second;  // prt view --second: a wavelet transfer beside an SH one
  EnvMap env;

  TransferKind kind() const { return kind_of(transfer); }
  template <typename T>
  const T* get() const {
    return std::get_if<T>(&transfer);
  }
  // The wavelet transfer shown: TRANSFER's, or --second's.
  const WaveletTransfer* wavelet() const {
    const WaveletTransfer* w = get<WaveletTransfer>();
    return w ? w : second ? &*second : nullptr;
  }
};

// Uploads the scene's transfer to `renderer` (the kind's pass: set_scene of
// a lightmap, set_mesh of a zonal-harmonic, compressed or SH transfer); an
// error names `transfer_path`. Refuses (PRT_CHECK) the kinds the renderer
// does not draw: callers refuse them first (Consumer::Render, View).
void upload(Renderer& renderer, const Scene& scene, const std::string& transfer_path);

// Reads TRANSFER, refuses it unless `consumer` takes its kind (the sentence
// of prt/transfer_file.h's table), loads MESH (a scene for the lightmap
// kinds) and checks that the transfer belongs to it, and loads ENV (checked
// to be finite). Throws prt::Error naming the file at fault; max_bands > 0
// also refuses a transfer with more SH bands, naming `command`.
Scene load_scene(const std::string& mesh, const std::string& transfer, const std::string& env, Consumer consumer,
                 int max_bands = 0, const char* command = "");
// The same with the transfer already read (`transfer` names its file).
Scene load_scene(const std::string& mesh, AnyTransfer loaded, const std::string& transfer, const std::string& env,
                 Consumer consumer, int max_bands = 0, const char* command = "");

// Throws prt::Error naming `path` unless `t` keeps a direct part (an
// interreflected transfer): what `option` ("--direct", "--shading direct")
// shows.
void check_direct(const Transfer& t, const std::string& path, const std::string& option);

// Reads a transfer file into `scene` (the mesh must be loaded) and checks it
// against the mesh; the rules of load_scene.
void load_transfer(Scene& scene, const std::string& transfer, Consumer consumer, int max_bands = 0,
                   const char* command = "");

// After the renderer has uploaded an SH-row scene's mesh and transfer (it keeps
// its own copy: on the GPU, or with Mesa's llvmpipe in this process), frees
// the CPU's: the mesh's arrays and the transfer (its header fields stay in
// Scene::header). What prt render holds while it draws.
void release_uploaded(Scene& scene);

// Rotates SH lighting (bands^2 RGB coefficients or more) by --rotate's
// yaw, pitch, roll degrees, in place: what prt relight and prt export --bake
// light a transfer with (sh::rotation_from_euler, sh::Rotation).
void rotate_lighting(std::vector<glm::dvec3>& light, int bands, const double euler[3]);

// ---- a skinned glTF MESH whose zonal-harmonic transfer follows its animation
// (prt render and prt view skin it on the GPU; docs/LDPRT.md) ----

// MESH's skin when MESH is a glTF 2.0 file (.gltf, .glb) that lists one
// (load_skin, whose errors surface: a skin prt cannot pose is refused, not
// left still); nullopt for any other file, and a glTF without skins.
std::optional<Skin> load_mesh_skin(const std::string& path, const Mesh& mesh);
// Seconds of one loop of `animation` (0 for a skin without animations: the
// rest pose). Throws prt::Error, naming the file, for an animation it lacks.
double animation_duration(const Skin& skin, int animation);
// The points the camera frames: the rest positions, then those of a few
// poses evenly spaced over the animation's loop.
std::vector<glm::vec3> animation_extent(const Mesh& rest, const Skin& skin, int animation);
// The refusals (prt::Error, exit 1, naming the file that does not fit): the
// given ones of `options` (--time, --animation) without a zonal-harmonic
// transfer or without a skin; --deform (`deform`) with a skin (one pose source).
void check_skin_options(const std::optional<Skin>& skin, bool zh, bool deform,
                        const std::vector<const CLI::Option*>& options, const std::string& mesh,
                        const std::string& transfer);

}  // namespace prt::cli
