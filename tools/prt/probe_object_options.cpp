#include "probe_object_options.h"

#include "options.h"

#include <prt/error.h>
#include <prt/scene.h>
#include <prt/transfer_file.h>

#include <filesystem>

namespace prt::cli {

ProbeObject load_probe_object(const ProbeObjectArgs& a, const std::string& scene, const EnvMap& env,
                              Renderer& renderer) {
  ProbeTransfer t = read_transfer_as<ProbeTransfer>(a.probes);  // another kind: refused, naming both
  if (load_scene_or_mesh(scene).hash() != t.scene_hash)
    throw Error(a.probes + ": computed for another scene than " + scene + ": rerun prt precompute " + scene + " --probes ...");
  ProbeObjectPlacement place;
  place.size = a.size;
  if (!a.at.empty()) {
    double xyz[3];
    parse_triple(a.at, "--object-at", xyz);
    place.at = glm::dvec3(xyz[0], xyz[1], xyz[2]);
  }
  const Mesh object = load_mesh(a.object);
  try {  // the volume's refusals (its band count, buffers past this OpenGL's limits), naming the file
    return ProbeObject(std::move(t), object, env, renderer, place, std::filesystem::path(a.object).filename().string());
  } catch (const NoGlContext&) {
    throw;
  } catch (const Error& e) {
    throw Error(a.probes + ": " + e.what());
  }
}

}  // namespace prt::cli
