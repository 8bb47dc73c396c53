// Transfer compressed by clustered PCA (prt/compressed_transfer.h):
// decompression, and CPU relighting by per-cluster lighting products.
#include <prt/compressed_transfer.h>

#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/sh.h>

#include "transfer_rules.h"

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <tbb/parallel_for.h>

#include <cmath>

namespace prt {

std::size_t ClusteredSignal::planned_bytes(std::size_t rows, std::size_t dim, int clusters, int vectors,
                                           int weight_bits) {
  if (rows == 0) return 0;
  const std::size_t K = std::min<std::size_t>(std::size_t(clusters), rows);
  const std::size_t N = std::min<std::size_t>(std::size_t(vectors), dim);
  return rows * (std::size_t(index_bits_for(int(K)) / 8) + std::size_t(weight_bits / 8) * N) + K * 4 * (N + 1) * dim +
         (weight_bits == 16 ? K * N * 4 : 0);
}

std::size_t ClusteredSignal::bytes() const { return planned_bytes(rows(), dim, clusters, vectors, weight_bits); }

void ClusteredSignal::reconstruct(std::size_t r, float* out) const {
  PRT_CHECK_OP(r, <, rows());
  const std::size_t k = cluster[r];
  std::vector<double> acc(means.begin() + std::ptrdiff_t(k * dim), means.begin() + std::ptrdiff_t((k + 1) * dim));
  for (int j = 0; j < vectors; ++j) {
    const double w = weights[r * std::size_t(vectors) + j];
    const float* b = bases.data() + (k * vectors + j) * dim;
    for (std::size_t i = 0; i < dim; ++i) acc[i] += w * b[i];
  }
  for (std::size_t i = 0; i < dim; ++i) out[i] = float(acc[i]);
}

namespace {

std::string signal_problem(const ClusteredSignal& s, std::size_t rows, std::size_t dim, const char* what) {
  if (s.dim != dim)
    return fmt::format("the compressed {} have {} values per row; the transfer's rows have {}", what, s.dim, dim);
  if (s.rows() != rows)
    return fmt::format("the compressed {} have {} rows; the transfer stores {} vertices", what, s.rows(), rows);
  if (rows == 0) {
    if (s.clusters != 0 || s.vectors != 0 || !s.means.empty() || !s.bases.empty() || !s.weights.empty())
      return fmt::format("the compressed {} have clusters but no rows", what);
    return {};
  }
  if (s.clusters < 1 || s.clusters > (1 << 24))
    return fmt::format("the compressed {} have {} clusters; expected 1 to 2^24", what, s.clusters);
  if (s.vectors < 0 || std::size_t(s.vectors) > dim)
    return fmt::format("the compressed {} have {} principal vectors; expected 0 to {} (the row length)", what,
                       s.vectors, dim);
  const std::size_t K = std::size_t(s.clusters), N = std::size_t(s.vectors);
  if (s.means.size() != K * dim || s.bases.size() != K * N * dim || s.weights.size() != rows * N)
    return fmt::format("the compressed {} have {} means, {} basis values and {} weights; expected {}, {} and {}", what,
                       s.means.size(), s.bases.size(), s.weights.size(), K * dim, K * N * dim, rows * N);
  if (s.weight_bits != 32 && s.weight_bits != 16)
    return fmt::format("the compressed {} have {}-bit weights; expected 32 or 16", what, s.weight_bits);
  if (s.weight_scales.size() != (s.weight_bits == 16 ? K * N : 0))
    return fmt::format("the compressed {} have {} weight scales; {}-bit weights take {}", what, s.weight_scales.size(),
                       s.weight_bits, s.weight_bits == 16 ? K * N : 0);
  for (std::size_t r = 0; r < rows; ++r)
    if (s.cluster[r] >= K)
      return fmt::format("row {} of the compressed {} is in cluster {}; there are {}", r, what, s.cluster[r], K);
  const auto finite = [&](const std::vector<float>& a, const char* part) -> std::string {
    for (std::size_t i = 0; i < a.size(); ++i)
      if (!std::isfinite(a[i]))
        return fmt::format("the compressed {} have a non-finite {} ({:g} at index {})", what, part, double(a[i]), i);
    return {};
  };
  for (const auto& [a, part] : {std::pair{&s.means, "mean"}, std::pair{&s.bases, "basis value"},
                                std::pair{&s.weights, "weight"}, std::pair{&s.weight_scales, "weight scale"}})
    if (auto p = finite(*a, part); !p.empty()) return p;
  if (s.weight_bits == 16) {
    for (float sc : s.weight_scales)
      if (!(sc >= 0.0f)) return fmt::format("the compressed {} have a negative weight scale ({:g})", what, double(sc));
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t j = 0; j < N; ++j) {
        const float sc = s.weight_scales[s.cluster[r] * N + j], w = s.weights[r * N + j];
        if (quantised_weight(w, sc) != w)
          return fmt::format("row {} of the compressed {} has weight {} = {:g}, not a multiple of its scale {:g} within "
                             "32767 steps (16-bit weights)",
                             r, what, j, double(w), double(sc));
      }
  }
  return {};
}

void check(const CompressedTransfer& c) {
  if (const std::string p = compressed_transfer_problem(c); !p.empty()) throw Error("compressed transfer: " + p);
}

// The transfer with every stored row zero: what relight() needs for its
// analytic vertices (and the stored ones then come from the clusters).
Transfer zero_rows(const CompressedTransfer& c) {
  Transfer t = c.transfer;
  t.coeffs.assign(t.stored_vertices() * t.stride(), 0.0f);
  if (t.glossy) t.glossy_matrices.assign(t.stored_vertices() * t.glossy_stride(), 0.0f);
  return t;
}

// The diffuse radiance of every stored row: mean product + sum_j w_j basis product.
template <typename F>
void for_stored(const Transfer& t, F&& f) {
  tbb::parallel_for(std::size_t(0), t.vertices, [&](std::size_t v) {
    const std::size_t r = t.slots.empty() ? v : t.slots[v];
    if (r != Transfer::kAnalytic) f(v, r);
  });
}

glm::dvec3 row_radiance(const ClusteredSignal& s, const std::vector<glm::dvec3>& products, std::size_t r) {
  const int per = s.vectors + 1;
  const std::size_t k = s.cluster[r];
  glm::dvec3 b = products[k * per];
  for (int j = 0; j < s.vectors; ++j) b += double(s.weights[r * s.vectors + j]) * products[k * per + 1 + j];
  return b;
}

}  // namespace

