// Per-vertex SH transfer with Embree (docs/PRECOMPUTE.md).
//
// Shadowed transfer is computed as the analytic unshadowed transfer minus the
// occluded part: T = (rho/pi) [A_l Y_lm(n) - sum_{occluded j} w cos_j Y(w_j)].
// An unoccluded vertex is therefore exact, and the sampling error lives only
// in the occluded directions (a control variate that also spares the SH work
// of every unoccluded ray). Interreflection reuses the first pass's hits as a
// sparse gather matrix G (receiver vertex x emitting vertex), one gather per
// bounce. Vertices none of whose rays is occluded keep no stored transfer
// (prt/transfer.h, "analytic vertices").
//
// Glossy matrices (TransferOptions::glossy) come from the same rays: the
// hemisphere product matrix of the normal minus w Y Y^T of every occluded ray
// (one BLAS rank-k update per vertex); interreflected adds, for every ray
// that hits a front face, w Y(s) T_q^T with T_q the hit point's final
// diffuse transfer (one BLAS product per vertex after the bounces).
// Computing SH transfer: see prt/precompute.h.
#include <prt/precompute.h>

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/glossy.h>
#include <prt/sh.h>

#include "progress_ticker.h"
#include "ray_scene.h"

#include <fmt/format.h>

#include <cblas.h>

#include "blas.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cmath>
#include <memory>

namespace prt {

namespace {

void check_options(const TransferOptions& o, const Mesh& mesh) {
  sh::check_bands(o.bands, "--bands");
  if (o.samples < 1 || o.samples > (1 << 24))
    throw Error(fmt::format("--samples must be between 1 and 16777216, got {}", o.samples));
  if (o.bounces < 0 || o.bounces > 64)
    throw Error(fmt::format("--bounces must be between 0 and 64, got {}", o.bounces));
  if (!(o.bounce_tolerance >= 0.0 && o.bounce_tolerance < 1.0))
    throw Error(fmt::format("--bounce-tolerance must be in [0, 1), got {:f}", o.bounce_tolerance));
  if (o.glossy && o.mode == TransferMode::Unshadowed)
    throw Error("--material glossy needs --mode shadowed or interreflected (an unshadowed vertex's glossy matrix is the "
                "hemisphere's, computed at run time)");
  if (o.glossy && o.bands > kMaxGlossyBands)
    throw Error(fmt::format("--bands must be at most {} for glossy transfer (each matrix has bands^4 entries), got {}",
                            kMaxGlossyBands, o.bands));
  detail::check_common_options(o.albedo, o.vertex_colors, o.threads, o.offset, mesh);
}

// Albedo of vertex v, channel c.
struct Albedo {
  const TransferOptions& o;
  const Mesh& m;
  float operator()(std::size_t v, int c) const {
    return o.vertex_colors ? std::clamp(m.colors[v][c], 0.0f, 1.0f) : o.albedo[c];
  }
};

// Sparse gather matrix in CSR form: row v lists (emitting vertex, weight)
// with weight = sum over rays of v that hit the front of a triangle touching
// that vertex of w cos barycentric.
struct Gather {
  std::vector<std::size_t> row;  // V + 1
  std::vector<std::uint32_t> col;
  std::vector<float> val;
};

// A ray of a vertex that hit the front of a triangle, for interreflected
// glossy: its direction's index and where it hit.
struct FrontHit {
  std::uint32_t dir, triangle;
  float u, v;
};

// out (n x n, row-major, upper triangle) = alpha a^T a + beta out for the k x n
// row-major a: the BLAS rank-k update.
void rank_k_update(int n, int k, double alpha, const double* a, double beta, double* out) {
  cblas_dsyrk(CblasRowMajor, CblasUpper, CblasTrans, n, k, alpha, a, n, beta, out, n);
}

}  // namespace

namespace {

// Interreflected glossy: M_p[c] += w sum_front hits Y(s) T_q[c]^T, T_q the
// final diffuse transfer (t.coeffs, one row per vertex) at the hit point by
// its barycentric coordinates; per vertex one BLAS product
// (nc x H) (H x channels nc).
void add_glossy_bounce_light(Transfer& t, const Mesh& mesh, std::vector<std::vector<FrontHit>>& front_hits,
                             const std::vector<double>& Y, double w, const Progress& progress) {
  const std::size_t V = t.vertices, nc = std::size_t(t.bands) * t.bands, stride = t.stride();
  const std::size_t gstride = t.glossy_stride();
  detail::ProgressTicker ticker(progress, V, "glossy bounce light");
  constexpr std::size_t kGrain = 64;
  tbb::parallel_for(std::size_t(0), (V + kGrain - 1) / kGrain, [&](std::size_t block) {
    if (ticker.cancelled()) return;
    std::vector<double> Yh, Th, B(nc * stride);
    const std::size_t v0 = block * kGrain, v1 = std::min(V, v0 + kGrain);
    for (std::size_t v = v0; v < v1; ++v) {
      std::vector<FrontHit>& hits = front_hits[v];
      if (hits.empty()) continue;
      const std::size_t H = hits.size();
      Yh.resize(H * nc);
      Th.assign(H * stride, 0.0);
      for (std::size_t h = 0; h < H; ++h) {
        std::copy_n(Y.begin() + std::ptrdiff_t(hits[h].dir * nc), nc, Yh.begin() + std::ptrdiff_t(h * nc));
        const glm::uvec3 tri = mesh.triangles[hits[h].triangle];
        const double b[3] = {1.0 - hits[h].u - hits[h].v, hits[h].u, hits[h].v};
        double* th = Th.data() + h * stride;
        for (int c = 0; c < 3; ++c) {
          const float* src = t.coeffs.data() + std::size_t(tri[c]) * stride;
          for (std::size_t k = 0; k < stride; ++k) th[k] += b[c] * src[k];
        }
      }
      cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, int(nc), int(stride), int(H), w, Yh.data(), int(nc),
                  Th.data(), int(stride), 0.0, B.data(), int(stride));
      float* g = t.glossy_matrices.data() + v * gstride;
      for (int c = 0; c < t.channels; ++c)
        for (std::size_t i = 0; i < nc; ++i)
          for (std::size_t j = 0; j < nc; ++j)
            g[std::size_t(c) * nc * nc + i * nc + j] =
                float(double(g[std::size_t(c) * nc * nc + i * nc + j]) + B[i * stride + std::size_t(c) * nc + j]);
      std::vector<FrontHit>().swap(hits);
    }
    ticker.tick(v1 - v0);
  });
  ticker.finish();
}

}  // namespace

