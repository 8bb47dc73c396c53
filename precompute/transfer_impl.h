// Private to prt::precompute: the transfer pass at any set of points
// (precompute/transfer.cpp), for the units that compute transfer at points of
// their own choosing (lightmap texels: precompute/lightmap.cpp).
#pragma once

#include <prt/precompute.h>

#include <glm/common.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

namespace prt::detail {

// Interreflection at points that are themselves the emitters (texels): which
// point a front hit (triangle, barycentrics u, v of corners 1 and 2) lands on.
// For a lightmap, the covered texel under the hit's lightmap UV (the texel
// that holds the hit point's transfer), or a covered neighbour where rounding
// puts the UV on an uncovered one.
struct HitToPoint {
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  const glm::vec2* uv = nullptr;           // per mesh vertex, in [0, 1]
  const glm::uvec3* triangles = nullptr;   // the mesh's
  int width = 0, height = 0;
  const std::uint32_t* point_of_texel = nullptr;  // width * height: the point index, or kNone

  // Bilinear: the covered texels among the 4 around the hit's lightmap UV
  // (texel centres at (i + 0.5) / size), their weights renormalised over the
  // covered ones, as a GPU samples the dilated lightmap; where none of the
  // 4 is covered, the nearest covered one (point()). Writes up to 4 (point,
  // weight) pairs; returns how many.
  int points(std::uint32_t tri, float u, float v, std::uint32_t* idx, float* weight) const {
    const glm::uvec3 t = triangles[tri];
    const glm::vec2 p = (1.0f - u - v) * uv[t.x] + u * uv[t.y] + v * uv[t.z];
    const float x = p.x * float(width) - 0.5f, y = p.y * float(height) - 0.5f;
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const float fx = x - float(x0), fy = y - float(y0);
    int n = 0;
    float sum = 0;
    for (int dy = 0; dy <= 1; ++dy)
      for (int dx = 0; dx <= 1; ++dx) {
        const int xx = x0 + dx, yy = y0 + dy;
        if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
        const std::uint32_t i = point_of_texel[std::size_t(yy) * std::size_t(width) + std::size_t(xx)];
        const float w = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy);
        if (i == kNone || !(w > 0.0f)) continue;
        idx[n] = i;
        weight[n++] = w;
        sum += w;
      }
    if (n == 0) {
      const std::uint32_t i = point(tri, u, v);
      if (i == kNone) return 0;
      idx[0] = i;
      weight[0] = 1.0f;
      return 1;
    }
    for (int k = 0; k < n; ++k) weight[k] /= sum;
    return n;
  }

  std::uint32_t point(std::uint32_t tri, float u, float v) const {
    const glm::uvec3 t = triangles[tri];
    const glm::vec2 p = (1.0f - u - v) * uv[t.x] + u * uv[t.y] + v * uv[t.z];
    const int x = int(p.x * float(width)), y = int(p.y * float(height));
    for (int ring = 0; ring <= 1; ++ring)
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dx = -ring; dx <= ring; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
          const std::uint32_t i = point_of_texel[std::size_t(yy) * std::size_t(width) + std::size_t(xx)];
          if (i != kNone) return i;
        }
    return kNone;
  }
};

