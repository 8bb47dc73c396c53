// Glossy transfer matrices (prt/precompute.h, prt/glossy.h): per vertex, the
// hemisphere product matrix of its normal minus w Y Y^T of every occluded
// ray above the horizon, over the same seeded direction set as the diffuse
// transfer.
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/precompute.h>
#include <prt/sh.h>

#include "progress_ticker.h"
#include "ray_scene.h"

#include <fmt/format.h>

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <memory>

namespace prt {

GlossyMatrices compute_glossy_matrices(const Mesh& mesh, const GlossyOptions& o, const Progress& progress) {
  if (o.bands < 1 || o.bands > 16) throw Error(fmt::format("--bands must be between 1 and 16 for glossy transfer, got {}", o.bands));
  if (o.samples < 1 || o.samples > (1 << 24))
    throw Error(fmt::format("--samples must be between 1 and 16777216, got {}", o.samples));
  detail::check_common_options(glm::vec3(1.0f), false, o.threads, o.offset, mesh);
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

  const int n = o.bands, nc = n * n;
  const std::size_t V = mesh.vertex_count();
  GlossyMatrices g;
  g.bands = n;
  g.vertices = V;
  g.slots.assign(V, GlossyMatrices::kAnalytic);
  const std::size_t P = g.packed_size();

  const int M = 2 * o.samples;
  const std::vector<glm::vec3> dirs = detail::direction_set(M, o.seed);
  std::vector<double> Y(std::size_t(M) * nc);
  for (int j = 0; j < M; ++j) sh::eval<double>(n, dirs[j].x, dirs[j].y, dirs[j].z, Y.data() + std::size_t(j) * nc);
  const double w = 4.0 * M_PI / M;
  const float offset = float(o.offset > 0 ? o.offset : detail::default_ray_offset(mesh));
  const detail::RayScene scene(mesh);

  // Per block: its stored vertices (those with an occluded ray) in vertex
  // order, and their packed M_p = H(n) - the occluded sum, in float.
  constexpr std::size_t kGrain = 32;
  const std::size_t blocks = (V + kGrain - 1) / kGrain;
  struct Found {
    std::vector<std::uint32_t> vertices;
    std::vector<float> packed;
  };
  std::vector<Found> found(blocks);
  detail::ProgressTicker ticker(progress, V, "rays");
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
    detail::enable_ftz_daz();
    if (ticker.cancelled()) return;
    std::vector<double> acc(P);
    glm::vec3 batch[8];
    int batch_j[8];
    const std::size_t v0 = b * kGrain, v1 = std::min(V, v0 + kGrain);
    for (std::size_t v = v0; v < v1; ++v) {
      const glm::vec3 nrm = mesh.normals[v];
      if (glm::dot(nrm, nrm) == 0.0f) continue;
      std::fill(acc.begin(), acc.end(), 0.0);
      std::size_t occluded_rays = 0;
      const glm::vec3 origin = mesh.positions[v] + offset * nrm;
      int count = 0;
      const auto flush = [&] {
        const std::uint32_t hit = scene.occluded8(origin, batch, count, offset);
        for (int i = 0; i < count; ++i) {
          if (!(hit & (1u << i))) continue;
          ++occluded_rays;
          const double* y = Y.data() + std::size_t(batch_j[i]) * nc;
          std::size_t k = 0;
          for (int p = 0; p < nc; ++p) {
            const double wp = w * y[p];
            for (int q = p; q < nc; ++q) acc[k++] += wp * y[q];
          }
        }
        count = 0;
      };
      for (int j = 0; j < M; ++j) {
        if (glm::dot(dirs[j], nrm) <= 0.0f) continue;  // below the horizon: V_p = 0 already
        batch[count] = dirs[j];
        batch_j[count] = j;
        if (++count == 8) flush();
      }
      if (count > 0) flush();
      if (occluded_rays == 0) continue;
      const std::vector<double> H = glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm)), n);
      Found& f = found[b];
      f.vertices.push_back(std::uint32_t(v));
      std::size_t k = 0;
      for (int p = 0; p < nc; ++p)
        for (int q = p; q < nc; ++q, ++k) f.packed.push_back(float(H[std::size_t(p) * nc + q] - acc[k]));
    }
    ticker.tick(v1 - v0);
  });
  ticker.finish();

  // Stored rows in vertex order (blocks are in vertex order).
  for (const Found& f : found) {
    const std::size_t first = g.packed.size() / P;
    for (std::size_t i = 0; i < f.vertices.size(); ++i) g.slots[f.vertices[i]] = std::uint32_t(first + i);
    g.packed.insert(g.packed.end(), f.packed.begin(), f.packed.end());
  }
  return g;
}

std::vector<double> glossy_matrix(const GlossyMatrices& g, const Mesh& mesh, std::size_t v) {
  PRT_CHECK_OP(v, <, g.vertices);
  const int nc = g.bands * g.bands;
  std::vector<double> m(std::size_t(nc) * nc, 0.0);
  const glm::vec3 nrm = mesh.normals[v];
  if (g.slots[v] == GlossyMatrices::kAnalytic) {
    if (glm::dot(nrm, nrm) == 0.0f) return m;
    return glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm)), g.bands);
  }
  const float* in = g.packed.data() + std::size_t(g.slots[v]) * g.packed_size();
  std::size_t k = 0;
  for (int p = 0; p < nc; ++p)
    for (int q = p; q < nc; ++q, ++k) m[std::size_t(p) * nc + q] = m[std::size_t(q) * nc + p] = in[k];
  return m;
}

}  // namespace prt
