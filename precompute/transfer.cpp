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
#include <prt/probes.h>
#include <prt/sh.h>
#include <prt/subsurface.h>

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
#include <glm/gtc/packing.hpp>
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
  if (o.tracer && o.comm && o.comm->size() > 1)
    throw Error("--device gpu runs in one process (one process drives the GPU): run it without mpirun, or use "
                "--device cpu under mpirun");
  if (o.directional) {
    if (o.glossy) throw Error("--directional keeps a lightmap's L1 rows; --material glossy a vertex's whole matrices: one of them");
    if (o.mode == TransferMode::Unshadowed)
      throw Error("--directional needs --mode shadowed or interreflected (an unshadowed texel's rows are its "
                  "hemisphere's, computed at run time)");
    if (o.bands < 2) throw Error("--directional needs --bands 2 or more (the L1 of the light reaches band 1)");
    if (o.light_bounce)
      throw Error("--directional and --light-bounce: the directional rows carry the environment's light only, not "
                  "the lights' bounce; precompute them apart");
    if (o.transmission_eta != 0) throw Error("--directional: a translucent lightmap has no directional rows");
  }
  if (o.light_bounce) {
    if (o.mode != TransferMode::Interreflected || o.bounces < 1)
      throw Error("--light-bounce keeps the interreflected pass's gather: it needs --mode interreflected and --bounces 1 "
                  "or more");
    if (o.glossy) throw Error("--light-bounce: the lights bounce off diffuse surfaces; a glossy transfer keeps no operator");
    if (o.comm && o.comm->size() > 1)
      throw Error("--light-bounce runs in one process: its operator is made of every point's gather row at once (run "
                  "it without mpirun)");
    if (!(o.light_bounce_patch >= 0) || !std::isfinite(o.light_bounce_patch))
      throw Error(fmt::format("--bounce-patch must be a finite size >= 0, got {}", o.light_bounce_patch));
    if (!(o.light_bounce_ratio > 0) || !std::isfinite(o.light_bounce_ratio))
      throw Error(fmt::format("--bounce-ratio must be a finite number > 0, got {}", o.light_bounce_ratio));
    if (o.light_bounce_clusters < -1 || o.light_bounce_clusters >= kMaxPatchLevels)
      throw Error(fmt::format("--bounce-clusters must be -1 (none) to {}, got {}", kMaxPatchLevels - 1,
                              o.light_bounce_clusters));
  }
  // Before any ray: the probe rows' grid (LightBounce::ProbeRows).
  if (o.light_bounce_probes != std::array<int, 3>{0, 0, 0}) {
    if (!o.light_bounce) throw Error("--probes with a transfer: the light-bounce operator's probe rows need --light-bounce");
    if (const std::string p = probe_dims_problem(o.light_bounce_probes); !p.empty()) throw Error("--probes: " + p);
  }
  if (o.transmission_eta != 0) {
    if (!(o.transmission_eta >= 1 && o.transmission_eta <= 3))
      throw Error(fmt::format("the relative index of refraction must be 1 to 3, got {}", o.transmission_eta));
    if (o.mode == TransferMode::Unshadowed || o.glossy || o.light_bounce)
      throw Error("a transmitted-irradiance transfer (subsurface) is shadowed or interreflected, not glossy, with no "
                  "light-bounce operator");
    if (o.mode == TransferMode::Interreflected && !o.between_bounces)
      throw Error("an interreflected transmitted-irradiance transfer bounces exit radiance: it needs between_bounces "
                  "(compute_subsurface_transfer)");
  }
  if (o.between_bounces && !(o.transmission_eta > 0))
    throw Error("between_bounces is a translucent material's surface integral: it needs transmission_eta");
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
  const bool glossy_ir = (o.glossy || o.directional) && o.mode == TransferMode::Interreflected;
  const std::size_t V = P, nc = std::size_t(o.bands) * o.bands;
  const std::size_t stride = (grey ? 1 : 3) * nc;
  const std::size_t row = V * stride * sizeof(float);
  Transfer shape;  // the matrices' layout, as compute_impl will make them (glossy_stride)
  shape.bands = o.bands;
  shape.channels = grey ? 1 : 3;
  shape.mode = o.mode;
  shape.glossy_rows = o.directional ? kDirectionalRows : 0;
  const std::size_t gstride = o.glossy || o.directional ? shape.glossy_stride() : 0;
  const std::size_t M = trace ? 2 * std::size_t(o.samples) : 0;
  const std::size_t threads = std::size_t(o.threads > 0 ? o.threads : tbb::this_task_arena::max_concurrency());
  std::size_t fixed = row;                                        // coeffs
  if (o.mode == TransferMode::Interreflected) fixed += row;       // direct
  if (gather) fixed += row * (o.bounces > 1 ? 2 : 1);             // the bounce buffers
  if (emitters) fixed += row + mesh.vertex_count() * stride * sizeof(float);  // the points' bounce light, the vertices' transfer
  fixed += V * (sizeof(float) + sizeof(glm::vec3) + 1);           // ao, bent normals, analytic
  fixed += V * sizeof(std::uint32_t);                             // the slots of the analytic rows' compaction
  fixed += V * gstride * sizeof(float);                           // glossy matrices
  fixed += (own + 1) * sizeof(std::uint64_t) * ((gather ? 1 : 0) + (glossy_ir ? 1 : 0));  // record offsets
  fixed += M * nc * (sizeof(float) + (o.glossy || o.directional ? sizeof(double) : 0));  // the directions' SH tables
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
// its barycentric coordinates (`hit_points`, texels: the texels around the
// hit's lightmap UV, whose rows `vertex_rows` then are); per vertex one BLAS product
// (rows x H) (H x channels nc), rows = the matrices' (t.glossy_row_count()).
// Vertices [v0, v0 + offsets.size() - 1), their
// hits in `store`'s blocks (block b of `blocks` vertices).
void add_glossy_bounce_light(Transfer& t, const float* vertex_rows, const Mesh& mesh,
                             const detail::HitToPoint* hit_points, const detail::SpillStore& store,
                             const std::vector<std::uint64_t>& offsets, std::size_t v0, std::size_t block,
                             const std::vector<double>& Y, double w, const Progress& progress) {
  const std::size_t nc = std::size_t(t.bands) * t.bands, stride = t.stride(), rows = t.glossy_row_count();
  const std::size_t gstride = t.glossy_stride(), own = offsets.size() - 1;
  detail::ProgressTicker ticker(progress, own, "glossy bounce light");
  constexpr std::size_t kGrain = 64;
  std::vector<std::uint8_t> buffer;
  for (std::size_t b = 0; b * block < own; ++b) {
    const std::size_t b0 = b * block, b1 = std::min(own, b0 + block);
    const auto* hits_of_block = reinterpret_cast<const FrontHit*>(store.get(2 * b + 1, buffer));
    tbb::parallel_for(std::size_t(0), (b1 - b0 + kGrain - 1) / kGrain, [&](std::size_t grain) {
      if (ticker.cancelled()) return;
      std::vector<double> Yh, Th, B(rows * stride);
      const std::size_t g0 = b0 + grain * kGrain, g1 = std::min(b1, g0 + kGrain);
      for (std::size_t i = g0; i < g1; ++i) {
        const std::size_t H = std::size_t(offsets[i + 1] - offsets[i]);
        if (H == 0) continue;
        const FrontHit* hits = hits_of_block + (offsets[i] - offsets[b0]);
        Yh.resize(H * nc);
        Th.assign(H * stride, 0.0);
        for (std::size_t h = 0; h < H; ++h) {
          std::copy_n(Y.begin() + std::ptrdiff_t(hits[h].dir * nc), nc, Yh.begin() + std::ptrdiff_t(h * nc));
          double* th = Th.data() + h * stride;
          std::uint32_t idx[4];
          float wt[4];
          int np = 0;
          if (hit_points) {
            np = hit_points->points(hits[h].triangle, hits[h].u, hits[h].v, idx, wt);
          } else {
            const glm::uvec3 tri = mesh.triangles[hits[h].triangle];
            np = 3;
            std::copy_n(&tri.x, 3, idx);
            wt[0] = 1.0f - hits[h].u - hits[h].v, wt[1] = hits[h].u, wt[2] = hits[h].v;
          }
          for (int c = 0; c < np; ++c) {
            const float* src = vertex_rows + std::size_t(idx[c]) * stride;
            for (std::size_t k = 0; k < stride; ++k) th[k] += double(wt[c]) * src[k];
          }
        }
        // Y^T's first `rows` rows: Yh is H x nc, its first `rows` columns.
        cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, int(rows), int(stride), int(H), w, Yh.data(), int(nc),
                    Th.data(), int(stride), 0.0, B.data(), int(stride));
        float* g = t.glossy_matrices.data() + (v0 + i) * gstride;
        for (int c = 0; c < t.channels; ++c)
          for (std::size_t p = 0; p < rows; ++p)
            for (std::size_t q = 0; q < nc; ++q)
              g[std::size_t(c) * rows * nc + p * nc + q] =
                  float(double(g[std::size_t(c) * rows * nc + p * nc + q]) + B[p * stride + std::size_t(c) * nc + q]);
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
  const bool grey = !o.vertex_colors && o.albedo.x == o.albedo.y && o.albedo.y == o.albedo.z && !o.between_bounces;
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

// Points per worker task in compute_impl's passes.
constexpr std::size_t kWorkerGrain = 64;
// Directional rows: rays with cos below this are "near the horizon", where
// the direction set's hemisphere quadrature has its error.
constexpr float kHorizonBand = 0.25f;

using Entry = std::pair<std::uint32_t, float>;  // a gather row's (emitting point, weight)

// What compute_impl's phases share: the inputs, what the options ask for,
// the memory plan, the direction set's tables and the ray scene.
struct Run {
  Run(const Mesh& m, const Source& s, const TransferOptions& opts, const Progress& p,
      const std::vector<float>* emitting, int emitting_channels)
      : mesh(m), src(s), o(opts), progress(p), comm(opts.comm ? *opts.comm : single_process()), emitters(emitting),
        emitter_channels(emitting_channels), n(opts.bands), nc(sh::num_coeffs(opts.bands)), V(s.count),
        r0(range_begin(V, comm.rank(), comm.size())), own(range_begin(V, comm.rank() + 1, comm.size()) - r0),
        grey(!s.albedo && !opts.vertex_colors && opts.albedo.x == opts.albedo.y && opts.albedo.y == opts.albedo.z &&
             !opts.between_bounces),
        trace(opts.mode != TransferMode::Unshadowed),
        gather(opts.mode == TransferMode::Interreflected && opts.bounces > 0 && !emitting),
        glossy(opts.glossy || opts.directional),
        glossy_ir(glossy && opts.mode == TransferMode::Interreflected), grows(opts.directional ? kDirectionalRows : nc),
        want_hits(gather || glossy_ir || emitting), channels(grey ? 1 : 3), vertex_albedo{opts, m} {}

  const Mesh& mesh;
  const Source& src;
  const TransferOptions& o;
  const Progress& progress;
  const Communicator& comm;
  // Points, interreflected: every vertex's dense transfer of bounces - 1
  // bounces (emitter_channels channels), gathered at each front hit.
  const std::vector<float>* emitters;
  int emitter_channels;
  int n, nc;  // bands, coefficients per channel
  std::size_t V, r0, own;  // the points; this rank's are [r0, r0 + own)
  bool grey, trace, gather, glossy, glossy_ir;
  int grows;  // glossy: the matrices' rows (nc; kDirectionalRows for a directional lightmap)
  bool want_hits;
  int channels;  // the transfer's: 1 for a grey albedo, else 3
  std::size_t stride = 0, gstride = 0;  // floats per point of t.coeffs and of t.glossy_matrices
  Plan plan;
  Albedo vertex_albedo;
  std::vector<double> A;  // the kernel's zonal factors per band: the clamped cosine's, or fresnel_cosine_factors'
  // The kernel a direction at cosine c above the horizon weighs: c, or
  // T(eta, c) c (TransferOptions::transmission_eta).
  double kernel(double c) const { return o.transmission_eta > 0 ? fresnel_transmittance(o.transmission_eta, c) * c : c; }
  // The kernel's integral over the hemisphere, and of the direction times it
  // (the bent normal's unoccluded sum, along the normal).
  double k0 = M_PI, k1 = 2.0 * M_PI / 3.0;
  // The direction set (M directions of weight w), its basis in float and,
  // glossy, in double (the products of the matrices sum many rays).
  int M = 0;
  std::vector<glm::vec3> dirs;
  std::vector<float> Ytab;
  std::vector<double> Ydbl;
  double w = 0.0;
  float offset = 0.0f;
  const detail::RayScene* scene = nullptr;

  float albedo(std::size_t v, int c) const {
    return src.albedo ? src.albedo[v][c] : src.vertices ? vertex_albedo(v, c) : o.albedo[c];
  }
};

// What the first pass keeps besides the transfer: which points are analytic,
// their records and the points' gathered bounce light.
struct FirstPass {
  explicit FirstPass(const Run& run)
      : store(run.plan.record_budget), grow(run.want_hits && run.gather ? run.own + 1 : 0, 0),
        frow(run.glossy_ir ? run.own + 1 : 0, 0) {}

  // Vertices with a normal and no occluded ray: their transfer is the
  // analytic clamped cosine, stored by no one (finish_transfer compacts them).
  std::vector<std::uint8_t> analytic;
  // Points: the light the vertices they see reflect onto them (one gather
  // of the vertices' transfer per front hit, scaled as the direct part).
  std::vector<float> bounce_light;
  // The records of this rank's vertices, a block of plan.block vertices at
  // a time: block b's gather rows (the sparse gather matrix G, receiver
  // vertex x emitting vertex, weight w cos barycentric, merged per emitter)
  // in store block 2b, its front hits (glossy interreflected) in 2b + 1;
  // per vertex the offsets of its records.
  detail::SpillStore store;
  std::vector<std::uint64_t> grow, frow;
};

// One worker's scratch for the vertex it traces, and that vertex's sums.
struct Scratch {
  explicit Scratch(const Run& run)
      : Yn(std::size_t(run.nc)), occ(std::size_t(run.nc)), C(run.glossy ? std::size_t(run.nc) * run.nc : 0),
        s(std::size_t(run.nc)), eacc(run.emitters ? run.stride : 0) {}

  std::vector<double> Yn, occ;
  std::vector<double> Yocc, C;  // glossy: the occluded rays' Y, and w Yocc^T Yocc
  std::vector<double> Yvis, Cv;  // directional: the visible rays' Y, and w Yvis^T Yvis (first rows)
  std::size_t horizon_rays = 0, horizon_visible = 0;  // directional: rays near the horizon, and those visible
  std::vector<Entry> r;
  std::vector<float> s;  // S of the vertex
  std::vector<double> eacc;  // points: sum of w cos barycentric T_vertex over front hits
  glm::vec3 batch[8];
  int batch_j[8];
  float batch_c[8];
  detail::Hit hits[8];
  std::size_t occluded_rays = 0;
  double occ_cos = 0.0;
  glm::dvec3 occ_dir{0.0};
};

// The header of the transfer compute_impl returns.
Transfer transfer_header(const Run& run) {
  const TransferOptions& o = run.o;
  Transfer t;
  t.bands = run.n;
  t.channels = run.channels;
  t.mode = o.mode;
  t.bounces = o.mode == TransferMode::Interreflected ? o.bounces : 0;
  t.samples = o.mode == TransferMode::Unshadowed ? 0 : o.samples;
  t.albedo = o.albedo;
  t.vertex_colors = o.vertex_colors;
  t.seed = o.seed;
  t.vertices = run.V;
  t.mesh_hash = run.mesh.hash();
  return t;
}

// The direction set and its basis tables, the ray offset.
void make_tables(Run& run) {
  const int M = 2 * run.o.samples, n = run.n, nc = run.nc;
  run.M = M;
  run.dirs = run.trace ? detail::direction_set(M, run.o.seed) : std::vector<glm::vec3>{};
  const std::vector<glm::vec3>& dirs = run.dirs;
  run.Ytab.resize(run.trace ? std::size_t(M) * nc : 0);
  for (int j = 0; j < (run.trace ? M : 0); ++j)
    sh::eval<float>(n, dirs[j].x, dirs[j].y, dirs[j].z, run.Ytab.data() + std::size_t(j) * nc);
  run.Ydbl.resize(run.glossy ? std::size_t(M) * nc : 0);
  for (int j = 0; j < (run.glossy ? M : 0); ++j)
    sh::eval<double>(n, dirs[j].x, dirs[j].y, dirs[j].z, run.Ydbl.data() + std::size_t(j) * nc);
  run.w = 4.0 * M_PI / M;
  run.offset = float(run.o.offset > 0 ? run.o.offset : detail::default_ray_offset(run.mesh));
}

// Vertex v's direct transfer: albedo times S.
void write_direct(const Run& run, Transfer& t, std::size_t v, const std::vector<float>& s) {
  for (int c = 0; c < t.channels; ++c) {
    const float a = run.albedo(v, c);
    for (int k = 0; k < run.nc; ++k) t.coeffs[v * run.stride + std::size_t(c) * run.nc + k] = a * s[k];
  }
}

// Ray `j` of a point (its normal `nrm`, c = dot(nrm, d_j) in float > 0),
// occluded or not, and where it hit
// (used where run.want_hits): the occluded directions' cosine-weighted basis
// subtracted, the visible ones kept for directional rows, front hits
// recorded for the bounce gather (and the glossy bounce light in `fronts`).
// Every tracer's rays go through here, in direction order.
void take_ray(const Run& run, Scratch& sc, float c, int j, bool occluded, const detail::Hit& hit,
              std::vector<FrontHit>* fronts) {
  const int nc = run.nc;
  if (run.o.directional) {
    const bool near_horizon = c < kHorizonBand;
    sc.horizon_rays += near_horizon;
    if (!occluded) {
      sc.horizon_visible += near_horizon;
      sc.Yvis.insert(sc.Yvis.end(), run.Ydbl.begin() + std::ptrdiff_t(j) * nc,
                     run.Ydbl.begin() + std::ptrdiff_t(j + 1) * nc);
    }
  }
  if (!occluded) return;
  ++sc.occluded_rays;
  const double wc = run.w * run.kernel(c);
  const float* y = run.Ytab.data() + std::size_t(j) * nc;
  for (int q = 0; q < nc; ++q) sc.occ[q] += wc * y[q];
  sc.occ_cos += wc;
  sc.occ_dir += wc * glm::dvec3(run.dirs[j]);
  if (run.glossy)
    sc.Yocc.insert(sc.Yocc.end(), run.Ydbl.begin() + std::ptrdiff_t(j) * nc, run.Ydbl.begin() + std::ptrdiff_t(j + 1) * nc);
  if (run.glossy_ir && hit.front) fronts->push_back({std::uint32_t(j), hit.triangle, hit.u, hit.v});
  if (run.emitters && hit.front) {
    const glm::uvec3 tri = run.mesh.triangles[hit.triangle];
    const float bc[3] = {1.0f - hit.u - hit.v, hit.u, hit.v};
    const std::size_t estride = std::size_t(run.emitter_channels) * nc;
    for (int corner = 0; corner < 3; ++corner) {
      const double wb = double(float(wc) * bc[corner]);
      const float* e = run.emitters->data() + std::size_t(tri[corner]) * estride;
      for (int ch = 0; ch < run.channels; ++ch) {
        const float* ec = e + (run.emitter_channels == 1 ? 0 : std::size_t(ch) * nc);
        for (int q = 0; q < nc; ++q) sc.eacc[std::size_t(ch) * nc + q] += wb * ec[q];
      }
    }
  }
  if (run.gather && hit.front) {
    if (run.src.hit_points) {  // points (texels): those around the hit's lightmap UV
      std::uint32_t idx[4];
      float wt[4];
      const int np = run.src.hit_points->points(hit.triangle, hit.u, hit.v, idx, wt);
      for (int q = 0; q < np; ++q) sc.r.emplace_back(idx[q], float(wc) * wt[q]);
    } else {
      const glm::uvec3 tri = run.mesh.triangles[hit.triangle];
      const float bc[3] = {1.0f - hit.u - hit.v, hit.u, hit.v};
      for (int corner = 0; corner < 3; ++corner) sc.r.emplace_back(tri[corner], float(wc) * bc[corner]);
    }
  }
}

// One batch of `count` rays from `origin` (scratch.batch) traced by Embree,
// each taken (take_ray).
void trace_batch(const Run& run, Scratch& sc, glm::vec3 origin, int count, std::vector<FrontHit>* fronts) {
  std::uint32_t occluded = 0;
  if (run.want_hits) {
    run.scene->intersect8(origin, sc.batch, count, run.offset, sc.hits);
    for (int k = 0; k < count; ++k) occluded |= sc.hits[k].hit() ? 1u << k : 0u;
  } else {
    occluded = run.scene->occluded8(origin, sc.batch, count, run.offset);
  }
  for (int k = 0; k < count; ++k)
    take_ray(run, sc, sc.batch_c[k], sc.batch_j[k], (occluded & (1u << k)) != 0, sc.hits[k], fronts);
}

// A directional lightmap's texel: sc.C's first `rows` rows (each whole)
// set so that H - C is M_p = (the visible rays' sum) + f (H - the set's own
// hemisphere sum). The direction set's error over the hemisphere lies at
// the horizon, so it is mended in the share f of the horizon the texel sees
// (0 for a texel under a roof, whose rows are then its window's rays alone;
// 1 in the open). H - occluded (f = 1 always, as vertices' glossy
// matrices) was 1.4x this error in the bundled room at 256 samples, its
// texels' sky seen through windows (docs/LIGHTMAPS.md "Directional
// lightmaps").
void directional_occluded(const Run& run, Scratch& sc, const std::vector<double>& H) {
  const int nc = run.nc, rows = run.grows;
  const std::size_t visible = sc.Yvis.size() / std::size_t(nc), entries = std::size_t(rows) * nc;
  cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, rows, nc, int(sc.occluded_rays), run.w, sc.Yocc.data(), nc,
              sc.Yocc.data(), nc, 0.0, sc.C.data(), nc);
  sc.Cv.assign(entries, 0.0);
  if (visible > 0)
    cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, rows, nc, int(visible), run.w, sc.Yvis.data(), nc,
                sc.Yvis.data(), nc, 0.0, sc.Cv.data(), nc);
  const double f = sc.horizon_rays ? double(sc.horizon_visible) / double(sc.horizon_rays) : 0.0;
  for (std::size_t e = 0; e < entries; ++e) {
    const double set_hemisphere = sc.C[e] + sc.Cv[e];
    sc.C[e] = H[e] - sc.Cv[e] - f * (H[e] - set_hemisphere);
  }
}

// Glossy: vertex v's matrix M_p = H(n) - w sum_occluded Y Y^T (upper
// triangle from the BLAS); interreflected keeps it full, per channel, for
// the bounce light added later. A directional lightmap's texel keeps its
// first rows (directional_occluded).
void write_glossy_matrix(const Run& run, Transfer& t, Scratch& sc, std::size_t v, glm::vec3 nrm) {
  const int nc = run.nc, rows = run.grows;
  const bool symmetric = t.glossy_symmetric();
  const std::vector<double> H = glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm)), run.n);
  if (rows == nc)  // the upper triangle
    rank_k_update(nc, int(sc.occluded_rays), run.w, sc.Yocc.data(), 0.0, sc.C.data());
  else
    directional_occluded(run, sc, H);
  const auto occluded = [&](int p, int q) {
    return rows == nc ? sc.C[std::size_t(std::min(p, q)) * nc + std::size_t(std::max(p, q))]
                      : sc.C[std::size_t(p) * nc + q];
  };
  float* g = t.glossy_matrices.data() + v * run.gstride;
  const std::size_t per_channel = std::size_t(rows) * nc;
  std::size_t k = 0;
  for (int p = 0; p < rows; ++p)
    for (int q = symmetric ? p : 0; q < nc; ++q) {
      const double value = H[std::size_t(p) * nc + q] - occluded(p, q);
      if (symmetric)
        g[k++] = float(value);
      else
        for (int c = 0; c < t.glossy_channels(); ++c) g[std::size_t(c) * per_channel + std::size_t(p) * nc + q] = float(value);
    }
}