// Where the first pass traces from: the mesh's vertices, or other points
// (SamplePoints, texels) with their own albedo.
struct Source {
  const glm::vec3* positions = nullptr;
  const glm::vec3* normals = nullptr;
  std::size_t count = 0;
  const glm::vec3* albedo = nullptr;  // per point (points only); nullptr: TransferOptions::albedo
  bool vertices = true;               // the mesh's own vertices (their colours with vertex_colors)
  // Points that gather their bounces from each other (texels): with this,
  // interreflection iterates over the points, as over vertices.
  const HitToPoint* hit_points = nullptr;
  bool compact = false;  // points: drop analytic rows (slots), as for vertices
  // The mesh's ray scene, built once by a caller that traces many batches
  // (adaptive sample points); nullptr: built for this call.
  const RayScene* scene = nullptr;
  // Points that are some of the mesh's vertices (adaptive sample points,
  // precompute/adaptive.cpp): the interreflection gathers from every vertex
  // (the gather's columns are mesh vertices), whose rows `expand` makes from
  // the points' rows (P x stride in, V x stride out: the points' own rows
  // copied, the other vertices interpolated). Glossy interreflected takes
  // the hits' final transfer from it too.
  // `transfer`: the rows are transfer (the direct part, or the total), else
  // one bounce's light alone.
  const std::function<void(const std::vector<float>& point_rows, std::vector<float>& vertex_rows, bool transfer)>*
      expand = nullptr;
  // Filled on rank 0 (every rank with keep_everywhere) with each point's
  // analytic flag (1: no occluded ray), before any compaction.
  std::vector<std::uint8_t>* analytic_out = nullptr;
};

// Some points as a Source (adaptive sample points' batches, subdivision
// rounds): their positions, normals and per-point albedo (clamped to
// [0, 1]) copied; source() is a Source over them tracing against `scene`
// (nullptr: one built per call), with `hit_points` (texels gathering from
// each other) when set.
struct VertexPoints {
  std::vector<glm::vec3> positions, normals, albedo;
  const HitToPoint* hit_points = nullptr;
  // Points `ids` of arrays of positions, normals and albedo (nullptr: none per point).
  VertexPoints(const glm::vec3* p, const glm::vec3* n, const glm::vec3* a, const std::vector<std::uint32_t>& ids) {
    positions.reserve(ids.size());
    normals.reserve(ids.size());
    for (std::uint32_t v : ids) {
      positions.push_back(p[v]);
      normals.push_back(n[v]);
      if (a) albedo.push_back(glm::clamp(a[v], 0.0f, 1.0f));
    }
  }
  // Vertices `ids` of `mesh`, their colours as albedo with vertex_colors.
  VertexPoints(const Mesh& mesh, const std::vector<std::uint32_t>& ids, bool vertex_colors)
      : VertexPoints(mesh.positions.data(), mesh.normals.data(), vertex_colors ? mesh.colors.data() : nullptr, ids) {}
  Source source(const RayScene* scene) const {
    Source src;
    src.positions = positions.data();
    src.normals = normals.data();
    src.count = positions.size();
    src.albedo = albedo.empty() ? nullptr : albedo.data();
    src.vertices = false;
    src.hit_points = hit_points;
    src.scene = scene;
    return src;
  }
};

// Sample points chosen among by adaptive sample points (precompute/adaptive.cpp):
// a mesh's vertices, or a lightmap's texels. Neighbours (CSR, both ways) are
// what the choice walks along the surface: mesh edges, or texels next to each
// other in one chart of the atlas.
struct AdaptivePoints {
  const glm::vec3* positions = nullptr;
  const glm::vec3* normals = nullptr;  // unit, or zero: no transfer (zero row, never traced)
  std::size_t count = 0;
  std::vector<glm::vec3> albedo;       // per point, in [0, 1]; empty: TransferOptions::albedo
  std::vector<std::uint32_t> offset, next;
  double spacing = 0;                  // mean distance between neighbours (the finest level's scale)
  const HitToPoint* hit_points = nullptr;  // texels: the bounces gather from them, as compute_at's points
};

// Throws prt::Error for adaptive options out of range (for `points` sample points).
void check_adaptive_options(const AdaptiveOptions& adaptive, std::size_t points);

// The adaptive transfer at `points` (checked options; glossy only for a
// mesh's vertices): rows of every point, the interpolated ones marked in
// Transfer::interpolated, analytic rows compacted; mesh_hash and
// shading_hash left to the caller.
Transfer adaptive_at(const Mesh& mesh, const AdaptivePoints& points, const TransferOptions& options,
                     const AdaptiveOptions& adaptive, const Progress& progress, AdaptiveReport& report);

