// prt render / prt view --probes FILE --object MESH: an object lit by a
// probe volume moving through the scene (docs/PROBES.md "Rendering").
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/probes.h>
#include <prt/render.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <memory>
#include <string>

namespace prt::cli {

struct ProbeObjectArgs {
  std::string probes, object;  // --probes FILE (prt precompute --probes), --object MESH
  double size = 0;             // --object-size: its bounding box's diagonal; 0: twice the smallest spacing
  std::string at;              // --object-at x,y,z: fixed; else a circle through the volume
};

class ProbeObject {
 public:
  // Loads the probe volume (checked against SCENE, the mesh or scene file
  // given to the command), the object (its normals), and hands both to the
  // renderer. Throws prt::Error naming the file at fault.
  ProbeObject(const ProbeObjectArgs& args, const std::string& scene, const EnvMap& env, Renderer& renderer);
  // Relights the probes for the environment rotation R (light from d
  // arrives from R d), uploads them, and places the object at `t` in
  // [0, 1) of its path (a full circle).
  void frame(Renderer& renderer, const glm::dmat3& R, double t);
  // Another map (prt view's N, P, a dropped file): the probes relit under it.
  void set_environment(const EnvMap& env) { relighter_ = std::make_unique<ProbeRelighter>(t_, env); }
  std::string describe() const;

 private:
  ProbeTransfer t_;
  std::unique_ptr<ProbeRelighter> relighter_;
  std::vector<glm::vec3> lit_;
  glm::dvec3 centre_{0.0}, object_centre_{0.0};
  double radius_ = 0, scale_ = 1, object_diagonal_ = 0;
  bool fixed_ = false;
  std::size_t vertices_ = 0;
  std::string name_;
};

}  // namespace prt::cli