Transfer compute_transfer(const Mesh& mesh, const TransferOptions& o, const Progress& progress) {
  check_options(o, mesh);
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

  const int n = o.bands, nc = sh::num_coeffs(n);
  const std::size_t V = mesh.vertex_count();
  const bool grey = !o.vertex_colors && o.albedo.x == o.albedo.y && o.albedo.y == o.albedo.z;
  Transfer t;
  t.bands = n;
  t.channels = grey ? 1 : 3;
  t.mode = o.mode;
  t.bounces = o.mode == TransferMode::Interreflected ? o.bounces : 0;
  t.samples = o.mode == TransferMode::Unshadowed ? 0 : o.samples;
  t.albedo = o.albedo;
  t.vertex_colors = o.vertex_colors;
  t.seed = o.seed;
  t.vertices = V;
  t.mesh_hash = mesh.hash();
  const std::size_t stride = t.stride();
  const Albedo albedo{o, mesh};

  // Geometry-only transfer S (no albedo), one channel: S_k = (1/pi) integral V cos+ Y_k.
  std::vector<double> A = sh::clamped_cosine_factors(n);
  std::vector<float> S(V * nc, 0.0f);
  t.ao.assign(V, 1.0f);
  t.bent_normals.assign(mesh.normals.begin(), mesh.normals.end());
  Gather G;
  const bool trace = o.mode != TransferMode::Unshadowed;
  const bool gather = o.mode == TransferMode::Interreflected && o.bounces > 0;

  const bool glossy = o.glossy;
  if (glossy) detail::blas_single_threaded();
  const bool glossy_ir = glossy && o.mode == TransferMode::Interreflected;
  const bool want_hits = gather || glossy_ir;
  t.glossy = glossy;
  const std::size_t gstride = glossy ? t.glossy_stride() : 0;
  if (glossy) t.glossy_matrices.assign(V * gstride, 0.0f);
  std::vector<std::vector<FrontHit>> front_hits(glossy_ir ? V : 0);

  const int M = 2 * o.samples;
  const std::vector<glm::vec3> dirs = trace ? detail::direction_set(M, o.seed) : std::vector<glm::vec3>{};
  std::vector<float> Ytab(trace ? std::size_t(M) * nc : 0);
  for (int j = 0; j < (trace ? M : 0); ++j) sh::eval<float>(n, dirs[j].x, dirs[j].y, dirs[j].z, Ytab.data() + std::size_t(j) * nc);
  // Glossy: the basis in double (the products of the matrices sum many rays).
  std::vector<double> Ydbl(glossy ? std::size_t(M) * nc : 0);
  for (int j = 0; j < (glossy ? M : 0); ++j) sh::eval<double>(n, dirs[j].x, dirs[j].y, dirs[j].z, Ydbl.data() + std::size_t(j) * nc);
  const double w = 4.0 * M_PI / M;
  const float offset = float(o.offset > 0 ? o.offset : detail::default_ray_offset(mesh));

  std::unique_ptr<detail::RayScene> scene;
  if (trace) scene = std::make_unique<detail::RayScene>(mesh);
  std::vector<std::vector<std::pair<std::uint32_t, float>>> rows(gather ? V : 0);
  // Vertices with a normal and no occluded ray: their transfer is the
  // analytic clamped cosine, stored by no one (compact_transfer below).
  std::vector<std::uint8_t> analytic(V, 0);

  detail::ProgressTicker first(progress, V, trace ? "rays" : "transfer");
  constexpr std::size_t kGrain = 64;
  tbb::parallel_for(std::size_t(0), (V + kGrain - 1) / kGrain, [&](std::size_t block) {
    detail::enable_ftz_daz();
    if (first.cancelled()) return;
    std::vector<double> Yn(nc), occ(nc);
    std::vector<double> Yocc, C(glossy ? std::size_t(nc) * nc : 0);  // glossy: the occluded rays' Y, and w Yocc^T Yocc
    glm::vec3 batch[8];
    int batch_j[8];
    detail::Hit hits[8];
    const std::size_t v0 = block * kGrain, v1 = std::min(V, v0 + kGrain);
    for (std::size_t v = v0; v < v1; ++v) {
      const glm::vec3 nrm = mesh.normals[v];
      if (glm::dot(nrm, nrm) == 0.0f) {  // unreferenced or no normal: no transfer
        t.ao[v] = 0.0f;
        continue;
      }
      sh::eval<double>(n, nrm.x, nrm.y, nrm.z, Yn.data());
      float* s = S.data() + v * nc;
      if (!trace) {
        analytic[v] = 1;
        for (int l = 0; l < n; ++l)
          for (int m = -l; m <= l; ++m) s[sh::index(l, m)] = float(A[l] * Yn[sh::index(l, m)] / M_PI);
        continue;
      }
      std::fill(occ.begin(), occ.end(), 0.0);
      Yocc.clear();
      std::size_t occluded_rays = 0;
      double occ_cos = 0.0;
      glm::dvec3 occ_dir(0.0);
      const glm::vec3 origin = mesh.positions[v] + offset * nrm;
      auto row_of = [&](int count) {
        // Occluded directions of this batch: subtract their cosine-weighted
        // basis; record front hits for the bounce gather.
        std::uint32_t occluded = 0;
        if (want_hits) {
          scene->intersect8(origin, batch, count, offset, hits);
          for (int i = 0; i < count; ++i) occluded |= hits[i].hit() ? 1u << i : 0u;
        } else {
          occluded = scene->occluded8(origin, batch, count, offset);
        }
        for (int i = 0; i < count; ++i) {
          if (!(occluded & (1u << i))) continue;
          ++occluded_rays;
          const int j = batch_j[i];
          const double wc = w * glm::dot(nrm, dirs[j]);
          const float* y = Ytab.data() + std::size_t(j) * nc;
          for (int k = 0; k < nc; ++k) occ[k] += wc * y[k];
          occ_cos += wc;
          occ_dir += wc * glm::dvec3(dirs[j]);
          if (glossy) Yocc.insert(Yocc.end(), Ydbl.begin() + std::ptrdiff_t(j) * nc, Ydbl.begin() + std::ptrdiff_t(j + 1) * nc);
          if (glossy_ir && hits[i].front)
            front_hits[v].push_back({std::uint32_t(j), hits[i].triangle, hits[i].u, hits[i].v});
          if (gather && hits[i].front) {
            const glm::uvec3 tri = mesh.triangles[hits[i].triangle];
            const float b[3] = {1.0f - hits[i].u - hits[i].v, hits[i].u, hits[i].v};
            for (int c = 0; c < 3; ++c) rows[v].emplace_back(tri[c], float(wc) * b[c]);
          }
        }
      };
      int count = 0;
      double all_cos = 0.0;  // the direction set's own integral of cos+ (pi up to its quadrature error)
      for (int j = 0; j < M; ++j) {
        const float c = glm::dot(nrm, dirs[j]);
        if (c <= 0.0f) continue;  // below the horizon: no ray
        all_cos += w * c;
        batch[count] = dirs[j];
        batch_j[count++] = j;
        if (count == 8) {
          row_of(count);
          count = 0;
        }
      }
      if (count) row_of(count);
      analytic[v] = occluded_rays == 0;
      if (glossy && occluded_rays > 0) {
        // M_p = H(n) - w sum_occluded Y Y^T (upper triangle from the BLAS).
        rank_k_update(nc, int(occluded_rays), w, Yocc.data(), 0.0, C.data());
        const std::vector<double> H = glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm)), n);
        float* g = t.glossy_matrices.data() + v * gstride;
        std::size_t k = 0;
        for (int p = 0; p < nc; ++p)
          for (int q = glossy_ir ? 0 : p; q < nc; ++q) {
            const int a = std::min(p, q), b = std::max(p, q);
            const double value = H[std::size_t(p) * nc + q] - C[std::size_t(a) * nc + b];
            if (glossy_ir)  // full, per channel; the bounce light is added below
              for (int c = 0; c < t.channels; ++c) g[std::size_t(c) * nc * nc + std::size_t(p) * nc + q] = float(value);
            else
              g[k++] = float(value);
          }
      }
      // Scale the occluded sums so the set integrates cos+ to exactly pi: a
      // fully occluded vertex then gets AO 0 and T_00 0 exactly.
      const double scale = all_cos > 0.0 ? M_PI / all_cos : 1.0;
      for (int l = 0; l < n; ++l)
        for (int m = -l; m <= l; ++m) {
          const int k = sh::index(l, m);
          s[k] = float((A[l] * Yn[k] - scale * occ[k]) / M_PI);
        }
      t.ao[v] = float(std::clamp(1.0 - scale * occ_cos / M_PI, 0.0, 1.0));
      const glm::dvec3 bent = (2.0 * M_PI / 3.0) * glm::dvec3(nrm) - scale * occ_dir;
      const double len = glm::length(bent);
      t.bent_normals[v] = len > 0 ? glm::vec3(bent / len) : nrm;
      if (gather) {  // merge duplicate emitters, in a fixed order; same scale as above
        auto& r = rows[v];
        for (auto& e : r) e.second = float(scale * e.second);
        std::sort(r.begin(), r.end(), [](auto& a, auto& b) { return a.first < b.first; });
        std::size_t out = 0;
        for (std::size_t i = 0; i < r.size(); ++i) {
          if (out > 0 && r[out - 1].first == r[i].first)
            r[out - 1].second += r[i].second;
          else
            r[out++] = r[i];
        }
        r.resize(out);
        r.shrink_to_fit();
      }
    }
    first.tick(v1 - v0);
  });
  first.finish();
  scene.reset();

  // Direct transfer: albedo times S.
  t.coeffs.assign(V * stride, 0.0f);
  tbb::parallel_for(std::size_t(0), V, [&](std::size_t v) {
    for (int c = 0; c < t.channels; ++c) {
      const float a = albedo(v, c);
      for (int k = 0; k < nc; ++k) t.coeffs[v * stride + std::size_t(c) * nc + k] = a * S[v * nc + k];
    }
  });
  S.clear();
  S.shrink_to_fit();
  t.shading_hash = shading_hash(mesh, o.vertex_colors);
  if (!gather) {
    if (o.mode == TransferMode::Interreflected) t.direct = t.coeffs;
    if (glossy_ir) add_glossy_bounce_light(t, mesh, front_hits, Ydbl, w, progress);
    compact_transfer(t, analytic);
    return t;
  }

  // CSR gather matrix from the per-vertex rows.
  G.row.assign(V + 1, 0);
  for (std::size_t v = 0; v < V; ++v) G.row[v + 1] = G.row[v] + rows[v].size();
  G.col.resize(G.row[V]);
  G.val.resize(G.row[V]);
  for (std::size_t v = 0; v < V; ++v) {
    for (std::size_t i = 0; i < rows[v].size(); ++i) {
      G.col[G.row[v] + i] = rows[v][i].first;
      G.val[G.row[v] + i] = rows[v][i].second;
    }
    std::vector<std::pair<std::uint32_t, float>>().swap(rows[v]);
  }

  // Bounces: T_{b+1}(v) = (rho_v / pi) sum_u G_vu T_b(u), each from the
  // previous bounce alone; the total is summed separately.
  t.direct = t.coeffs;
  double direct_energy = 0.0;
  for (float x : t.direct) direct_energy += std::abs(x);
  t.direct_energy = direct_energy / double(std::max<std::size_t>(V, 1));
  t.bounces = 0;
  std::vector<float> prev = t.coeffs, next(V * stride);
  for (int b = 1; b <= o.bounces; ++b) {
    detail::ProgressTicker bounce(progress, V, "bounces");
    tbb::parallel_for(std::size_t(0), (V + kGrain - 1) / kGrain, [&](std::size_t block) {
      std::vector<double> acc(stride);
      const std::size_t v0 = block * kGrain, v1 = std::min(V, v0 + kGrain);
      for (std::size_t v = v0; v < v1; ++v) {
        std::fill(acc.begin(), acc.end(), 0.0);
        for (std::size_t e = G.row[v]; e < G.row[v + 1]; ++e) {
          const float* src = prev.data() + std::size_t(G.col[e]) * stride;
          const double g = G.val[e];
          for (std::size_t k = 0; k < stride; ++k) acc[k] += g * src[k];
        }
        for (int c = 0; c < t.channels; ++c) {
          const double a = albedo(v, c) / M_PI;
          for (int k = 0; k < nc; ++k) next[v * stride + std::size_t(c) * nc + k] = float(a * acc[std::size_t(c) * nc + k]);
        }
      }
      bounce.tick(v1 - v0);
    });
    bounce.finish();
    double energy = 0.0;
    for (std::size_t i = 0; i < next.size(); ++i) {
      t.coeffs[i] += next[i];
      energy += std::abs(next[i]);
    }
    t.bounce_energy.push_back(energy / double(std::max<std::size_t>(V, 1)));
    t.bounces = b;
    if (o.bounce_tolerance > 0 && t.bounce_energy.back() < o.bounce_tolerance * t.direct_energy) break;
    prev.swap(next);
  }
  // An analytic vertex has no gather row (no occluded ray), so no bounce
  // added anything to it: its total is its direct part, the clamped cosine.
  if (glossy_ir) add_glossy_bounce_light(t, mesh, front_hits, Ydbl, w, progress);
  compact_transfer(t, analytic);
  return t;
}

