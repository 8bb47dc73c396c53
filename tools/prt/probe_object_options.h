// prt render / prt view --probes FILE --object MESH: an object lit by a
// probe volume moving through the scene (docs/PROBES.md "Rendering").
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/probe_object.h>
#include <prt/probes.h>
#include <prt/render.h>

#include <string>

namespace prt::cli {

struct ProbeObjectArgs {
  std::string probes, object;  // --probes FILE (prt precompute --probes), --object MESH
  double size = 0;             // --object-size: its bounding box's diagonal; 0: twice the smallest spacing
  std::string at;              // --object-at x,y,z: fixed; else a circle through the volume
};

// Reads the probe volume (checked against SCENE, the mesh or scene file
// given to the command) and the object, and hands both to the renderer
// (prt::ProbeObject). Throws prt::Error naming the file at fault.
ProbeObject load_probe_object(const ProbeObjectArgs& args, const std::string& scene, const EnvMap& env,
                              Renderer& renderer);

}  // namespace prt::cli
