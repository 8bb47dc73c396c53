// prt/subsurface_scatter.h - the dipole's integral over a mesh's surface
// (docs/SUBSURFACE.md "The surface integral"): light transmitted into the
// surface at every vertex, leaving it at every vertex through the dipole
// profile R_d of prt/subsurface.h.
#pragma once

#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/subsurface.h>
#include <prt/transfer.h>

#include <cstdint>
#include <span>
#include <vector>

namespace prt {

// Each vertex's share of the surface: a third of the area of each triangle
// it is a corner of, in mesh units squared (degenerate triangles give none).
std::vector<double> vertex_areas(const Mesh& mesh);

struct SubsurfaceScatterOptions {
  double length_scale = 1.0;  // millimetres per mesh unit (D3DX's fLengthScale), > 0
  // Jensen & Buhler 2002's hierarchical evaluation: a cluster of sources is
  // taken whole, at its area-weighted centre, where its area over its
  // squared distance to the receiver is below this (a solid angle, in
  // steradians); 0 sums every pair (the brute-force reference, O(N^2)).
  double max_solid_angle = 0.05;
  int threads = 0;  // 0: every core
  // The receivers: empty, every vertex; else these vertices, the output's
  // rows in their order.
  std::vector<std::uint32_t> receivers;
};

// For every receiving vertex o, per channel c of the material and
// coefficient k < nc:
//   out[o][c][k] = (1 / pi) sum_i R_d,c(S |x_o - x_i|) S^2 A_i in[i][k],
// S the length scale, A_i vertex_areas' (so a row of transmitted irradiance
// in `in`, nc floats a vertex, becomes a row of exit radiance). Sums in
// double; rows of 3 x nc floats, [vertex][channel][k]. Throws prt::Error for
// a bad material, length scale or row count.
std::vector<float> subsurface_scatter(const Mesh& mesh, const SubsurfaceMaterial& material,
                                      std::span<const float> in, int nc, const SubsurfaceScatterOptions& options = {});

// A translucent mesh's transfer (docs/SUBSURFACE.md): the transmitted
// irradiance's (compute_transfer with transmission_eta the material's eta,
// shadowed; `options`' mode, albedo and vertex colours are not used: the
// material's reflectance is its profile), times pi, summed over the surface
// by subsurface_scatter into RGB rows, so that a row dotted with lighting L
// is the exit radiance L_o. Every vertex is stored; AO and bent normals are
// the transmitted irradiance's.
Transfer compute_subsurface_transfer(const Mesh& mesh, const TransferOptions& options,
                                     const SubsurfaceMaterial& material, const SubsurfaceScatterOptions& scatter = {});

}  // namespace prt