std::string compressed_transfer_problem(const CompressedTransfer& c) {
  const Transfer& t = c.transfer;
  if (auto p = detail::transfer_problem_without_rows(t); !p.empty()) return p;
  if (auto p = signal_problem(c.coeffs, t.stored_vertices(), t.stride(), "coefficients"); !p.empty()) return p;
  if (t.glossy) {
    if (auto p = signal_problem(c.glossy, t.stored_vertices(), t.glossy_stride(), "glossy matrices"); !p.empty())
      return p;
  } else if (c.glossy.rows() != 0 || c.glossy.clusters != 0) {
    return "compressed glossy matrices in a transfer without the glossy flag";
  }
  if (c.choice) return compression_choice_problem(*c.choice);
  return {};
}

std::vector<glm::dvec3> cluster_lighting(const ClusteredSignal& s, int channels, int bands,
                                         std::span<const glm::dvec3> light) {
  const int nc = bands * bands, per = s.vectors + 1;
  PRT_CHECK_OP(light.size(), >=, std::size_t(nc));
  PRT_CHECK_OP(s.dim, ==, std::size_t(channels) * nc);
  std::vector<glm::dvec3> out(std::size_t(s.clusters) * per, glm::dvec3(0.0));
  for (int k = 0; k < s.clusters; ++k)
    for (int j = 0; j < per; ++j) {
      const float* v = j == 0 ? s.means.data() + std::size_t(k) * s.dim
                              : s.bases.data() + (std::size_t(k) * s.vectors + (j - 1)) * s.dim;
      glm::dvec3 r(0.0);
      for (int c = 0; c < 3; ++c) {
        const float* vc = v + (channels == 1 ? 0 : std::size_t(c) * nc);
        for (int i = 0; i < nc; ++i) r[c] += double(vc[i]) * light[std::size_t(i)][c];
      }
      out[std::size_t(k) * per + j] = r;
    }
  return out;
}

