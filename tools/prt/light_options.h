// The options that light a scene with lights inside it (docs/LIGHTS.md),
// defined once for every command that takes them: --lights FILE.json|none
// and --sun auto|none.
#pragma once

#include <prt/envmap.h>
#include <prt/lights.h>

#include <CLI/CLI.hpp>

#include <glm/mat3x3.hpp>

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

// "; 2 lights (1 point, 1 spot)" for a command's summary, "" without lights.
std::string describe_lights(const std::vector<Light>& lights);

}  // namespace prt::cli
