#include "scene.h"

#include <prt/error.h>
#include <prt/transfer_io.h>

namespace prt::cli {

Scene load_scene(const std::string& mesh, const std::string& transfer, const std::string& env, int max_bands,
                 const char* command) {
  Scene s{load_mesh(mesh), read_transfer(transfer), {}};
  check_matches(s.transfer, s.mesh, transfer);
  if (max_bands > 0 && s.transfer.bands > max_bands)
    throw Error(transfer + ": " + std::to_string(s.transfer.bands) + " bands; prt " + command + " takes at most " +
                std::to_string(max_bands));
  s.env = load_envmap(env);
  require_finite(s.env);
  return s;
}

}  // namespace prt::cli