std::vector<glm::dvec3> glossy_cluster_lighting(const Transfer& z, const ClusteredSignal& g,
                                                std::span<const glm::dvec3> light) {
  PRT_CHECK(z.glossy);
  const std::size_t nc = std::size_t(z.bands) * z.bands;
  PRT_CHECK_OP(light.size(), >=, nc);
  PRT_CHECK_OP(g.dim, ==, z.glossy_stride());
  const int per = g.vectors + 1, gch = z.glossy_channels();
  std::vector<glm::dvec3> ml(std::size_t(g.clusters) * per * nc, glm::dvec3(0.0));
  tbb::parallel_for(0, g.clusters, [&](int k) {
    for (int j = 0; j < per; ++j) {
      const float* M = j == 0 ? g.means.data() + std::size_t(k) * g.dim
                              : g.bases.data() + (std::size_t(k) * g.vectors + (j - 1)) * g.dim;
      glm::dvec3* dst = ml.data() + (std::size_t(k) * per + j) * nc;
      if (z.glossy_symmetric()) {
        std::size_t q = 0;
        for (std::size_t a = 0; a < nc; ++a)
          for (std::size_t b = a; b < nc; ++b, ++q) {
            dst[a] += double(M[q]) * light[b];
            if (b != a) dst[b] += double(M[q]) * light[a];
          }
      } else {
        for (int ch = 0; ch < 3; ++ch) {
          const float* Mc = M + std::size_t(gch == 3 ? ch : 0) * nc * nc;
          for (std::size_t a = 0; a < nc; ++a)
            for (std::size_t b = 0; b < nc; ++b) dst[a][ch] += double(Mc[a * nc + b]) * light[b][ch];
        }
      }
    }
  });
  return ml;
}

Transfer decompress(const CompressedTransfer& c) {
  check(c);
  Transfer t = c.transfer;
  const std::size_t rows = t.stored_vertices();
  t.coeffs.assign(rows * t.stride(), 0.0f);
  for (std::size_t r = 0; r < rows; ++r) c.coeffs.reconstruct(r, t.coeffs.data() + r * t.stride());
  if (t.glossy) {
    t.glossy_matrices.assign(rows * t.glossy_stride(), 0.0f);
    for (std::size_t r = 0; r < rows; ++r) c.glossy.reconstruct(r, t.glossy_matrices.data() + r * t.glossy_stride());
  }
  return t;
}

std::vector<glm::vec3> relight(const CompressedTransfer& c, const Mesh& mesh, const std::vector<glm::dvec3>& light) {
  check(c);
  const Transfer z = zero_rows(c);
  std::vector<glm::vec3> out = relight(z, mesh, light);  // analytic vertices; checks the lighting's size
  const std::vector<glm::dvec3> p = cluster_lighting(c.coeffs, z.channels, z.bands, light);
  for_stored(z, [&](std::size_t v, std::size_t r) { out[v] = glm::vec3(row_radiance(c.coeffs, p, r)); });
  return out;
}

std::vector<glm::vec3> relight_glossy(const CompressedTransfer& c, const Mesh& mesh,
                                      const std::vector<glm::dvec3>& light, const GlossyShading& s) {
  check(c);
  const Transfer z = zero_rows(c);
  std::vector<glm::vec3> out = relight_glossy(z, mesh, light, s);  // analytic vertices; checks the shading
  const int n = z.bands;
  const std::size_t nc = std::size_t(n) * n;
  const glm::dvec3 scale = glossy_diffuse_scale(z, s);
  const std::vector<glm::dvec3> p = cluster_lighting(c.coeffs, z.channels, n, light);
  const ClusteredSignal& g = c.glossy;
  const int per = g.vectors + 1;
  const std::vector<glm::dvec3> ml = glossy_cluster_lighting(c.transfer, c.glossy, light);  // [k][j][i], nc RGB per matrix
  const std::vector<double> lambda = glossy::phong_lobe_factors(s.gloss, n);
  for_stored(z, [&](std::size_t v, std::size_t r) {
    glm::dvec3 rgb = glm::dvec3(out[v]) + scale * row_radiance(c.coeffs, p, r);  // out[v]: 0 for a stored row
    const glm::vec3 nf = mesh.normals[v];
    if (nf != glm::vec3(0.0f) && s.specular > 0) {
      const glm::dvec3 nrm = glm::normalize(glm::dvec3(nf));
      if (const auto mirror = glossy::mirror_direction(nrm, glm::dvec3(mesh.positions[v]), s.eye)) {
        std::vector<double> y(nc);
        sh::eval<double>(n, mirror->x, mirror->y, mirror->z, y.data());
        const std::size_t k = g.cluster[r];
        glm::dvec3 gl(0.0);
        for (int l = 0; l < n; ++l)
          for (int m = -l; m <= l; ++m) {
            const std::size_t i = std::size_t(sh::index(l, m));
            glm::dvec3 li = ml[(k * per) * nc + i];
            for (int j = 0; j < g.vectors; ++j) li += double(g.weights[r * g.vectors + j]) * ml[(k * per + 1 + j) * nc + i];
            gl += lambda[std::size_t(l)] * y[i] * li;
          }
        rgb += s.specular * gl;
      }
    }
    out[v] = glm::vec3(rgb);
  });
  return out;
}

}  // namespace prt
