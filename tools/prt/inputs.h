// What relight, render and view all load: a mesh, its transfer (checked to
// belong to it) and an environment map (checked to be finite).
#pragma once

#include <prt/envmap.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/render.h>
#include <prt/scene.h>
#include <prt/transfer.h>
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
  Mesh mesh;
  TransferBasis basis = TransferBasis::SH;
  Transfer transfer;        // basis SH (compressed: the header fields only; its arrays are in compressed->transfer)
  std::optional<CompressedTransfer> compressed;  // a file from prt compress (when the command takes them)
  WaveletTransfer wavelet;  // basis Wavelet
  // Basis ZH (prt precompute --basis zh): the lobes, `transfer` then holds
  // their header fields (bands, channels, mode, albedo); `mesh` is the rest pose.
  std::optional<ZhTransfer> zh;
  // A lightmap (prt precompute SCENE --lightmap): the scene (its mesh is
  // also `mesh`) and the lightmap; `transfer` then holds its header fields.
  std::optional<prt::Scene> world;
  std::optional<LightmapTransfer> lightmap;
  EnvMap env;
};

// Uploads the scene's transfer to `renderer` (set_scene, or set_mesh of the
// compressed or plain transfer); an error names `transfer_path`.
void upload(Renderer& renderer, const Scene& scene, const std::string& transfer_path);

// Throws prt::Error naming the file at fault; max_bands > 0 also refuses an
// SH transfer with more bands, naming `command` in the message. Wavelet
// files are refused unless allow_wavelet, compressed ones unless
// allow_compressed, zonal-harmonic ones unless allow_zh.
Scene load_scene(const std::string& mesh, const std::string& transfer, const std::string& env, int max_bands = 0,
                 const char* command = "", bool allow_wavelet = false, bool allow_compressed = false,
                 bool allow_zh = false);

// Throws prt::Error naming `path` unless `t` keeps a direct part (an
// interreflected transfer): what `option` ("--direct", "--shading direct")
// shows.
void check_direct(const Transfer& t, const std::string& path, const std::string& option);

// Loads a transfer file into `scene` (the mesh must be loaded) and checks it
// against the mesh; the rules of load_scene.
void load_transfer(Scene& scene, const std::string& transfer, int max_bands, const char* command,
                   bool allow_wavelet, bool allow_compressed = false, bool allow_zh = false);

// After the renderer has uploaded an SH scene's mesh and transfer (it keeps
// its own copy: on the GPU, or with Mesa's llvmpipe in this process), frees
// the CPU's: the mesh's arrays, the transfer's arrays (its header fields
// stay) and the compressed transfer. What prt render holds while it draws.
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