// A vertex's gather row scaled, its duplicate emitters merged in a fixed
// order, appended to `rows`.
void merge_gather_row(std::vector<Entry>& r, double scale, std::vector<Entry>& rows) {
  for (auto& e : r) e.second = float(scale * e.second);
  std::sort(r.begin(), r.end(), [](auto& a, auto& b) { return a.first < b.first; });
  std::size_t out = 0;
  for (std::size_t q = 0; q < r.size(); ++q) {
    if (out > 0 && r[out - 1].first == r[q].first)
      r[out - 1].second += r[q].second;
    else
      r[out++] = r[q];
  }
  rows.insert(rows.end(), r.begin(), r.begin() + std::ptrdiff_t(out));
}

// Point r0 + i before its rays: false when it needs none (no normal: no
// transfer; unshadowed: the analytic row), written; else its normal's basis
// in sc.Yn.
bool start_point(const Run& run, Transfer& t, FirstPass& fp, Scratch& sc, std::size_t i, std::vector<Entry>* rows,
                 std::vector<FrontHit>* fronts) {
  const int n = run.n;
  const std::size_t v = run.r0 + i;
  const glm::vec3 nrm = run.src.normals[v];
  if (glm::dot(nrm, nrm) == 0.0f) {  // unreferenced or no normal: no transfer
    t.ao[v] = 0.0f;
    if (run.gather) fp.grow[i + 1] = rows->size();
    if (run.glossy_ir) fp.frow[i + 1] = fronts->size();
    return false;
  }
  sh::eval<double>(n, nrm.x, nrm.y, nrm.z, sc.Yn.data());
  if (!run.trace) {
    fp.analytic[v] = 1;
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m) sc.s[sh::index(l, m)] = float(run.A[l] * sc.Yn[sh::index(l, m)] / M_PI);
    write_direct(run, t, v, sc.s);
    return false;
  }
  return true;
}

