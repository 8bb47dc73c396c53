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
    const sh::Sh9 three = sh::to_three(rad), unity = sh::to_unity(rad), godot = sh::to_godot(rad);
    nlohmann::ordered_json th = nlohmann::ordered_json::array(), un = nlohmann::ordered_json::array(),
                           go = nlohmann::ordered_json::array();
    for (std::size_t k = 0; k < 9; ++k) {
      th.push_back({three[k].x, three[k].y, three[k].z});
      un.push_back({unity[k].x, unity[k].y, unity[k].z});
      go.push_back({godot[k].x, godot[k].y, godot[k].z});
    }
    const glm::vec3 x = t.positions[p];
    const glm::dvec3 xu = sh::to_engine_axes(sh::Convention::Unity, glm::dvec3(x));
    probes.push_back({{"position", {x.x, x.y, x.z}}, {"state", states[int(t.state[p])]}, {"three", th},
                      {"unity_position", {xu.x, xu.y, xu.z}}, {"unity", un}, {"godot", go}});
  }
  const glm::dvec3 sp = t.grid.spacing();
  // three.js's LightProbeGridWebGL puts probe i of N at the centre of cell i
  // of a box of `size` centred at `position`: size (max - min) N / (N - 1)
  // (N >= 2) puts them where prt's grid has them.
  const glm::dvec3 centre = 0.5 * (glm::dvec3(t.grid.min) + glm::dvec3(t.grid.max));
  const glm::dvec3 size = sp * glm::dvec3(t.grid.dims[0], t.grid.dims[1], t.grid.dims[2]);
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
      {"three_grid", {{"position", {centre.x, centre.y, centre.z}},
                      {"size", {size.x, size.y, size.z}},
                      {"resolution", t.grid.dims},
                      {"loader", "web/prt-three.js probeGridFromPrt: new LightProbeGridWebGL(...size, ...resolution) at "
                                 "position, its texture made from the probes' three arrays (docs/WEB.md)"}}},
      {"unity", "UnityEngine.Rendering.SphericalHarmonicsL2: sh[channel, k] = unity[k][channel] (E/pi with Unity's "
                "constants folded in, as LightProbes hold it), at unity_position (Unity's left-handed axes: z negated)"},
      {"godot", "Godot 4 LightmapGIData probe_data: sh[probe * 9 + k] = Color(godot[k]) (radiance / pi without the "
                "Condon-Shortley phase, as Godot's lightmapper bakes it; its shader shows E/pi x albedo) at points = "
                "position (the LightmapGI node's space; Godot's axes are prt's); tetrahedra and bsp are Godot's to "
                "build (docs/PROBES.md)"},
      {"states", "sky: sees only the map (nothing stored); stored; invalid: inside geometry (zero, give it no weight)"},
      {"probes", probes}};
  return doc.dump(1) + "\n";
}

}  // namespace prt