std::vector<double> glossy_vertex_matrices(const Mesh& mesh, const TransferOptions& options,
                                           std::span<const std::uint32_t> vertices) {
  TransferOptions o = options;
  o.glossy = true;
  o.mode = TransferMode::Shadowed;
  check_options(o, mesh);
  detail::blas_single_threaded();
  for (std::uint32_t v : vertices)
    if (v >= mesh.vertex_count())
      throw Error(fmt::format("glossy matrices: vertex {} is out of range (the mesh has {})", v, mesh.vertex_count()));
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);
  const int n = o.bands, nc = n * n;
  const int M = 2 * o.samples;
  const std::vector<glm::vec3> dirs = detail::direction_set(M, o.seed);
  const double w = 4.0 * M_PI / M;
  const float offset = float(o.offset > 0 ? o.offset : detail::default_ray_offset(mesh));
  const detail::RayScene scene(mesh);
  std::vector<double> out(vertices.size() * std::size_t(nc) * nc, 0.0);
  tbb::parallel_for(std::size_t(0), vertices.size(), [&](std::size_t i) {
    detail::enable_ftz_daz();
    const std::uint32_t v = vertices[i];
    const glm::vec3 nrm = mesh.normals[v];
    if (glm::dot(nrm, nrm) == 0.0f) return;
    const glm::vec3 origin = mesh.positions[v] + offset * nrm;
    std::vector<double> Yocc, y(static_cast<std::size_t>(nc)), C(std::size_t(nc) * nc, 0.0);
    glm::vec3 batch[8];
    int count = 0;
    std::size_t occluded = 0;
    const auto flush = [&] {
      const std::uint32_t hit = scene.occluded8(origin, batch, count, offset);
      for (int k = 0; k < count; ++k)
        if (hit & (1u << k)) {
          sh::eval<double>(n, batch[k].x, batch[k].y, batch[k].z, y.data());
          Yocc.insert(Yocc.end(), y.begin(), y.end());
          ++occluded;
        }
      count = 0;
    };
    for (int j = 0; j < M; ++j) {
      if (glm::dot(dirs[j], nrm) <= 0.0f) continue;
      batch[count++] = dirs[j];
      if (count == 8) flush();
    }
    if (count) flush();
    if (occluded) rank_k_update(nc, int(occluded), w, Yocc.data(), 0.0, C.data());
    const std::vector<double> H = glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm)), n);
    double* m = out.data() + i * std::size_t(nc) * nc;
    for (int p = 0; p < nc; ++p)
      for (int q = 0; q < nc; ++q)
        m[std::size_t(p) * nc + q] = H[std::size_t(p) * nc + q] - C[std::size_t(std::min(p, q)) * nc + std::max(p, q)];
  });
  return out;
}

}  // namespace prt