void finish_point(const Run& run, Transfer& t, FirstPass& fp, Scratch& sc, std::size_t i, double all_cos,
                  std::vector<Entry>* rows, std::vector<FrontHit>* fronts);

// A point's sums zeroed before its rays.
void reset_sums(const Run& run, Scratch& sc) {
  std::fill(sc.occ.begin(), sc.occ.end(), 0.0);
  sc.Yocc.clear();
  sc.Yvis.clear();
  sc.horizon_rays = sc.horizon_visible = 0;
  sc.r.clear();
  sc.occluded_rays = 0;
  sc.occ_cos = 0.0;
  sc.occ_dir = glm::dvec3(0.0);
  if (run.emitters) std::fill(sc.eacc.begin(), sc.eacc.end(), 0.0);
}

// Point r0 + i of this rank: its rays traced, its direct transfer, AO, bent
// normal (and glossy matrix, bounce light) written, its records appended to
// its grain's `rows` and `fronts` (null when not kept).
void trace_point(const Run& run, Transfer& t, FirstPass& fp, Scratch& sc, std::size_t i, std::vector<Entry>* rows,
                 std::vector<FrontHit>* fronts) {
  if (!start_point(run, t, fp, sc, i, rows, fronts)) return;
  const std::size_t v = run.r0 + i;
  const glm::vec3 nrm = run.src.normals[v];
  reset_sums(run, sc);
  const glm::vec3 origin = run.src.positions[v] + run.offset * nrm;
  int count = 0;
  double all_cos = 0.0;  // the direction set's own integral of cos+ (pi up to its quadrature error)
  for (int j = 0; j < run.M; ++j) {
    const float c = glm::dot(nrm, run.dirs[j]);
    if (c <= 0.0f) continue;  // below the horizon: no ray
    all_cos += run.w * run.kernel(c);
    sc.batch[count] = run.dirs[j];
    sc.batch_c[count] = c;
    sc.batch_j[count++] = j;
    if (count == 8) {
      trace_batch(run, sc, origin, count, fronts);
      count = 0;
    }
  }
  if (count) trace_batch(run, sc, origin, count, fronts);
  finish_point(run, t, fp, sc, i, all_cos, rows, fronts);
}

