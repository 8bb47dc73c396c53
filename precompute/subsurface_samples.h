// precompute/subsurface_samples.h - irradiance samples apart from the
// vertices (docs/SUBSURFACE.md "Irradiance samples"): where the light
// transmitted into a translucent mesh varies across a triangle more than a
// linear interpolation of its corners follows, the triangle is split at its
// edges' midpoints and the new points traced, so that the surface integral
// sums the light entering between the vertices.
#pragma once

#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/progress.h>

#include <cstddef>
#include <vector>

namespace prt::detail {

struct IrradianceSamples {
  // The mesh's vertices first (the same indices), then the added points;
  // the triangles, split where they were (positions and triangles only:
  // the surface integral's sources, not a mesh to trace).
  Mesh sources;
  std::vector<float> rows;  // a row per point, the given rows' stride
  std::size_t added = 0;
};

// `rows`: the transmitted irradiance's rows at every vertex (as
// compute_transfer gives them with transmission_eta: one or three equal
// channels). A triangle is split into four where the rows' DC terms (the
// irradiance under uniform light) at the ends of one of its edges differ by
// more than `max_difference` of the larger, or their normals by more than
// 30 degrees, up to `levels` times; the new points lie on the flat
// triangle with the corners' normals interpolated, and are traced by
// compute_point_transfer with `trace` (shadowed, in this process alone).
IrradianceSamples irradiance_samples(const Mesh& mesh, std::vector<float> rows, const TransferOptions& trace,
                                     double max_difference, int levels, const Progress& progress = {});

}  // namespace prt::detail
