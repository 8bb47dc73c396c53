// The options that light a scene with lights inside it (docs/LIGHTS.md),
// defined once for every command that takes them: --lights FILE.json|none
// and --sun auto|none.
#pragma once

#include "inputs.h"

#include <prt/direct_light.h>
#include <prt/envmap.h>
#include <prt/filter.h>
#include <prt/lightmap.h>
#include <prt/projection.h>
#include <prt/lights.h>

#include <CLI/CLI.hpp>

#include <glm/mat3x3.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace prt::cli {

struct LightArgs {
  std::vector<std::string> files;  // --lights, repeatable: FILE.json adds its lights, `none` drops the scene's own
  std::string sun = "none";        // --sun auto|none
  const CLI::Option *lights_opt = nullptr, *sun_opt = nullptr;
  bool sun_auto() const { return sun == "auto"; }
  bool given() const;  // --lights or --sun on the command line
};

// Adds --lights and --sun to `command`; `rotates` says whether the command's
// --rotate turns the sun (help text).
void add_light_options(CLI::App* command, LightArgs& args);

// The lights SCENE is lit with: the scene file's own (a glTF's
// KHR_lights_punctual, read by prt::load_scene; `scene_lights` when the
// caller has loaded it, else read here from `scene_path`), unless --lights
// none, then each --lights file's. Throws prt::Error naming the file.
std::vector<Light> command_lights(const LightArgs& args, const std::string& scene_path,
                                  const std::vector<Light>* scene_lights = nullptr);

// --sun auto: takes the map's sun out of `env` (in place: the rest stays)
// and returns it as a directional light of the same irradiance, turned by
// `rotation` (the lighting's: --rotate turns the sky and its sun alike).
// nullopt with --sun none, or when the map has no compact bright source (then
// a note on stderr unless quiet). Prints what it found unless quiet.
std::optional<Light> take_sun(const LightArgs& args, EnvMap& env, const glm::dmat3& rotation, bool quiet);

// --sun auto in prt relight and prt export --bake: take_sun's light appended
// to `lights`; `sun_map` (when given and a sun is found): the sun's pixels
// alone, ENV less the sky left in `env`, whose bounce an interreflected
// transfer carries (add_sun_bounce).
void add_map_sun(const LightArgs& args, std::vector<Light>& lights, EnvMap& env, const glm::dmat3& rotation,
                 bool quiet, std::optional<EnvMap>* sun_map);

// Adds the lights' direct light (prt/direct_light.h: albedo/pi x irradiance,
// each light's shadow ray traced against `occluders`) at the points to `rgb`,
// and with a transfer's light-bounce operator (prt/light_bounce.h; the points
// its rows: the transfer's vertices or texels) their bounce. Returns the
// milliseconds it took (0 without lights).
double add_direct_light(std::vector<glm::vec3>& rgb, const std::vector<Light>& lights, const Mesh& occluders,
                        std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                        std::span<const glm::vec3> albedo, const std::optional<GlossyLobe>& lobe = std::nullopt,
                        const LightBounce* bounce = nullptr);
// The same at a lightmap's texels, at the sample points prt precompute traced
// from (moved out of geometry as it moves them: prt/precompute.h).
double add_texel_lights(std::vector<glm::vec3>& rgb, const std::vector<Light>& lights, const Mesh& occluders,
                        LightmapTexels texels, const LightBounce* bounce = nullptr);
// The operator a transfer's lights bounce through in prt relight and prt
// export --bake: null without one, or for --direct (the direct part alone).
inline const LightBounce* bounce_of(const Transfer& t, bool direct_only) {
  return t.light_bounce.empty() || direct_only ? nullptr : &t.light_bounce;
}

// The sun's bounce when --sun auto took it out of the map: an interreflected
// transfer T keeps its direct part T_d, so the sun's light projected alone
// (L_sun, windowed and turned as the sky: `euler` null when not turned) goes
// through T - T_d while its direct light is traced (add_direct_light). A
// shadowed transfer has no bounce to carry.
template <typename T, typename Points>
void add_sun_bounce(std::vector<glm::vec3>& rgb, const std::optional<EnvMap>& sun_map, const T& t,
                    const Points& points, sh::Window window, double window_width, const double* euler) {
  if (!sun_map || t.mode != TransferMode::Interreflected) return;
  std::vector<glm::dvec3> sun = project(*sun_map, t.bands);
  sh::apply_window(std::span<glm::dvec3>(sun), window, window_width > 0 ? window_width : t.bands);
  if (euler) rotate_lighting(sun, t.bands, euler);
  const std::vector<glm::vec3> all = relight(t, points, sun), direct = relight_direct(t, points, sun);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] += all[i] - direct[i];
}

// Lights on a translucent transfer (TransferHeader::subsurface, prt
// precompute --material subsurface): refused with prt::kTranslucentLightsWhy
// when `lit` (the command found lights: the scene's own, --lights files',
// --sun auto's), naming the file. Nothing for other transfers.
void check_translucent_lights(const TransferHeader& t, bool lit, const std::string& transfer_path);

// "2 lights (1 point, 1 spot)" for a command's summary, "" without lights.
std::string describe_lights(const std::vector<Light>& lights);

// ---- lights drawn by a renderer (prt render, prt view) ----

// --light-path INDEX:x,y,z;x,y,z;...: light INDEX (in the order the command
// lists them) goes round the closed polyline through the points once over
// the frames, at constant speed.
struct LightPath {
  std::size_t light = 0;
  std::vector<glm::dvec3> points;
  glm::dvec3 at(double t) const;  // t in [0, 1): the position a fraction t of the way round
};
LightPath parse_light_path(const std::string& text);

// The lights of a rendered scene: the scene's and --lights files', and the
// sun (last), whose direction turns with the sky each frame; paths move
// lights over the frames.
struct RenderLights {
  std::vector<Light> lights;
  std::optional<glm::dvec3> sun_direction;  // the sun's travel direction in the map's frame
  std::vector<LightPath> paths;
  bool empty() const { return lights.empty(); }
  // The lights at fraction t of the frames with the sky turned by R.
  std::vector<Light> at(double t, const glm::dmat3& rotation) const;
};
// What a renderer needs beside the lights for `scene`: for a lightmap, its texels' sample points
// moved out of geometry as prt precompute moved them (the points prt
// relight lights; Renderer::set_light_points), nullopt otherwise.
std::optional<LightmapTexels> renderer_light_points(const Scene& scene);

// Reads the lights (command_lights, take_sun on `env` in place) and checks
// the paths against them; `scene_lights` as command_lights.
RenderLights render_lights(const LightArgs& args, const std::vector<std::string>& paths, EnvMap& env,
                           const std::string& scene_path, const std::vector<Light>* scene_lights, bool quiet);

}  // namespace prt::cli