// Point r0 + i once its rays' sums are in `sc` (and `all_cos`, the
// direction set's own integral of the kernel above its horizon): its
// direct transfer, AO, bent normal (and glossy matrix, bounce light) written,
// its gather row merged into `rows`.
void finish_point(const Run& run, Transfer& t, FirstPass& fp, Scratch& sc, std::size_t i, double all_cos,
                  std::vector<Entry>* rows, std::vector<FrontHit>* fronts) {
  const int n = run.n, nc = run.nc;
  const std::size_t v = run.r0 + i, stride = run.stride;
  const glm::vec3 nrm = run.src.normals[v];
  fp.analytic[v] = sc.occluded_rays == 0 && !(run.o.transmission_eta > 0);  // readers rebuild analytic rows with A_l
  if (run.glossy && sc.occluded_rays > 0) write_glossy_matrix(run, t, sc, v, nrm);
  // Scale the occluded sums so the set integrates the kernel to exactly its
  // K_0 (cos+: pi): a fully occluded vertex then gets AO 0 and T_00 0 exactly.
  const double k0 = run.k0;
  const double scale = all_cos > 0.0 ? k0 / all_cos : 1.0;
  for (int l = 0; l < n; ++l)
    for (int m = -l; m <= l; ++m) {
      const int k = sh::index(l, m);
      sc.s[k] = float((run.A[l] * sc.Yn[k] - scale * sc.occ[k]) / M_PI);
    }
  write_direct(run, t, v, sc.s);
  if (run.emitters)  // (rho / pi) scale sum w cos b T_vertex: bounce b at the point is bounce b - 1 at the vertices
    for (int c = 0; c < t.channels; ++c) {
      const double a = run.albedo(v, c) / M_PI * scale;
      for (int k = 0; k < nc; ++k)
        fp.bounce_light[v * stride + std::size_t(c) * nc + k] = float(a * sc.eacc[std::size_t(c) * nc + k]);
    }
  t.ao[v] = float(std::clamp(1.0 - scale * sc.occ_cos / k0, 0.0, 1.0));
  const glm::dvec3 bent = run.k1 * glm::dvec3(nrm) - scale * sc.occ_dir;
  const double len = glm::length(bent);
  t.bent_normals[v] = len > 0 ? glm::vec3(bent / len) : nrm;
  if (run.gather) {  // same scale as above
    merge_gather_row(sc.r, scale, *rows);
    fp.grow[i + 1] = rows->size();  // within the grain; made global by store_block
  }
  if (run.glossy_ir) fp.frow[i + 1] = fronts->size();
}

