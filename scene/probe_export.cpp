// The engines' JSON of a probe volume (prt export --probes; docs/PROBES.md "Export").
#include <prt/error.h>
#include <prt/probes.h>
#include <prt/rotation.h>
#include <prt/sh_convention.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace prt {

std::string probe_engine_json(const ProbeTransfer& t, const EnvMap& map, const std::array<double, 3>& rotate,
                              const ProbeExportNames& names) {
  if (t.bands != 3) throw Error(fmt::format("{} bands; engines' probes hold 3 (L2): precompute with --bands 3", t.bands));
  ProbeRelighter relighter(t, map);
  relighter.set_rotation(sh::rotation_from_euler(rotate[0], rotate[1], rotate[2]));
  std::vector<glm::vec3> lit;
  relighter.relight(lit);
  nlohmann::ordered_json probes = nlohmann::ordered_json::array();
  const char* states[] = {"sky", "stored", "invalid"};
  for (std::size_t p = 0; p < t.probes(); ++p) {
    std::vector<glm::dvec3> rad(9);
    for (int k = 0; k < 9; ++k) rad[std::size_t(k)] = glm::dvec3(lit[p * 9 + std::size_t(k)]);
    const sh::Sh9 three = sh::to_three(rad), unity = sh::to_unity(rad);
    nlohmann::ordered_json th = nlohmann::ordered_json::array(), un = nlohmann::ordered_json::array();
    for (int k = 0; k < 9; ++k) {
      th.push_back({three[std::size_t(k)].x, three[std::size_t(k)].y, three[std::size_t(k)].z});
      un.push_back({unity[std::size_t(k)].x, unity[std::size_t(k)].y, unity[std::size_t(k)].z});
    }
    const glm::vec3 x = t.positions[p];
    const glm::dvec3 xu = sh::to_engine_axes(sh::Convention::Unity, glm::dvec3(x));
    probes.push_back({{"position", {x.x, x.y, x.z}}, {"state", states[int(t.state[p])]}, {"three", th},
                      {"unity_position", {xu.x, xu.y, xu.z}}, {"unity", un}});
  }
  const glm::dvec3 sp = t.grid.spacing();
  nlohmann::ordered_json doc = {
      {"format", "prt probe volume SH"},
      {"generator", names.generator},
      {"scene", names.scene},
      {"probes_file", names.probes_file},
      {"map", names.map},
      {"rotate", {rotate[0], rotate[1], rotate[2]}},
      {"grid", {{"dims", t.grid.dims}, {"min", {t.grid.min.x, t.grid.min.y, t.grid.min.z}},
                {"max", {t.grid.max.x, t.grid.max.y, t.grid.max.z}}, {"spacing", {sp.x, sp.y, sp.z}},
                {"order", "probe i + NX (j + NY k) at min + (max - min) (i, j, k) / (dims - 1); position: moved off "
                          "surfaces (docs/PROBES.md)"}}},
      {"three", "THREE.LightProbe(new THREE.SphericalHarmonics3().fromArray(three.flat())): the probe's incident "
                "radiance, three.js's SphericalHarmonics3 convention, three's axes (= prt's)"},
      {"unity", "UnityEngine.Rendering.SphericalHarmonicsL2: sh[channel, k] = unity[k][channel] (E/pi with Unity's "
                "constants folded in, as LightProbes hold it), at unity_position (Unity's left-handed axes: z negated)"},
      {"states", "sky: sees only the map (nothing stored); stored; invalid: inside geometry (zero, give it no weight)"},
      {"probes", probes}};
  return doc.dump(1) + "\n";
}

}  // namespace prt
