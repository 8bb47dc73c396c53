// prt/ply.h - writing a mesh with per-vertex float colours as PLY.
#pragma once

#include <prt/mesh.h>

#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace prt {

// Binary little-endian PLY: vertex x y z nx ny nz red green blue, faces as
// uchar-count/int-index lists. Written atomically (prt/io.h). Colours:
// PlyColors::Float, linear and unclamped (HDR radiance in the map's units),
// or PlyColors::Bytes, display values in [0, 1] (clamped) stored as uchar
// round(255 v), what mesh viewers show (prt relight --tonemap, --srgb).
// `colors` empty: no colour properties (a mesh alone, e.g. the refined mesh
// of prt precompute --subdivide). `comment`: the header's comment line.
enum class PlyColors { Float, Bytes };
void write_ply(const std::string& path, const Mesh& mesh, const std::vector<glm::vec3>& colors,
               PlyColors format = PlyColors::Float,
               const std::string& comment = "prt relight: linear radiance per vertex");

}  // namespace prt
