// prt/probe_object.h - an object lit by a probe volume, moving through the
// scene (prt render / prt view --probes FILE --object MESH, prt.render(probes=,
// object=); docs/PROBES.md "Rendering").
//
// Holds the volume and its relighter, places the object (a uniform scale, its
// bounding box centred at a point) and hands both to the renderer: each frame
// relights only the probes of the cells the object's bounding sphere reaches
// under the rotated map, and uploads them (Renderer::set_probe_lighting).
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/probes.h>
#include <prt/render.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace prt {

struct ProbeObjectPlacement {
  // The object's bounding-box diagonal in scene units; 0: twice the volume's
  // smallest probe spacing.
  double size = 0;
  // Fixed at this point; else a circle at a third of the volume's height, a
  // quarter of its narrower horizontal extent across, about its centre.
  std::optional<glm::dvec3> at;
};

class ProbeObject {
 public:
  // Takes the volume (3 bands: throws prt::Error otherwise, saying so) and
  // the object (its normals), and hands both to the renderer (its errors).
  // The caller has checked that the volume belongs to the scene drawn.
  // `name` is the object's, for describe().
  ProbeObject(ProbeTransfer volume, const Mesh& object, const EnvMap& env, Renderer& renderer,
              const ProbeObjectPlacement& place = {}, std::string name = "object");
  // Relights the probes for the environment rotation R (light from d
  // arrives from R d), uploads them, and places the object at `t` in
  // [0, 1) of its path (a full circle; a fixed object stays).
  void frame(Renderer& renderer, const glm::dmat3& R, double t);
  // Another map (prt view's N, P, a dropped file): the probes relit under it.
  void set_environment(const EnvMap& env);
  // "NAME: V vertices lit by P probes (NXxNYxNZ, MODE)"
  std::string describe() const;

 private:
  std::unique_ptr<const ProbeTransfer> t_;  // on the heap: the relighter refers to it, and a ProbeObject moves
  std::unique_ptr<ProbeRelighter> relighter_;
  std::vector<glm::vec3> lit_;
  glm::dvec3 centre_{0.0}, object_centre_{0.0};
  double radius_ = 0, scale_ = 1, object_diagonal_ = 0;
  bool fixed_ = false;
  std::size_t vertices_ = 0;
  std::string name_;
};

}  // namespace prt
