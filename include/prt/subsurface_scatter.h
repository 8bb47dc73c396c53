// prt/subsurface_scatter.h - the dipole's integral over a mesh's surface
// (docs/SUBSURFACE.md "The surface integral"): light transmitted into the
// surface at every vertex, leaving it at every vertex through the dipole
// profile R_d of prt/subsurface.h.
#pragma once

#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/scene.h>
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
  // taken whole, at its area-weighted centre with its spread's
  // second-order term, where its area over its squared distance to the
  // receiver is below this (a solid angle, in steradians; docs/SUBSURFACE.md
  // tables the error: 0.1-0.5% relative RMS at 0.1 against every pair);
  // 0 sums every pair (the brute-force reference, O(N^2)).
  double max_solid_angle = 0.1;
  int threads = 0;  // 0: every core
  // The receivers: empty, every vertex; else these vertices, the output's
  // rows in their order.
  std::vector<std::uint32_t> receivers;
  // compute_subsurface_transfer's irradiance samples apart from the vertices
  // (docs/SUBSURFACE.md "Irradiance samples"): a triangle is split into four
  // at its edges' midpoints, up to split_levels times, where the
  // transmitted irradiance under uniform light (the rows' DC terms) at the
  // ends of one of its edges differs by more than split_difference of the
  // larger (a shadow's edge, a groove), or their normals by more than 30
  // degrees (a bend); the new points are traced and summed as sources, the
  // vertices alone receive. split_levels 0: the vertices alone, as
  // subsurface_scatter.
  double split_difference = 0.15;
  int split_levels = 2;
  // When set, compute_subsurface_transfer stores how many points it added.
  std::size_t* added_samples = nullptr;
};

// For every receiving point o, per channel c of the material and
// coefficient k < nc:
//   out[o][c][k] = (1 / pi) sum_i S^2 A_i Rbar_c(o, i) in[i][c][k],
// S the length scale, A_i the point's area (mesh units squared) and Rbar the
// mean of the profile R_d over a disc of that area about point i
// (docs/SUBSURFACE.md "Near sources": its closed form on the point itself,
// a product rule within three radii, R_d + rho^2 / 8 Laplacian farther), so
// that a row of transmitted irradiance becomes a row of exit radiance. `in`
// holds nc floats a point (one row for the three channels) or 3 nc
// ([point][channel][k], each channel its own). Sums in double; rows of
// 3 x nc floats, [point][channel][k]. Throws prt::Error for a bad material,
// length scale, area or row count.
std::vector<float> subsurface_scatter(std::span<const glm::vec3> positions, std::span<const double> areas,
                                      const SubsurfaceMaterial& material, std::span<const float> in, int nc,
                                      const SubsurfaceScatterOptions& options = {});
// The mesh's vertices, with vertex_areas.
std::vector<float> subsurface_scatter(const Mesh& mesh, const SubsurfaceMaterial& material,
                                      std::span<const float> in, int nc, const SubsurfaceScatterOptions& options = {});

// A translucent mesh's transfer (docs/SUBSURFACE.md): the transmitted
// irradiance's transfer (compute_transfer with transmission_eta the
// material's eta: each ray weighed by T(eta, cos) cos), its rows times pi
// summed over the surface by subsurface_scatter, so that a row dotted with
// lighting L is the exit radiance L_o. `options`' mode is shadowed or
// interreflected: then the exit radiance of the mesh's other surfaces lights
// each vertex too, bounce by bounce (each bounce's gathered irradiance
// summed over the surface again; `options.bounces`, bounce_tolerance).
// Its albedo and vertex colours are not used (the material's reflectance
// is its profile); neither glossy nor light_bounce. The result: RGB rows,
// every vertex stored, `subsurface` recording the material and length
// scale; AO and bent normals are the transmitted irradiance's. Under
// mpirun, rank 0's result (others return an empty transfer). Throws
// prt::Error for a bad material, length scale or option; Error("cancelled")
// when `progress` says stop.
Transfer compute_subsurface_transfer(const Mesh& mesh, const TransferOptions& options,
                                     const SubsurfaceMaterial& material, const SubsurfaceScatterOptions& scatter = {},
                                     const Progress& progress = {});

// The same exit radiance at a lightmap's covered texels (prt precompute
// --lightmap WxH --material subsurface): each texel traced as
// compute_lightmap_transfer traces it (transmission_eta the material's) and
// summed over the texels as sources (a disc of the area it covers,
// texels.area, at its point on its triangle) and receivers, as
// subsurface_scatter sums points without triangles; interreflected, bounce
// by bounce, the texels gathering from each other. RGB rows, one per
// texel, none analytic; AO and bent normals the transmitted irradiance's.
// Under mpirun, rank 0's result (others: empty). Throws as
// compute_subsurface_transfer, and for texels without their triangles or
// areas.
LightmapTransfer compute_subsurface_lightmap(const Scene& scene, const LightmapTexels& texels,
                                             const TransferOptions& options, const SubsurfaceMaterial& material,
                                             const SubsurfaceScatterOptions& scatter = {},
                                             const Progress& progress = {});

}  // namespace prt
