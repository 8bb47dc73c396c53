// What relight, render and view all load: a mesh, its transfer (checked to
// belong to it) and an environment map (checked to be finite).
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include <string>

namespace prt::cli {

struct Scene {
  Mesh mesh;
  Transfer transfer;
  EnvMap env;
};

// Throws prt::Error naming the file at fault; max_bands > 0 also refuses a
// transfer with more bands, naming `command` in the message.
Scene load_scene(const std::string& mesh, const std::string& transfer, const std::string& env, int max_bands = 0,
                 const char* command = "");

}  // namespace prt::cli
