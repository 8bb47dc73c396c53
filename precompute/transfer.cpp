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
#include "spill_store.h"
#include "transfer_impl.h"

#include <fmt/format.h>

#include <cblas.h>

#include "blas.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

namespace prt {

using detail::Source;


namespace {

void check_options(const TransferOptions& o, const Mesh& mesh) {
  if (o.bands < 1 || o.bands > kMaxTransferBands)
    throw Error(fmt::format("--bands must be between 1 and {} (prt render and prt view draw at most {} bands; transfer "
                            "accuracy is measured up to {}), got {}",
                            kMaxTransferBands, kMaxTransferBands, kMaxTransferBands, o.bands));
  if (o.samples < 1 || o.samples > kMaxSamples)
    throw Error(fmt::format("--samples must be between 1 and {}, got {}", kMaxSamples, o.samples));
  if (o.bounces < 0 || o.bounces > kMaxBounces)
    throw Error(fmt::format("--bounces must be between 0 and {}, got {}", kMaxBounces, o.bounces));
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

// Bytes a vertex's records may take at most (M directions): its gather row
// before merging (`pairs` per ray: 3 for vertices, the hit triangle's
// corners; 4 for texels, the bilinear neighbours) and its front hits (glossy
// interreflected).
std::size_t max_records_per_vertex(const TransferOptions& o, bool gather, bool glossy_ir, int pairs = 3) {
  const std::size_t M = 2 * std::size_t(o.samples);
  return (gather ? M * std::size_t(pairs) * sizeof(std::pair<std::uint32_t, float>) : 0) +
         (glossy_ir ? M * sizeof(FrontHit) : 0);
}

// Embree's ray scene (RayScene) per triangle, with a margin: the bumpy sphere
// of 2M triangles (scripts/make_scale_mesh.py-like) peaks 140 MB higher
// shadowed (1 ray) than unshadowed (no scene): 70 bytes per triangle
// (docs/PRECOMPUTE.md, "Memory").
constexpr std::size_t kRaySceneBytesPerTriangle = 96;

// How compute_transfer uses its memory on this rank: vertices per block of
// the first pass and the bytes of records it keeps in memory.
struct Plan {
  TransferMemory memory;
  std::size_t block = 4096;  // vertices per block
  std::size_t record_budget = std::numeric_limits<std::size_t>::max();
};

// P points (the mesh's vertices, or SamplePoints), `own` of them this
// rank's; `emitters`: points gathering the vertices' bounce light at once
// (compute_point_transfer) instead of keeping records.
Plan plan_memory(const Mesh& mesh, std::size_t P, const TransferOptions& o, std::size_t own, bool emitters, bool grey,
                 int pairs = 3) {
  Plan p;
  const bool trace = o.mode != TransferMode::Unshadowed;
  const bool gather = o.mode == TransferMode::Interreflected && o.bounces > 0 && !emitters;
  const bool glossy_ir = o.glossy && o.mode == TransferMode::Interreflected;
  const std::size_t V = P, nc = std::size_t(o.bands) * o.bands;
  const std::size_t stride = (grey ? 1 : 3) * nc;
  const std::size_t row = V * stride * sizeof(float);
  std::size_t gstride = 0;
  if (o.glossy) gstride = glossy_ir ? std::size_t(grey ? 1 : 3) * nc * nc : nc * (nc + 1) / 2;
  const std::size_t M = trace ? 2 * std::size_t(o.samples) : 0;
  const std::size_t threads = std::size_t(o.threads > 0 ? o.threads : tbb::this_task_arena::max_concurrency());
  std::size_t fixed = row;                                        // coeffs
  if (o.mode == TransferMode::Interreflected) fixed += row;       // direct
  if (gather) fixed += row * (o.bounces > 1 ? 2 : 1);             // the bounce buffers
  if (emitters) fixed += row + mesh.vertex_count() * stride * sizeof(float);  // the points' bounce light, the vertices' transfer
  fixed += V * (sizeof(float) + sizeof(glm::vec3) + 1);           // ao, bent normals, analytic
  fixed += V * gstride * sizeof(float);                           // glossy matrices
  fixed += (own + 1) * sizeof(std::uint64_t) * ((gather ? 1 : 0) + (glossy_ir ? 1 : 0));  // record offsets
  fixed += M * nc * (sizeof(float) + (o.glossy ? sizeof(double) : 0));  // the directions' SH tables
  fixed += trace ? mesh.triangles.size() * kRaySceneBytesPerTriangle : 0;
  fixed += threads * (M * std::size_t(pairs) * sizeof(std::pair<std::uint32_t, float>) + M * nc * sizeof(double));  // per-thread scratch
  const std::size_t per_vertex = max_records_per_vertex(o, gather, glossy_ir, pairs);
  // A block's records: the workers' output, its copy into the block, and
  // the buffer a spilled block is read back into.
  const auto workspace = [&](std::size_t block) { return 3 * block * per_vertex; };
  constexpr std::size_t kGrain = 64;  // the smallest block: one worker's grain
  p.memory.base = detail::resident_bytes();
  p.memory.fixed = fixed;
  p.memory.per_vertex_records = per_vertex;
  p.memory.minimum = p.memory.base + fixed + workspace(kGrain);
  p.record_budget = o.records_in_memory_max;
  if (o.memory_limit == 0) return p;
  if (o.memory_limit < p.memory.minimum) {
    const auto gb = [](std::size_t b) { return fmt::format("{:.2f} GB", double(b) / 1e9); };
    throw Error(fmt::format(
        "--memory-limit {}: too small for {} ({} vertices, {} triangles) with these options: the process holds {} "
        "before it starts, the ray scene and per-vertex arrays need {} whatever the limit, and a block of {} "
        "vertices {} more; the smallest limit that works is {} (--memory-limit {}M)",
        gb(o.memory_limit), mesh.source, V, mesh.triangles.size(), gb(p.memory.base), gb(fixed), kGrain,
        gb(workspace(kGrain)), gb(p.memory.minimum), (p.memory.minimum + 999999) / 1000000));
  }
  const std::size_t avail = o.memory_limit - p.memory.base - fixed;
  // A quarter of what is left for the block's workspace (at most 64k
  // vertices: more does not trace faster), the rest for records kept in memory.
  p.block = per_vertex ? std::clamp<std::size_t>(avail / 4 / std::max<std::size_t>(workspace(1), 1), kGrain, 65536) : 65536;
  p.record_budget = std::min(o.records_in_memory_max, avail - std::min(avail, workspace(p.block)));
  return p;
}

// One block of vertices' records as bytes: the workers' grains, in vertex
// order (each vertex's offsets are kept apart, in memory).
template <typename Record>
std::vector<std::uint8_t> pack(const std::vector<std::vector<Record>>& grains) {
  std::size_t n = 0;
  for (const auto& g : grains) n += g.size();
  std::vector<std::uint8_t> bytes(n * sizeof(Record));
  std::size_t at = 0;
  for (const auto& g : grains) {
    if (!g.empty()) std::memcpy(bytes.data() + at, g.data(), g.size() * sizeof(Record));
    at += g.size() * sizeof(Record);
  }
  return bytes;
}

template <typename T>
void all_gather(std::vector<T>& data, std::size_t V, const Communicator& comm) {
  if (comm.size() > 1) comm.all_gather(data.data(), rank_blocks(V, data.size() / std::max<std::size_t>(V, 1) * sizeof(T), comm));
}
template <typename T>
void gather_to_root(std::vector<T>& data, std::size_t V, const Communicator& comm) {
  if (comm.size() == 1) return;
  const std::vector<std::size_t> b = rank_blocks(V, data.size() / std::max<std::size_t>(V, 1) * sizeof(T), comm);
  comm.gather_to_root(reinterpret_cast<char*>(data.data()) + b[std::size_t(comm.rank())], data.data(), b);
}

// Interreflected glossy: M_p[c] += w sum_front hits Y(s) T_q[c]^T, T_q the
// final diffuse transfer (`vertex_rows`, t.coeffs' rows for every mesh vertex) at the hit point by
// its barycentric coordinates; per vertex one BLAS product
// (nc x H) (H x channels nc). Vertices [v0, v0 + offsets.size() - 1), their
// hits in `store`'s blocks (block b of `blocks` vertices).
void add_glossy_bounce_light(Transfer& t, const float* vertex_rows, const Mesh& mesh, const detail::SpillStore& store,
                             const std::vector<std::uint64_t>& offsets, std::size_t v0, std::size_t block,
                             const std::vector<double>& Y, double w, const Progress& progress) {
  const std::size_t nc = std::size_t(t.bands) * t.bands, stride = t.stride();
  const std::size_t gstride = t.glossy_stride(), own = offsets.size() - 1;
  detail::ProgressTicker ticker(progress, own, "glossy bounce light");
  constexpr std::size_t kGrain = 64;
  std::vector<std::uint8_t> buffer;
  for (std::size_t b = 0; b * block < own; ++b) {
    const std::size_t b0 = b * block, b1 = std::min(own, b0 + block);
    const auto* hits_of_block = reinterpret_cast<const FrontHit*>(store.get(2 * b + 1, buffer));
    tbb::parallel_for(std::size_t(0), (b1 - b0 + kGrain - 1) / kGrain, [&](std::size_t grain) {
      if (ticker.cancelled()) return;
      std::vector<double> Yh, Th, B(nc * stride);
      const std::size_t g0 = b0 + grain * kGrain, g1 = std::min(b1, g0 + kGrain);
      for (std::size_t i = g0; i < g1; ++i) {
        const std::size_t H = std::size_t(offsets[i + 1] - offsets[i]);
        if (H == 0) continue;
        const FrontHit* hits = hits_of_block + (offsets[i] - offsets[b0]);
        Yh.resize(H * nc);
        Th.assign(H * stride, 0.0);
        for (std::size_t h = 0; h < H; ++h) {
          std::copy_n(Y.begin() + std::ptrdiff_t(hits[h].dir * nc), nc, Yh.begin() + std::ptrdiff_t(h * nc));
          const glm::uvec3 tri = mesh.triangles[hits[h].triangle];
          const double bc[3] = {1.0 - hits[h].u - hits[h].v, hits[h].u, hits[h].v};
          double* th = Th.data() + h * stride;
          for (int c = 0; c < 3; ++c) {
            const float* src = vertex_rows + std::size_t(tri[c]) * stride;
            for (std::size_t k = 0; k < stride; ++k) th[k] += bc[c] * src[k];
          }
        }
        cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, int(nc), int(stride), int(H), w, Yh.data(), int(nc),
                    Th.data(), int(stride), 0.0, B.data(), int(stride));
        float* g = t.glossy_matrices.data() + (v0 + i) * gstride;
        for (int c = 0; c < t.channels; ++c)
          for (std::size_t p = 0; p < nc; ++p)
            for (std::size_t q = 0; q < nc; ++q)
              g[std::size_t(c) * nc * nc + p * nc + q] =
                  float(double(g[std::size_t(c) * nc * nc + p * nc + q]) + B[p * stride + std::size_t(c) * nc + q]);
      }
      ticker.tick(g1 - g0);
    });
  }
  ticker.finish();
}

}  // namespace

std::size_t resident_memory() { return detail::resident_bytes(); }

std::size_t default_memory_limit(int processes_here) {
  return std::size_t(0.8 * double(detail::machine_memory_bytes()) / double(std::max(processes_here, 1)));
}

TransferMemory transfer_memory(const Mesh& mesh, const TransferOptions& o) {
  check_options(o, mesh);
  const Communicator& comm = o.comm ? *o.comm : single_process();
  const std::size_t V = mesh.vertex_count();
  TransferOptions unlimited = o;
  unlimited.memory_limit = 0;
  const bool grey = !o.vertex_colors && o.albedo.x == o.albedo.y && o.albedo.y == o.albedo.z;
  return plan_memory(mesh, V, unlimited,
                     range_begin(V, comm.rank() + 1, comm.size()) - range_begin(V, comm.rank(), comm.size()), false, grey)
      .memory;
}

TransferMemory detail::point_transfer_memory(const Mesh& mesh, std::size_t points, const TransferOptions& o, bool grey,
                                             int pairs) {
  const Communicator& comm = o.comm ? *o.comm : single_process();
  TransferOptions unlimited = o;
  unlimited.memory_limit = 0;
  return plan_memory(mesh, points, unlimited,
                     range_begin(points, comm.rank() + 1, comm.size()) - range_begin(points, comm.rank(), comm.size()),
                     false, grey, pairs)
      .memory;
}

namespace {

// compute_transfer at `src` (the vertices: the transfer file's layout), or
// at other points. `emitters` (points, interreflected): every vertex's dense
// transfer of bounces - 1 bounces, gathered once at each point's front hits
// instead of keeping records. `keep_everywhere`: every rank returns the
// whole, uncompacted transfer (compute_point_transfer's vertex pass).
Transfer compute_impl(const Mesh& mesh, const Source& src, const TransferOptions& o, const Progress& progress,
                      const std::vector<float>* emitters, int emitter_channels, bool keep_everywhere) {
  const Communicator& comm = o.comm ? *o.comm : single_process();
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

  const int n = o.bands, nc = sh::num_coeffs(n);
  const std::size_t V = src.count;
  // This rank's points: [r0, r1).
  const std::size_t r0 = range_begin(V, comm.rank(), comm.size()), r1 = range_begin(V, comm.rank() + 1, comm.size());
  const std::size_t own = r1 - r0;
  const bool grey = !src.albedo && !o.vertex_colors && o.albedo.x == o.albedo.y && o.albedo.y == o.albedo.z;
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
  const Albedo vertex_albedo{o, mesh};
  const auto albedo = [&](std::size_t v, int c) {
    return src.albedo ? src.albedo[v][c] : src.vertices ? vertex_albedo(v, c) : o.albedo[c];
  };

  const bool trace = o.mode != TransferMode::Unshadowed;
  const bool gather = o.mode == TransferMode::Interreflected && o.bounces > 0 && !emitters;
  const bool glossy = o.glossy;
  const bool glossy_ir = glossy && o.mode == TransferMode::Interreflected;
  const bool want_hits = gather || glossy_ir || emitters;
  // Checked before any ray: throws for a limit below the minimum.
  const Plan plan = plan_memory(mesh, V, o, own, emitters != nullptr, grey, src.hit_points ? 4 : 3);
  // Points: the light the vertices they see reflect onto them (one gather
  // of the vertices' transfer per front hit, scaled as the direct part).
  std::vector<float> bounce_light(emitters ? V * stride : 0, 0.0f);

  // The direct transfer: albedo times S, the geometry-only transfer (one
  // channel), S_k = (1/pi) integral V cos+ Y_k, written per vertex.
  std::vector<double> A = sh::clamped_cosine_factors(n);
  t.coeffs.assign(V * stride, 0.0f);
  t.ao.assign(V, 1.0f);
  t.bent_normals.assign(src.normals, src.normals + V);

  if (glossy) detail::blas_single_threaded();
  t.glossy = glossy;
  const std::size_t gstride = glossy ? t.glossy_stride() : 0;
  if (glossy) t.glossy_matrices.assign(V * gstride, 0.0f);

  const int M = 2 * o.samples;
  const std::vector<glm::vec3> dirs = trace ? detail::direction_set(M, o.seed) : std::vector<glm::vec3>{};
  std::vector<float> Ytab(trace ? std::size_t(M) * nc : 0);
  for (int j = 0; j < (trace ? M : 0); ++j) sh::eval<float>(n, dirs[j].x, dirs[j].y, dirs[j].z, Ytab.data() + std::size_t(j) * nc);
  // Glossy: the basis in double (the products of the matrices sum many rays).
  std::vector<double> Ydbl(glossy ? std::size_t(M) * nc : 0);
  for (int j = 0; j < (glossy ? M : 0); ++j) sh::eval<double>(n, dirs[j].x, dirs[j].y, dirs[j].z, Ydbl.data() + std::size_t(j) * nc);
  const double w = 4.0 * M_PI / M;
  const float offset = float(o.offset > 0 ? o.offset : detail::default_ray_offset(mesh));

  std::unique_ptr<detail::RayScene> own_scene;
  if (trace && !src.scene) own_scene = std::make_unique<detail::RayScene>(mesh);
  const detail::RayScene* scene = src.scene ? src.scene : own_scene.get();
  // Vertices with a normal and no occluded ray: their transfer is the
  // analytic clamped cosine, stored by no one (compact_transfer below).
  std::vector<std::uint8_t> analytic(V, 0);
  // The records of this rank's vertices, a block of plan.block vertices at
  // a time: block b's gather rows (the sparse gather matrix G, receiver
  // vertex x emitting vertex, weight w cos barycentric, merged per emitter)
  // in store block 2b, its front hits (glossy interreflected) in 2b + 1;
  // per vertex the offsets of its records.
  detail::SpillStore store(plan.record_budget);
  std::vector<std::uint64_t> grow(want_hits && gather ? own + 1 : 0, 0), frow(glossy_ir ? own + 1 : 0, 0);
  using Entry = std::pair<std::uint32_t, float>;

  detail::ProgressTicker first(progress, own, trace ? "rays" : "transfer");
  constexpr std::size_t kGrain = 64;
  for (std::size_t b0 = 0; b0 < own; b0 += plan.block) {
    const std::size_t b1 = std::min(own, b0 + plan.block), grains = (b1 - b0 + kGrain - 1) / kGrain;
    std::vector<std::vector<Entry>> grain_rows(gather ? grains : 0);
    std::vector<std::vector<FrontHit>> grain_hits(glossy_ir ? grains : 0);
    tbb::parallel_for(std::size_t(0), grains, [&](std::size_t grain) {
      detail::enable_ftz_daz();
      if (first.cancelled()) return;
      std::vector<double> Yn(nc), occ(nc);
      std::vector<double> Yocc, C(glossy ? std::size_t(nc) * nc : 0);  // glossy: the occluded rays' Y, and w Yocc^T Yocc
      std::vector<Entry> r;
      std::vector<float> s(nc);  // S of the vertex
      std::vector<double> eacc(emitters ? stride : 0);  // points: sum of w cos barycentric T_vertex over front hits
      glm::vec3 batch[8];
      int batch_j[8];
      detail::Hit hits[8];
      const std::size_t i0 = b0 + grain * kGrain, i1 = std::min(b1, i0 + kGrain);
      for (std::size_t i = i0; i < i1; ++i) {
        const std::size_t v = r0 + i;
        const glm::vec3 nrm = src.normals[v];
        if (glm::dot(nrm, nrm) == 0.0f) {  // unreferenced or no normal: no transfer
          t.ao[v] = 0.0f;
          if (gather) grow[i + 1] = grain_rows[grain].size();
          if (glossy_ir) frow[i + 1] = grain_hits[grain].size();
          continue;
        }
        sh::eval<double>(n, nrm.x, nrm.y, nrm.z, Yn.data());
        const auto write_direct = [&] {
          for (int c = 0; c < t.channels; ++c) {
            const float a = albedo(v, c);
            for (int k = 0; k < nc; ++k) t.coeffs[v * stride + std::size_t(c) * nc + k] = a * s[k];
          }
        };
        if (!trace) {
          analytic[v] = 1;
          for (int l = 0; l < n; ++l)
            for (int m = -l; m <= l; ++m) s[sh::index(l, m)] = float(A[l] * Yn[sh::index(l, m)] / M_PI);
          write_direct();
          continue;
        }
        std::fill(occ.begin(), occ.end(), 0.0);
        Yocc.clear();
        r.clear();
        std::size_t occluded_rays = 0;
        double occ_cos = 0.0;
        glm::dvec3 occ_dir(0.0);
        const glm::vec3 origin = src.positions[v] + offset * nrm;
        if (emitters) std::fill(eacc.begin(), eacc.end(), 0.0);
        auto row_of = [&](int count) {
          // Occluded directions of this batch: subtract their cosine-weighted
          // basis; record front hits for the bounce gather.
          std::uint32_t occluded = 0;
          if (want_hits) {
            scene->intersect8(origin, batch, count, offset, hits);
            for (int k = 0; k < count; ++k) occluded |= hits[k].hit() ? 1u << k : 0u;
          } else {
            occluded = scene->occluded8(origin, batch, count, offset);
          }
          for (int k = 0; k < count; ++k) {
            if (!(occluded & (1u << k))) continue;
            ++occluded_rays;
            const int j = batch_j[k];
            const double wc = w * glm::dot(nrm, dirs[j]);
            const float* y = Ytab.data() + std::size_t(j) * nc;
            for (int q = 0; q < nc; ++q) occ[q] += wc * y[q];
            occ_cos += wc;
            occ_dir += wc * glm::dvec3(dirs[j]);
            if (glossy) Yocc.insert(Yocc.end(), Ydbl.begin() + std::ptrdiff_t(j) * nc, Ydbl.begin() + std::ptrdiff_t(j + 1) * nc);
            if (glossy_ir && hits[k].front)
              grain_hits[grain].push_back({std::uint32_t(j), hits[k].triangle, hits[k].u, hits[k].v});
            if (emitters && hits[k].front) {
              const glm::uvec3 tri = mesh.triangles[hits[k].triangle];
              const float bc[3] = {1.0f - hits[k].u - hits[k].v, hits[k].u, hits[k].v};
              const std::size_t estride = std::size_t(emitter_channels) * nc;
              for (int c = 0; c < 3; ++c) {
                const double wb = double(float(wc) * bc[c]);
                const float* e = emitters->data() + std::size_t(tri[c]) * estride;
                for (int ch = 0; ch < t.channels; ++ch) {
                  const float* ec = e + (emitter_channels == 1 ? 0 : std::size_t(ch) * nc);
                  for (int q = 0; q < nc; ++q) eacc[std::size_t(ch) * nc + q] += wb * ec[q];
                }
              }
            }
            if (gather && hits[k].front) {
              if (src.hit_points) {  // points (texels): those around the hit's lightmap UV
                std::uint32_t idx[4];
                float wt[4];
                const int np = src.hit_points->points(hits[k].triangle, hits[k].u, hits[k].v, idx, wt);
                for (int q = 0; q < np; ++q) r.emplace_back(idx[q], float(wc) * wt[q]);
              } else {
                const glm::uvec3 tri = mesh.triangles[hits[k].triangle];
                const float bc[3] = {1.0f - hits[k].u - hits[k].v, hits[k].u, hits[k].v};
                for (int c = 0; c < 3; ++c) r.emplace_back(tri[c], float(wc) * bc[c]);
              }
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
              const int a = std::min(p, q), bq = std::max(p, q);
              const double value = H[std::size_t(p) * nc + q] - C[std::size_t(a) * nc + bq];
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
        write_direct();
        if (emitters)  // (rho / pi) scale sum w cos b T_vertex: bounce b at the point is bounce b - 1 at the vertices
          for (int c = 0; c < t.channels; ++c) {
            const double a = albedo(v, c) / M_PI * scale;
            for (int k = 0; k < nc; ++k)
              bounce_light[v * stride + std::size_t(c) * nc + k] = float(a * eacc[std::size_t(c) * nc + k]);
          }
        t.ao[v] = float(std::clamp(1.0 - scale * occ_cos / M_PI, 0.0, 1.0));
        const glm::dvec3 bent = (2.0 * M_PI / 3.0) * glm::dvec3(nrm) - scale * occ_dir;
        const double len = glm::length(bent);
        t.bent_normals[v] = len > 0 ? glm::vec3(bent / len) : nrm;
        if (gather) {  // merge duplicate emitters, in a fixed order; same scale as above
          for (auto& e : r) e.second = float(scale * e.second);
          std::sort(r.begin(), r.end(), [](auto& a, auto& b) { return a.first < b.first; });
          std::size_t out = 0;
          for (std::size_t q = 0; q < r.size(); ++q) {
            if (out > 0 && r[out - 1].first == r[q].first)
              r[out - 1].second += r[q].second;
            else
              r[out++] = r[q];
          }
          auto& rows = grain_rows[grain];
          rows.insert(rows.end(), r.begin(), r.begin() + std::ptrdiff_t(out));
          grow[i + 1] = rows.size();  // within the grain; made global below
        }
        if (glossy_ir) frow[i + 1] = grain_hits[grain].size();
      }
      first.tick(i1 - i0);
    });
    if (first.cancelled()) break;
    // Offsets: the grains' counts made cumulative over the whole range.
    for (std::size_t grain = 0; grain < grains; ++grain) {
      const std::size_t i0 = b0 + grain * kGrain, i1 = std::min(b1, i0 + kGrain);
      if (gather) {
        const std::uint64_t base = grow[i0];
        for (std::size_t i = i0; i < i1; ++i) grow[i + 1] += base;
      }
      if (glossy_ir) {
        const std::uint64_t base = frow[i0];
        for (std::size_t i = i0; i < i1; ++i) frow[i + 1] += base;
      }
    }
    // G block: the emitters, then the weights.
    std::vector<std::uint8_t> g;
    if (gather) {
      std::size_t nnz = 0;
      for (const auto& rows : grain_rows) nnz += rows.size();
      g.resize(nnz * (sizeof(std::uint32_t) + sizeof(float)));
      auto* col = reinterpret_cast<std::uint32_t*>(g.data());
      auto* val = reinterpret_cast<float*>(g.data() + nnz * sizeof(std::uint32_t));
      std::size_t at = 0;
      for (auto& rows : grain_rows) {
        for (const Entry& e : rows) {
          col[at] = e.first;
          val[at++] = e.second;
        }
        std::vector<Entry>().swap(rows);
      }
    }
    store.append(std::move(g));
    store.append(glossy_ir ? pack(grain_hits) : std::vector<std::uint8_t>{});
  }
  first.finish();
  own_scene.reset();
  scene = nullptr;
  if (o.memory_report) {
    *o.memory_report = plan.memory;
    o.memory_report->block = plan.block;
    o.memory_report->records_in_memory = store.held_bytes();
    o.memory_report->records_spilled = store.spilled_bytes();
  }
  t.shading_hash = shading_hash(mesh, o.vertex_colors);

  // Every rank needs every vertex's direct transfer for the bounces and the
  // glossy bounce light; rank 0 the rest for the file.
  if (gather || glossy_ir || keep_everywhere) all_gather(t.coeffs, V, comm);
  else gather_to_root(t.coeffs, V, comm);
  gather_to_root(t.ao, V, comm);
  gather_to_root(t.bent_normals, V, comm);
  if (keep_everywhere) all_gather(analytic, V, comm);
  else gather_to_root(analytic, V, comm);
  if (src.analytic_out) *src.analytic_out = analytic;
  if (emitters) gather_to_root(bounce_light, V, comm);

  const auto finish = [&]() {
    if (glossy_ir) {
      std::vector<float> dense;
      if (src.expand) (*src.expand)(t.coeffs, dense, true);
      add_glossy_bounce_light(t, src.expand ? dense.data() : t.coeffs.data(), mesh, store, frow, r0, plan.block, Ydbl,
                              w, progress);
    }
    if (glossy) gather_to_root(t.glossy_matrices, V, comm);
    if (keep_everywhere) return std::move(t);
    if (comm.rank() != 0) return Transfer{};
    // Vertices: analytic rows are dropped (relight evaluates them from the
    // mesh's normals). Points keep every row: no mesh normal is theirs.
    if (src.vertices || src.compact) compact_transfer(t, analytic);
    return std::move(t);
  };
  if (emitters) {  // points: the direct part, plus the vertices' light gathered above
    t.direct = t.coeffs;
    for (std::size_t i = 0; i < t.coeffs.size(); ++i) t.coeffs[i] += bounce_light[i];
    return finish();
  }
  if (!gather) {
    if (o.mode == TransferMode::Interreflected) t.direct = t.coeffs;
    return finish();
  }

  // Bounces: T_{b+1}(v) = (rho_v / pi) sum_u G_vu T_b(u), each from the
  // previous bounce alone; the total is summed separately. Each rank
  // computes its vertices, then all of them are exchanged.
  t.direct = t.coeffs;
  double direct_energy = 0.0;
  for (float x : t.direct) direct_energy += std::abs(x);
  t.direct_energy = direct_energy / double(std::max<std::size_t>(V, 1));
  t.bounces = 0;
  std::vector<float> next(V * stride), other(o.bounces > 1 ? V * stride : 0);
  const std::vector<float>* prev = &t.direct;
  std::vector<std::uint8_t> buffer;
  std::vector<float> vertex_rows;  // with expand: every mesh vertex's row of the previous bounce
  for (int b = 1; b <= o.bounces; ++b) {
    if (src.expand) (*src.expand)(*prev, vertex_rows, b == 1);
    const float* emitting = src.expand ? vertex_rows.data() : prev->data();
    detail::ProgressTicker bounce(progress, own, "bounces");
    for (std::size_t blk = 0; blk * plan.block < own; ++blk) {
      const std::size_t b0 = blk * plan.block, b1 = std::min(own, b0 + plan.block);
      const std::uint8_t* bytes = store.get(2 * blk, buffer);
      const std::size_t nnz = std::size_t(grow[b1] - grow[b0]);
      const auto* col = reinterpret_cast<const std::uint32_t*>(bytes);
      const auto* val = reinterpret_cast<const float*>(bytes + nnz * sizeof(std::uint32_t));
      tbb::parallel_for(std::size_t(0), (b1 - b0 + kGrain - 1) / kGrain, [&](std::size_t grain) {
        std::vector<double> acc(stride);
        const std::size_t i0 = b0 + grain * kGrain, i1 = std::min(b1, i0 + kGrain);
        for (std::size_t i = i0; i < i1; ++i) {
          const std::size_t v = r0 + i;
          std::fill(acc.begin(), acc.end(), 0.0);
          for (std::size_t e = grow[i] - grow[b0]; e < grow[i + 1] - grow[b0]; ++e) {
            const float* emitter = emitting + std::size_t(col[e]) * stride;
            const double gv = val[e];
            for (std::size_t k = 0; k < stride; ++k) acc[k] += gv * emitter[k];
          }
          for (int c = 0; c < t.channels; ++c) {
            const double a = albedo(v, c) / M_PI;
            for (int k = 0; k < nc; ++k) next[v * stride + std::size_t(c) * nc + k] = float(a * acc[std::size_t(c) * nc + k]);
          }
        }
        bounce.tick(i1 - i0);
      });
      if (bounce.cancelled()) break;
    }
    bounce.finish();
    all_gather(next, V, comm);
    double energy = 0.0;
    for (std::size_t i = 0; i < next.size(); ++i) {
      t.coeffs[i] += next[i];
      energy += std::abs(next[i]);
    }
    t.bounce_energy.push_back(energy / double(std::max<std::size_t>(V, 1)));
    t.bounces = b;
    if (o.bounce_tolerance > 0 && t.bounce_energy.back() < o.bounce_tolerance * t.direct_energy) break;
    if (b < o.bounces) {
      other.swap(next);  // the bounce just computed is the next one's source
      prev = &other;
    }
  }
  std::vector<float>().swap(next);
  std::vector<float>().swap(other);
  // An analytic vertex has no gather row (no occluded ray), so no bounce
  // added anything to it: its total is its direct part, the clamped cosine.
  return finish();
}

}  // namespace

void detail::check_transfer_options(const TransferOptions& o, const Mesh& mesh) { check_options(o, mesh); }

Transfer detail::compute_at(const Mesh& mesh, const Source& src, const TransferOptions& o, const Progress& progress,
                            bool keep_everywhere) {
  check_options(o, mesh);
  return compute_impl(mesh, src, o, progress, nullptr, 0, keep_everywhere);
}

Transfer compute_transfer(const Mesh& mesh, const TransferOptions& o, const Progress& progress) {
  check_options(o, mesh);
  Source vertices;
  vertices.positions = mesh.positions.data();
  vertices.normals = mesh.normals.data();
  vertices.count = mesh.vertex_count();
  return compute_impl(mesh, vertices, o, progress, nullptr, 0, false);
}

Transfer compute_point_transfer(const Mesh& mesh, const SamplePoints& points, const TransferOptions& o,
                                const Progress& progress) {
  check_options(o, mesh);
  if (o.glossy) throw Error("glossy transfer is computed at the mesh's vertices only (compute_transfer)");
  const std::size_t P = points.positions.size();
  if (points.normals.size() != P || (!points.albedo.empty() && points.albedo.size() != P))
    throw Error(fmt::format("sample points: {} positions, {} normals and {} albedos (expected as many normals, and as "
                            "many albedos or none)",
                            P, points.normals.size(), points.albedo.size()));
  for (std::size_t i = 0; i < P; ++i) {
    const glm::vec3 p = points.positions[i], nrm = points.normals[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || std::abs(p.x) > kMaxCoordinate ||
        std::abs(p.y) > kMaxCoordinate || std::abs(p.z) > kMaxCoordinate)
      throw Error(fmt::format("sample point {}: position ({}, {}, {}) is not finite or beyond {:g}", i, p.x, p.y, p.z,
                              kMaxCoordinate));
    const float len2 = glm::dot(nrm, nrm);
    if (!(len2 == 0.0f || std::abs(len2 - 1.0f) < 1e-3f))
      throw Error(fmt::format("sample point {}: normal ({}, {}, {}) is neither unit length nor zero", i, nrm.x, nrm.y,
                              nrm.z));
    for (int c = 0; c < 3; ++c)
      if (!points.albedo.empty() && !(points.albedo[i][c] >= 0.0f && points.albedo[i][c] <= 1.0f))
        throw Error(fmt::format("sample point {}: albedo {} is outside [0, 1]", i, points.albedo[i][c]));
  }
  Source src;
  src.positions = points.positions.data();
  src.normals = points.normals.data();
  src.count = P;
  src.albedo = points.albedo.empty() ? nullptr : points.albedo.data();
  src.vertices = false;
  if (o.mode != TransferMode::Interreflected || o.bounces == 0) return compute_impl(mesh, src, o, progress, nullptr, 0, false);
  // The vertices first, bounces - 1 bounces, dense on every rank; then the
  // points, each gathering the vertices' total once.
  Source vertices;
  vertices.positions = mesh.positions.data();
  vertices.normals = mesh.normals.data();
  vertices.count = mesh.vertex_count();
  TransferOptions vo = o;
  vo.bounces = o.bounces - 1;
  vo.bounce_tolerance = 0;
  vo.memory_report = nullptr;
  const Transfer vt = compute_impl(mesh, vertices, vo, progress, nullptr, 0, true);
  return compute_impl(mesh, src, o, progress, &vt.coeffs, vt.channels, false);
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
