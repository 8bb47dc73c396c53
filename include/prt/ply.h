// prt/ply.h - writing a mesh with per-vertex float colours as PLY.
#pragma once

#include <prt/mesh.h>

#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace prt {

// Binary little-endian PLY: vertex x y z nx ny nz red green blue (float,
// linear, unclamped: HDR radiance in the map's units), faces as
// uchar-count/int-index lists. Written atomically (prt/io.h).
void write_ply(const std::string& path, const Mesh& mesh, const std::vector<glm::vec3>& colors);

}  // namespace prt
