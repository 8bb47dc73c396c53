// fit_zh_transfer (prt/precompute.h): an SH transfer's rows as zonal-harmonic
// lobes in each vertex's rest frame (prt/zh_transfer.h, docs/LDPRT.md).
#include <prt/precompute.h>

#include <prt/error.h>
#include <prt/transfer_io.h>
#include <prt/zh.h>

#include "progress_ticker.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <memory>

namespace prt {

ZhTransfer fit_zh_transfer(const Transfer& t, const Mesh& mesh, const ZhFitOptions& o, const Progress& progress) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error("zonal-harmonic fit: the transfer: " + p);
  check_matches(t, mesh, "the transfer to fit");
  if (t.glossy)
    throw Error("zonal-harmonic fit: a glossy transfer's matrices have no zonal form here (fit the diffuse transfer)");
  if (t.subsurface)
    throw Error("zonal-harmonic fit: a translucent material's transfer is a sum over the whole surface, which does not "
                "follow the mesh when it bends (local deformable PRT is for diffuse transfer)");
  if (t.bands > zh::kMaxBands)
    throw Error(fmt::format("zonal-harmonic fit: {} bands; lobes carry at most {}", t.bands, zh::kMaxBands));
  if (o.lobes < 1 || o.lobes > zh::kMaxLobes)
    throw Error(fmt::format("zonal-harmonic fit: lobes must be 1 to {}, got {}", zh::kMaxLobes, o.lobes));
  if (o.rounds < 0) throw Error("zonal-harmonic fit: rounds must be at least 0");
  if (o.threads < 0 || o.threads > kMaxThreads)
    throw Error(fmt::format("zonal-harmonic fit: threads must be 0 (every core) to {}, got {}", kMaxThreads, o.threads));
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

  ZhTransfer z;
  z.header() = t.header();
  z.lobes = o.lobes;
  z.mesh_hash = mesh.hash();
  z.topology_hash = topology_hash(mesh);
  z.slots = t.slots;
  const std::size_t rows = t.stored_vertices();
  z.axes.assign(rows * z.axes_stride(), 0.0f);
  z.coeffs.assign(rows * z.coeffs_stride(), 0.0f);
  // Each stored row's vertex (rows are in vertex order).
  std::vector<std::uint32_t> vertex_of(rows);
  for (std::size_t v = 0, r = 0; v < t.vertices; ++v)
    if (!t.is_analytic(v)) vertex_of[r++] = std::uint32_t(v);

  const VertexFrames frames = vertex_frames(mesh);
  z.tangents = frames.rules;
  const int n = t.bands, K = o.lobes, C = t.channels, nc = n * n;
  zh::FitOptions fo;
  fo.lobes = K;
  fo.rounds = o.rounds;
  fo.start_rounds = std::min(fo.start_rounds, o.rounds);
  // Per row, summed in row order after: the same error for any thread count.
  std::vector<double> residual(rows, 0.0), norms(rows, 0.0);
  detail::ProgressTicker ticker(progress, rows, "zonal-harmonic fit");
  ticker.start();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows, 64), [&](const tbb::blocked_range<std::size_t>& range) {
    if (ticker.cancelled()) return;
    std::vector<double> sum(static_cast<std::size_t>(nc)), row(static_cast<std::size_t>(nc)), g(std::size_t(K) * n);
    for (std::size_t r = range.begin(); r < range.end(); ++r) {
      const std::size_t v = vertex_of[r];
      const float* src = t.coeffs.data() + r * t.stride();
      float* axes_out = z.axes.data() + r * z.axes_stride();
      float* g_out = z.coeffs.data() + r * z.coeffs_stride();
      for (int i = 0; i < K; ++i) axes_out[3 * i + 2] = 1.0f;  // +z: the lobes of a vertex without a frame
      double norm = 0;
      for (int k = 0; k < C * nc; ++k) norm += double(src[k]) * src[k];
      norms[r] = norm;
      if (frames.kinds[v] == FrameKind::None) {  // no normal: its transfer is zero, so are its lobes
        residual[r] = norm;
        continue;
      }
      for (int k = 0; k < nc; ++k) {
        double s = 0;
        for (int c = 0; c < C; ++c) s += src[c * nc + k];
        sum[std::size_t(k)] = s;
      }
      const zh::Fit fit = zh::fit_lobes(n, sum.data(), fo);
      for (int c = 0; c < C; ++c) {
        for (int k = 0; k < nc; ++k) row[std::size_t(k)] = src[c * nc + k];
        residual[r] += zh::fit_coeffs(n, K, fit.axes.data(), row.data(), g.data());
        for (int k = 0; k < K * n; ++k) g_out[c * K * n + k] = float(g[std::size_t(k)]);
      }
      // World axes into the rest frame: a_local = F^T a.
      const glm::dmat3 F(frames.frames[v]);
      for (int i = 0; i < K; ++i) {
        const glm::dvec3 a(fit.axes[3 * std::size_t(i)], fit.axes[3 * std::size_t(i) + 1], fit.axes[3 * std::size_t(i) + 2]);
        const glm::dvec3 l = glm::normalize(glm::transpose(F) * a);
        for (int c = 0; c < 3; ++c) axes_out[3 * i + c] = float(l[c]);
      }
    }
    ticker.tick(range.size());
  });
  ticker.finish();
  double res = 0, norm = 0;
  for (std::size_t r = 0; r < rows; ++r) res += residual[r], norm += norms[r];
  z.fit_error = norm > 0 ? std::sqrt(res / norm) : 0.0;
  return z;
}

}  // namespace prt
