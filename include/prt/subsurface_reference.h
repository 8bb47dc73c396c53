// prt/subsurface_reference.h - ground truth for a translucent mesh's exit
// radiance (docs/SUBSURFACE.md, "The reference"): Monte Carlo against the
// environment map itself, no spherical harmonics, the dipole summed over
// surface samples without approximation. `prt reference --material
// subsurface` writes it; the precomputed translucent transfer is measured
// against it.
//
// Quantity: at a vertex x_o, per RGB channel c (each its own Dipole),
//   L_o(x_o) = (1/pi) int_surface R_d,c(S |x_o - x_i|) E_t(x_i) S^2 dA(x_i)
//   E_t(x_i) = int L_i(w) T(eta, cos th) V(x_i, w) cos th dw
// S the length scale (mm per mesh unit), th against the interpolated vertex
// normal at x_i, T = fresnel_transmittance, V the shadow rays' visibility
// (rays leave x_i + offset n with tnear = offset, as prt/reference.h's).
// L_i is the map's radiance (rotated by ReferenceOptions::rotation); with
// TransferMode::Interreflected every surface of the mesh is the same
// translucent material, and a ray from x_i that hits a front face at y
// brings L_o(y) there instead (estimated the same way with one hop fewer,
// `bounces` extra hops in all; back faces are black). Shadowed: hits
// block. Unshadowed is refused (no translucent transfer is unshadowed).
//
// Estimator (the importance sampling of the profile by probe rays that
// renderers use for BSSRDFs), per probe:
//   * an axis a: the vertex normal n (probability 1/2) or one of its tangents
//     t, b (1/4 each); a channel c uniformly among those whose R_d is not 0;
//   * a radius r (mm) from p_c(r) = R_d,c(r) 2 pi r / disc_c(r_max) on
//     [0, r_max], r_max = 1.001 x the bounding-box diagonal x S (so every
//     surface point can be reached: nothing is truncated), by inverting
//     Dipole::disc (a table of quantiles refined by safeguarded Newton), and
//     phi uniform: a point on the disc about x_o perpendicular to a;
//   * the segment through it along a, within the ball of radius r_max / S
//     about x_o, and every intersection x_i of it with the mesh (one
//     traversal that collects them all, each triangle once: two triangles
//     at the same place, as a box standing on a floor, both count;
//     watertight tracing);
//   * each x_i is a sample of the area measure (mm^2) of density
//       q(x_i) = sum_a' P(a') |n_g . a'| (1/C) sum_c' R_d,c'(r_a') / disc_c'(r_max)
//     (the mixture over axes and channels: one-sample MIS, balance
//     heuristic), r_a' = S x the distance of x_i from the line through x_o
//     along a', n_g the hit triangle's geometric normal; it adds
//       R_d,c(S |x_o - x_i|) E_t(x_i) / (pi q(x_i))
//     to channel c (1/mm^2 over 1/mm^2: the units of E_t), with E_t from
//     one iteration of prt/reference.h's estimator (a map sample and a cosine
//     sample, power-heuristic MIS) with the kernel T cos. Hits whose weight
//     is under 2% of the channel's R_d,total / pi survive by Russian roulette
//     (unbiased; most far layers of the segment cost no E_t).
//   An iteration at a receiver (`samples` iterations per vertex; the standard
//   error is theirs) is 4 C probes, their mean: for each channel c, the
//   axis' uniform variable stratified in 4 (2 probes along n, one along t,
//   one along b). In interreflected mode a surface hit by the cosine ray is
//   estimated by one probe from it (axis and channel at random, one of its
//   hits picked uniformly, weighted by the count), recursively.
//
// Unbiased up to float ray tracing. Deterministic: each vertex
// draws from its own generator seeded by (seed, vertex index), so results
// are bit-identical for any thread count.
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/progress.h>
#include <prt/reference.h>
#include <prt/subsurface.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace prt {

// The iterations per vertex (each 4 probes a channel) `prt reference
// --material subsurface` takes by default: docs/SUBSURFACE.md "The
// reference" has the noise it leaves.
inline constexpr int kSubsurfaceReferenceSamples = 4096;

// Renders the reference at every vertex. Uses `options`' samples (iterations
// per vertex), seed, offset, rotation, mode and bounces; throws prt::Error for
// unshadowed mode, glossy, lights, vertex colours, a bad material or length
// scale, a cube map, and what render_reference refuses; prt::Error
// ("cancelled") if `progress` returns false. radiance is L_o per vertex
// (0 at a vertex without a normal), std_error its standard error.
ReferenceResult render_subsurface_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                            const SubsurfaceRecord& record, const Progress& progress = {});

// The same at the listed vertices only (entry i: vertex vertices[i],
// bit-identical to its entry in the full reference).
ReferenceResult render_subsurface_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                            const SubsurfaceRecord& record,
                                            const std::vector<std::uint32_t>& vertices, const Progress& progress = {});

// The same at points on the mesh's surface (a lightmap's texels: prt
// reference --lightmap WxH --material subsurface), each with its shading
// normal (zero: 0 there); entry i draws from the generator seeded by
// (seed, i).
ReferenceResult render_subsurface_reference_at_points(const Mesh& mesh, const EnvMap& map,
                                                      const ReferenceOptions& options, const SubsurfaceRecord& record,
                                                      const std::vector<glm::vec3>& positions,
                                                      const std::vector<glm::vec3>& normals,
                                                      const Progress& progress = {});

}  // namespace prt