// Block [b0, b1)'s records into the store: the grains' offsets made
// cumulative over the whole range, then G's block (the emitters, then the
// weights) and the front hits.
void store_block(const Run& run, FirstPass& fp, std::size_t b0, std::size_t b1,
                 std::vector<std::vector<Entry>>& grain_rows, const std::vector<std::vector<FrontHit>>& grain_hits) {
  const std::size_t grains = (b1 - b0 + kWorkerGrain - 1) / kWorkerGrain;
  for (std::size_t grain = 0; grain < grains; ++grain) {
    const std::size_t i0 = b0 + grain * kWorkerGrain, i1 = std::min(b1, i0 + kWorkerGrain);
    if (run.gather) {
      const std::uint64_t base = fp.grow[i0];
      for (std::size_t i = i0; i < i1; ++i) fp.grow[i + 1] += base;
    }
    if (run.glossy_ir) {
      const std::uint64_t base = fp.frow[i0];
      for (std::size_t i = i0; i < i1; ++i) fp.frow[i + 1] += base;
    }
  }
  std::vector<std::uint8_t> g;
  if (run.gather) {
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
  fp.store.append(std::move(g));
  fp.store.append(run.glossy_ir ? pack(grain_hits) : std::vector<std::uint8_t>{});
}

// The occlusion job of this rank's points [b0, b1).
OcclusionJob occlusion_job(const Run& run, std::size_t b0, std::size_t b1) {
  OcclusionJob job;
  job.positions = std::span<const glm::vec3>(run.src.positions + run.r0 + b0, b1 - b0);
  job.normals = std::span<const glm::vec3>(run.src.normals + run.r0 + b0, b1 - b0);
  job.directions = run.dirs;
  job.basis = run.Ytab;
  job.nc = run.nc;
  job.weight = run.w;
  job.offset = run.offset;
  return job;
}

// Does the tracer's sums path give every point what the first pass needs?
// Only where each point needs its occluded rays' sums alone: no records
// (gather, glossy bounce, emitters), no per-ray rows (glossy, directional),
// the plain cosine kernel (the shader weighs rays by c).
bool sums_suffice(const Run& run) { return !run.want_hits && !run.glossy && !(run.o.transmission_eta > 0); }

// The first pass with TransferOptions::tracer, sums path: the tracer sums
// every point's occluded rays (prt/point_tracer.h), then each point is
// finished as the CPU's rays finish it.
void trace_points_summed(const PointTracer& tracer, const Run& run, Transfer& t, FirstPass& fp) {
  OcclusionSums sums;
  detail::ProgressTicker rays(run.progress, run.own, "rays (GPU)");
  std::size_t told = 0;
  tracer.trace(occlusion_job(run, 0, run.own), sums, [&](std::size_t done, std::size_t) {
    rays.tick(done - told);
    told = done;
    return !rays.cancelled();
  });
  rays.finish();
  const std::size_t nc = std::size_t(run.nc);
  tbb::parallel_for(std::size_t(0), (run.own + kWorkerGrain - 1) / kWorkerGrain, [&](std::size_t grain) {
    Scratch sc(run);
    for (std::size_t i = grain * kWorkerGrain; i < std::min(run.own, (grain + 1) * kWorkerGrain); ++i) {
      if (!start_point(run, t, fp, sc, i, nullptr, nullptr)) continue;
      std::copy_n(sums.occluded_basis.begin() + std::ptrdiff_t(i * nc), nc, sc.occ.begin());
      sc.occluded_rays = sums.occluded_rays[i];
      sc.occ_cos = sums.occluded_cos[i];
      sc.occ_dir = sums.occluded_dir[i];
      finish_point(run, t, fp, sc, i, sums.all_cos[i], nullptr, nullptr);
    }
  });
}

// Point r0 + i from the tracer's closest hits of its rays (`hits`, M, one
// per direction): each ray above the horizon taken in direction order, as
// trace_point takes Embree's, then finished.
void take_point_hits(const Run& run, Transfer& t, FirstPass& fp, Scratch& sc, std::size_t i, const RayHit* hits,
                     std::vector<Entry>* rows, std::vector<FrontHit>* fronts) {
  if (!start_point(run, t, fp, sc, i, rows, fronts)) return;
  const glm::vec3 nrm = run.src.normals[run.r0 + i];
  reset_sums(run, sc);
  double all_cos = 0.0;
  for (int j = 0; j < run.M; ++j) {
    const float c = glm::dot(nrm, run.dirs[j]);
    if (c <= 0.0f) continue;
    all_cos += run.w * run.kernel(c);
    const RayHit& h = hits[j];
    detail::Hit hit;
    if (h.hit()) {
      hit.triangle = h.triangle;
      hit.u = h.u;
      hit.v = h.v;
      hit.t = h.t;
      hit.front = detail::front_facing(run.mesh, h.triangle, run.dirs[j]);
    }
    take_ray(run, sc, c, j, h.hit(), hit, fronts);
  }
  finish_point(run, t, fp, sc, i, all_cos, rows, fronts);
}

// The first pass with TransferOptions::tracer, hits path: a block of
// plan.block points at a time, the tracer's chunks of closest hits taken
// per point (take_point_hits) on the worker threads, each worker grain's
// records in point order (a grain a chunk splits continues in the next),
// stored per block as trace_points stores Embree's.
void trace_points_hits(const PointTracer& tracer, const Run& run, Transfer& t, FirstPass& fp) {
  detail::ProgressTicker rays(run.progress, run.own, "rays (GPU)");
  const std::size_t M = std::size_t(run.M);
  for (std::size_t b0 = 0; b0 < run.own && !rays.cancelled(); b0 += run.plan.block) {
    const std::size_t b1 = std::min(run.own, b0 + run.plan.block);
    const std::size_t grains = (b1 - b0 + kWorkerGrain - 1) / kWorkerGrain;
    std::vector<std::vector<Entry>> grain_rows(run.gather ? grains : 0);
    std::vector<std::vector<FrontHit>> grain_hits(run.glossy_ir ? grains : 0);
    tracer.trace_hits(occlusion_job(run, b0, b1), [&](const HitChunk& ch) {
      if (ch.count == 0) return !rays.cancelled();
      const std::size_t g0 = ch.first / kWorkerGrain, g1 = (ch.first + ch.count - 1) / kWorkerGrain + 1;
      tbb::parallel_for(g0, g1, [&](std::size_t g) {
        detail::enable_ftz_daz();
        Scratch sc(run);
        std::vector<Entry>* rows = run.gather ? &grain_rows[g] : nullptr;
        std::vector<FrontHit>* fronts = run.glossy_ir ? &grain_hits[g] : nullptr;
        const std::size_t i0 = std::max(ch.first, g * kWorkerGrain);
        const std::size_t i1 = std::min(ch.first + ch.count, (g + 1) * kWorkerGrain);
        for (std::size_t i = i0; i < i1; ++i)
          take_point_hits(run, t, fp, sc, b0 + i, ch.hits.data() + (i - ch.first) * M, rows, fronts);
      });
      rays.tick(ch.count);
      return !rays.cancelled();
    });
    store_block(run, fp, b0, b1, grain_rows, grain_hits);
  }
  rays.finish();
}

// The first pass over this rank's points, a block of plan.block at a time:
// rays, direct transfer and records.
void trace_points(const Run& run, Transfer& t, FirstPass& fp) {
  if (run.o.tracer)
    return sums_suffice(run) ? trace_points_summed(*run.o.tracer, run, t, fp)
                             : trace_points_hits(*run.o.tracer, run, t, fp);
  detail::ProgressTicker first(run.progress, run.own, run.trace ? "rays" : "transfer");
  for (std::size_t b0 = 0; b0 < run.own; b0 += run.plan.block) {
    const std::size_t b1 = std::min(run.own, b0 + run.plan.block);
    const std::size_t grains = (b1 - b0 + kWorkerGrain - 1) / kWorkerGrain;
    std::vector<std::vector<Entry>> grain_rows(run.gather ? grains : 0);
    std::vector<std::vector<FrontHit>> grain_hits(run.glossy_ir ? grains : 0);
    tbb::parallel_for(std::size_t(0), grains, [&](std::size_t grain) {
      detail::enable_ftz_daz();
      if (first.cancelled()) return;
      Scratch sc(run);
      std::vector<Entry>* rows = run.gather ? &grain_rows[grain] : nullptr;
      std::vector<FrontHit>* fronts = run.glossy_ir ? &grain_hits[grain] : nullptr;
      const std::size_t i0 = b0 + grain * kWorkerGrain, i1 = std::min(b1, i0 + kWorkerGrain);
      for (std::size_t i = i0; i < i1; ++i) trace_point(run, t, fp, sc, i, rows, fronts);
      first.tick(i1 - i0);
    });
    if (first.cancelled()) break;
    store_block(run, fp, b0, b1, grain_rows, grain_hits);
  }
  first.finish();
}

// The end of compute_impl: the glossy bounce light, the glossy matrices to
// rank 0, analytic rows dropped. Returns the transfer (empty off rank 0
// unless keep_everywhere).
Transfer finish_transfer(const Run& run, Transfer& t, FirstPass& fp, bool keep_everywhere) {
  if (run.glossy_ir) {
    std::vector<float> dense;
    if (run.src.expand) (*run.src.expand)(t.coeffs, dense, true);
    add_glossy_bounce_light(t, run.src.expand ? dense.data() : t.coeffs.data(), run.mesh, run.src.hit_points, fp.store,
                            fp.frow, run.r0,
                            run.plan.block, run.Ydbl, run.w, run.progress);
  }
  if (run.glossy) gather_to_root(t.glossy_matrices, run.V, run.comm);
  if (keep_everywhere) return std::move(t);
  if (run.comm.rank() != 0) return Transfer{};
  // Vertices: analytic rows are dropped (relight evaluates them from the
  // mesh's normals). Points keep every row: no mesh normal is theirs.
  if (run.src.vertices || run.src.compact) compact_transfer(t, fp.analytic);
  return std::move(t);
}

// One bounce over block `blk` of this rank's points: next = (rho / pi) G
// emitting, G's block from the store.
void gather_block(const Run& run, const FirstPass& fp, std::size_t blk, const float* emitting, std::vector<float>& next,
                  std::vector<std::uint8_t>& buffer, detail::ProgressTicker& bounce) {
  const std::size_t stride = run.stride;
  const int nc = run.nc;
  const std::vector<std::uint64_t>& grow = fp.grow;
  const std::size_t b0 = blk * run.plan.block, b1 = std::min(run.own, b0 + run.plan.block);
  const std::uint8_t* bytes = fp.store.get(2 * blk, buffer);
  const std::size_t nnz = std::size_t(grow[b1] - grow[b0]);
  const auto* col = reinterpret_cast<const std::uint32_t*>(bytes);
  const auto* val = reinterpret_cast<const float*>(bytes + nnz * sizeof(std::uint32_t));
  tbb::parallel_for(std::size_t(0), (b1 - b0 + kWorkerGrain - 1) / kWorkerGrain, [&](std::size_t grain) {
    std::vector<double> acc(stride);
    const std::size_t i0 = b0 + grain * kWorkerGrain, i1 = std::min(b1, i0 + kWorkerGrain);
    for (std::size_t i = i0; i < i1; ++i) {
      const std::size_t v = run.r0 + i;
      std::fill(acc.begin(), acc.end(), 0.0);
      for (std::size_t e = grow[i] - grow[b0]; e < grow[i + 1] - grow[b0]; ++e) {
        const float* emitter = emitting + std::size_t(col[e]) * stride;
        const double gv = val[e];
        for (std::size_t k = 0; k < stride; ++k) acc[k] += gv * emitter[k];
      }
      for (int c = 0; c < run.channels; ++c) {
        const double a = run.albedo(v, c) / M_PI;
        for (int k = 0; k < nc; ++k) next[v * stride + std::size_t(c) * nc + k] = float(a * acc[std::size_t(c) * nc + k]);
      }
    }
    bounce.tick(i1 - i0);
  });
}

// Bounces: T_{b+1}(v) = (rho_v / pi) sum_u G_vu T_b(u), each from the
// previous bounce alone; the total is summed separately. Each rank
// computes its vertices, then all of them are exchanged.
void gather_bounces(const Run& run, Transfer& t, const FirstPass& fp) {
  const TransferOptions& o = run.o;
  const std::size_t V = run.V;
  t.direct = t.coeffs;
  double direct_energy = 0.0;
  for (float x : t.direct) direct_energy += std::abs(x);
  t.direct_energy = direct_energy / double(std::max<std::size_t>(V, 1));
  t.bounces = 0;
  std::vector<float> next(V * run.stride), other(o.bounces > 1 ? V * run.stride : 0);
  const std::vector<float>* prev = &t.direct;
  std::vector<std::uint8_t> buffer;
  std::vector<float> vertex_rows;  // with expand: every mesh vertex's row of the previous bounce
  for (int b = 1; b <= o.bounces; ++b) {
    if (run.src.expand) (*run.src.expand)(*prev, vertex_rows, b == 1);
    const float* emitting = run.src.expand ? vertex_rows.data() : prev->data();
    detail::ProgressTicker bounce(run.progress, run.own, "bounces");
    for (std::size_t blk = 0; blk * run.plan.block < run.own; ++blk) {
      gather_block(run, fp, blk, emitting, next, buffer, bounce);
      if (bounce.cancelled()) break;
    }
    bounce.finish();
    all_gather(next, V, run.comm);
    if (o.between_bounces) o.between_bounces(next);
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
  // An analytic vertex has no gather row (no occluded ray), so no bounce
  // added anything to it: its total is its direct part, the clamped cosine.
}

// The lights' bounce operator (prt/light_bounce.h): the gather rows of the
// bounces above, their columns merged into source patches (weights summed in
// double). One process (check_options), so this rank's rows are all of them.
// A weight as the file stores it: the nearest half-precision value (11
// significant bits: 0.05% of a weight, against the operator's percent).
float to_half_precision(double w) { return glm::unpackHalf1x16(glm::packHalf1x16(float(w))); }

// The operator's probe rows (LightBounce::ProbeRows): from each probe of
// probe_grid(mesh, dims), placed as compute_probe_transfer places it, the
// transfer's M directions over the sphere (4 pi / M each); a front hit's
// share of each point around it (bilinear texels, the triangle's corners)
// goes to that point's patch at level_at(the hit's distance), times
// Y_k(w), summed in double per (patch, k), stored as halves.
LightBounce::ProbeRows probe_rows(const Run& run, const detail::SourcePatches& sp,
                                  const std::function<int(double)>& level_at) {
  const ProbeGrid grid = probe_grid(run.mesh, run.o.light_bounce_probes);
  LightBounce::ProbeRows r;
  r.dims = grid.dims;
  r.min = grid.min;
  r.max = grid.max;
  r.bands = 3;  // L2: what probe volumes light objects with (ProbePass)
  const int nc = r.bands * r.bands;
  const std::size_t Q = grid.count(), P = run.V;
  const double lift = detail::probe_lift(grid);
  // The first pass's ray scene is gone by now (its memory went to the
  // bounces): one of the probe volume's kind (robust, as its rays start in
  // open space) for the probes' rays.
  const detail::RayScene rays(run.mesh, /*robust=*/true);
  std::vector<std::vector<std::uint32_t>> sources(Q);
  std::vector<std::vector<float>> weights(Q);
  detail::ProgressTicker ticker(run.progress, Q, "probe rows");
  tbb::parallel_for(std::size_t(0), Q, [&](std::size_t q) {
    detail::enable_ftz_daz();
    const int i = int(q % std::size_t(grid.dims[0]));
    const int j = int((q / std::size_t(grid.dims[0])) % std::size_t(grid.dims[1]));
    const int k = int(q / (std::size_t(grid.dims[0]) * std::size_t(grid.dims[1])));
    const glm::vec3 x = detail::lift_off_surfaces(rays, run.mesh, lift, glm::vec3(grid.position(i, j, k)));
    std::vector<std::pair<std::uint32_t, std::array<double, 9>>> row;
    std::array<double, 9> y{};
    detail::Hit hits[8];
    for (int j0 = 0; j0 < run.M; j0 += 8) {
      const int count = std::min(8, run.M - j0);
      rays.intersect8(x, run.dirs.data() + j0, count, run.offset, hits);
      for (int h = 0; h < count; ++h) {
        const detail::Hit& hit = hits[h];
        if (!hit.hit() || !hit.front) continue;
        const glm::vec3& d = run.dirs[std::size_t(j0 + h)];
        sh::eval<double>(r.bands, d.x, d.y, d.z, y.data());
        const int level = level_at(double(hit.t));
        std::uint32_t idx[4];
        float wt[4];
        int np = 0;
        if (run.src.hit_points) {
          np = run.src.hit_points->points(hit.triangle, hit.u, hit.v, idx, wt);
        } else {
          const glm::uvec3 tri = run.mesh.triangles[hit.triangle];
          const float bc[3] = {1.0f - hit.u - hit.v, hit.u, hit.v};
          for (int c = 0; c < 3; ++c) {
            idx[np] = tri[c];
            wt[np++] = bc[c];
          }
        }
        for (int e = 0; e < np; ++e) {
          if (idx[e] >= P || !(wt[e] > 0.0f)) continue;
          std::array<double, 9> w{};
          for (int c = 0; c < nc; ++c) w[std::size_t(c)] = run.w * double(wt[e]) * y[std::size_t(c)];
          row.emplace_back(sp.of_point[std::size_t(level) * P + idx[e]], w);
        }
      }
    }
    std::sort(row.begin(), row.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t e = 0; e < row.size();) {
      const std::uint32_t patch = row[e].first;
      std::array<double, 9> w{};
      for (; e < row.size() && row[e].first == patch; ++e)
        for (int c = 0; c < nc; ++c) w[std::size_t(c)] += row[e].second[std::size_t(c)];
      sources[q].push_back(patch);
      for (int c = 0; c < nc; ++c) weights[q].push_back(to_half_precision(w[std::size_t(c)]));
    }
    ticker.tick(1);
  });
  ticker.finish();
  r.offsets.assign(1, 0);
  for (std::size_t q = 0; q < Q; ++q) {
    r.source.insert(r.source.end(), sources[q].begin(), sources[q].end());
    r.weight.insert(r.weight.end(), weights[q].begin(), weights[q].end());
    r.offsets.push_back(std::uint32_t(r.source.size()));
  }
  return r;
}

LightBounce keep_light_bounce(const Run& run, const FirstPass& fp, int bounces) {
  static_assert(kMaxLightBounces == kMaxBounces);
  LightBounce b;
  b.bounces = bounces;
  const std::size_t P = run.V;
  detail::SourcePatches sp = detail::source_patches(run.src.positions, run.src.normals, P, run.o.light_bounce_patch);
  b.patches = sp.patches;
  b.patch.assign(sp.of_point.begin(), sp.of_point.begin() + std::ptrdiff_t(P));
  b.parent = std::move(sp.parent);
  b.offsets.assign(P + 1, 0);
  // An entry whose emitting point lies at distance d goes to the coarsest
  // patch whose cell is at most ratio x d: level floor(log2(ratio d / cell)).
  const double reach = run.o.light_bounce_ratio / run.o.light_bounce_patch;
  const auto level_at = [&](double d) {
    const double x = reach * d;
    return x < 2.0 ? 0 : std::min(sp.levels - 1, int(std::floor(std::log2(x))));
  };
  std::vector<std::uint8_t> buffer;
  const std::vector<std::uint64_t>& grow = fp.grow;
  for (std::size_t blk = 0; blk * run.plan.block < run.own; ++blk) {
    const std::size_t b0 = blk * run.plan.block, b1 = std::min(run.own, b0 + run.plan.block);
    const std::uint8_t* bytes = fp.store.get(2 * blk, buffer);
    const std::size_t nnz = std::size_t(grow[b1] - grow[b0]);
    const auto* col = reinterpret_cast<const std::uint32_t*>(bytes);
    const auto* val = reinterpret_cast<const float*>(bytes + nnz * sizeof(std::uint32_t));
    // Each point's row on its own (in parallel: the same bits in any
    // order), then appended in point order.
    const std::size_t grains = (b1 - b0 + kWorkerGrain - 1) / kWorkerGrain;
    std::vector<std::vector<std::uint32_t>> sources(grains), lengths(grains);
    std::vector<std::vector<float>> weights(grains);
    tbb::parallel_for(std::size_t(0), grains, [&](std::size_t g) {
      std::vector<std::pair<std::uint32_t, double>> row;
      const std::size_t i0 = b0 + g * kWorkerGrain, i1 = std::min(b1, i0 + kWorkerGrain);
      for (std::size_t i = i0; i < i1; ++i) {
        row.clear();
        const glm::dvec3 at(run.src.positions[run.r0 + i]);
        for (std::size_t e = grow[i] - grow[b0]; e < grow[i + 1] - grow[b0]; ++e) {
          const int l = level_at(glm::length(glm::dvec3(run.src.positions[col[e]]) - at));
          row.emplace_back(sp.of_point[std::size_t(l) * P + col[e]], val[e]);
        }
        std::sort(row.begin(), row.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
        std::size_t out = 0;
        for (std::size_t q = 0; q < row.size(); ++q) {
          if (out > 0 && row[out - 1].first == row[q].first) row[out - 1].second += row[q].second;
          else row[out++] = row[q];
        }
        for (std::size_t q = 0; q < out; ++q) {
          sources[g].push_back(row[q].first);
          weights[g].push_back(to_half_precision(row[q].second));
        }
        lengths[g].push_back(std::uint32_t(out));
      }
    });
    std::size_t i = b0;
    for (std::size_t g = 0; g < grains; ++g) {
      b.source.insert(b.source.end(), sources[g].begin(), sources[g].end());
      b.weight.insert(b.weight.end(), weights[g].begin(), weights[g].end());
      for (std::uint32_t n : lengths[g]) {
        b.offsets[run.r0 + i + 1] = b.offsets[run.r0 + i] + n;
        ++i;
      }
    }
  }
  if (run.o.light_bounce_probes[0] > 0) b.probes = probe_rows(run, sp, level_at);
  // Far hits gathered once per cluster of receivers (prt::link_clusters).
  if (run.o.light_bounce_clusters >= 0) b = link_clusters(b, run.o.light_bounce_clusters);
  return b;
}

// compute_transfer at `src` (the vertices: the transfer file's layout), or
// at other points. `emitters` (points, interreflected): every vertex's dense
// transfer of bounces - 1 bounces, gathered once at each point's front hits
// instead of keeping records. `keep_everywhere`: every rank returns the
// whole, uncompacted transfer (compute_point_transfer's vertex pass).
Transfer compute_impl(const Mesh& mesh, const Source& src, const TransferOptions& o, const Progress& progress,
                      const std::vector<float>* emitters, int emitter_channels, bool keep_everywhere) {
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);
  Run run(mesh, src, o, progress, emitters, emitter_channels);
  const Communicator& comm = run.comm;
  const std::size_t V = run.V;
  if (o.directional && !src.hit_points)
    throw Error("--directional rows are a lightmap's (prt precompute --lightmap WxH --directional), not a mesh's "
                "vertices'");
  Transfer t = transfer_header(run);
  run.stride = t.stride();
  // Checked before any ray: throws for a limit below the minimum.
  run.plan = plan_memory(mesh, V, o, run.own, emitters != nullptr, run.grey, src.hit_points ? 4 : 3);
  FirstPass fp(run);
  fp.bounce_light.assign(emitters ? V * run.stride : 0, 0.0f);

  // The direct transfer: albedo times S, the geometry-only transfer (one
  // channel), S_k = (1/pi) integral V cos+ Y_k, written per vertex.
  run.A = sh::clamped_cosine_factors(run.n);
  if (o.transmission_eta > 0) {  // the transmitted cosine's factors (docs/SUBSURFACE.md)
    run.A = fresnel_cosine_factors(o.transmission_eta, std::max(run.n, 2));
    run.k0 = run.A[0];
    run.k1 = run.A[1];
    run.A.resize(std::size_t(run.n));
  }
  t.coeffs.assign(V * run.stride, 0.0f);
  t.ao.assign(V, 1.0f);
  t.bent_normals.assign(src.normals, src.normals + V);
  if (run.glossy) detail::blas_single_threaded();
  t.glossy = run.glossy;
  t.glossy_rows = o.directional ? kDirectionalRows : 0;
  run.gstride = run.glossy ? t.glossy_stride() : 0;
  if (run.glossy) t.glossy_matrices.assign(V * run.gstride, 0.0f);
  make_tables(run);
  std::unique_ptr<detail::RayScene> own_scene;
  if (run.trace && !src.scene && !o.tracer) own_scene = std::make_unique<detail::RayScene>(mesh);
  run.scene = src.scene ? src.scene : own_scene.get();
  fp.analytic.assign(V, 0);

  trace_points(run, t, fp);
  own_scene.reset();
  run.scene = nullptr;
  if (o.memory_report) {
    *o.memory_report = run.plan.memory;
    o.memory_report->block = run.plan.block;
    o.memory_report->records_in_memory = fp.store.held_bytes();
    o.memory_report->records_spilled = fp.store.spilled_bytes();
  }
  t.shading_hash = shading_hash(mesh, o.vertex_colors);

  // Every rank needs every vertex's direct transfer for the bounces and the
  // glossy bounce light; rank 0 the rest for the file.
  if (run.gather || run.glossy_ir || keep_everywhere) all_gather(t.coeffs, V, comm);
  else gather_to_root(t.coeffs, V, comm);
  gather_to_root(t.ao, V, comm);
  gather_to_root(t.bent_normals, V, comm);
  if (keep_everywhere) all_gather(fp.analytic, V, comm);
  else gather_to_root(fp.analytic, V, comm);
  if (src.analytic_out) *src.analytic_out = fp.analytic;
  if (emitters) gather_to_root(fp.bounce_light, V, comm);

  if (o.between_bounces && (run.gather || comm.rank() == 0)) o.between_bounces(t.coeffs);
  if (emitters) {  // points: the direct part, plus the vertices' light gathered above
    t.direct = t.coeffs;
    for (std::size_t i = 0; i < t.coeffs.size(); ++i) t.coeffs[i] += fp.bounce_light[i];
  } else if (!run.gather) {
    if (o.mode == TransferMode::Interreflected) t.direct = t.coeffs;
  } else {
    gather_bounces(run, t, fp);
    if (o.light_bounce) t.light_bounce = keep_light_bounce(run, fp, t.bounces);
  }
  return finish_transfer(run, t, fp, keep_everywhere);
}

}  // namespace

void detail::check_transfer_options(const TransferOptions& o, const Mesh& mesh) { check_options(o, mesh); }

Transfer detail::compute_at(const Mesh& mesh, const Source& src, const TransferOptions& o, const Progress& progress,
                            bool keep_everywhere) {
  check_options(o, mesh);
  return compute_impl(mesh, src, o, progress, nullptr, 0, keep_everywhere);
}

Transfer compute_transfer(const Mesh& mesh, const TransferOptions& options, const Progress& progress) {
  check_options(options, mesh);
  TransferOptions o = options;
  if (o.light_bounce && o.light_bounce_patch == 0)  // patches of a few vertices
    o.light_bounce_patch = kLightBouncePatchSpacings * std::max(detail::mean_edge_length(mesh), 1e-30);
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
  if (o.between_bounces)
    throw Error("a translucent material's surface integral runs over the mesh's vertices only (compute_transfer)");
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