// The metric of adaptive sample points' and subdivision's TOL
// (docs/PRECOMPUTE.md): coefficient k of band l weighted (l + 1)^-2, the
// power of typical lighting per band, so that a difference of rows measures
// a difference of relit radiance.
inline std::vector<double> band_weights(int bands) {
  std::vector<double> w(std::size_t(bands) * std::size_t(bands));
  for (int l = 0; l < bands; ++l)
    for (int k = l * l; k < (l + 1) * (l + 1); ++k) w[std::size_t(k)] = 1.0 / double((l + 1) * (l + 1));
  return w;
}

// sum_c sum_k w_k (a - b)^2 / channels over `channels` rows of w.size()
// coefficients each (b nullptr: of a alone).
inline double weighted_square(const float* a, const float* b, const std::vector<double>& w, int channels) {
  const std::size_t nc = w.size();
  double s = 0;
  for (int c = 0; c < channels; ++c)
    for (std::size_t k = 0; k < nc; ++k) {
      const double d = double(a[std::size_t(c) * nc + k]) - (b ? double(b[std::size_t(c) * nc + k]) : 0.0);
      s += w[k] * d * d;
    }
  return s / channels;
}

// Throws prt::Error for options compute_transfer refuses on `mesh`.
void check_transfer_options(const TransferOptions& options, const Mesh& mesh);

// The plan compute_at makes for `points` points (no vertices, no emitters;
// `grey`: one channel; `pairs` per ray of the gather: 3 for vertices, 4 for
// texels) on this rank, as transfer_memory does for the vertices: `base` the
// process now, `fixed` the arrays and scene, `minimum` the least limit. For a
// plan known before the points are (check_lightmap_memory).
TransferMemory point_transfer_memory(const Mesh& mesh, std::size_t points, const TransferOptions& options, bool grey,
                                     int pairs);

// The transfer at `src` (checked options; no glossy at points but for
// subsets of vertices with `expand`). keep_everywhere: every rank returns
// the whole, uncompacted transfer (its coefficients; ambient occlusion, bent
// normals and glossy matrices on rank 0 only).
Transfer compute_at(const Mesh& mesh, const Source& src, const TransferOptions& options, const Progress& progress,
                    bool keep_everywhere = false);

// The lights' bounce operator's source patches (precompute/light_bounce.cpp;
// prt/light_bounce.h): nested grids of cells `cell`, 2 cell, 4 cell, ...
// world units, up to one that spans the points' bounds; a patch is the points
// in one cell with one dominant normal direction (the largest component of
// the normal and its sign: the two sides of a wall, and walls meeting at a
// corner, are apart; points without a normal form patches of their own).
// Numbered level by level from the finest, in order of first appearance.
struct SourcePatches {
  int levels = 0;
  std::uint32_t patches = 0;
  std::vector<std::uint32_t> of_point;  // levels x points: point i's patch at level l is of_point[l * points + i]
  std::vector<std::uint32_t> parent;    // per patch: its cell's patch at the next level, or LightBounce::kNoParent
};
SourcePatches source_patches(const glm::vec3* positions, const glm::vec3* normals, std::size_t count, double cell);

// A probe grid point nearer a surface than probe_lift(grid) (a twentieth of
// its smallest spacing) is moved twice that off it, to the side it is on
// (the front when it lies on it), once per surface (a corner):
// compute_probe_transfer's probes and the light-bounce operator's probe rows
// stand at the same places.
double probe_lift(const ProbeGrid& grid);
glm::vec3 lift_off_surfaces(const RayScene& rays, const Mesh& mesh, double lift, glm::vec3 x);

// Throws prt::Error for options.light_bounce: adaptive sample points
// interpolate some points' transfer, which then have no gather row.
void refuse_adaptive_light_bounce(const TransferOptions& options);  // and a translucent surface integral
// The mean length of a mesh's edges (each triangle's three; 0 for none): the
// spacing of its vertices, a vertex transfer's default patch size.
double mean_edge_length(const Mesh& mesh);

}  // namespace prt::detail
