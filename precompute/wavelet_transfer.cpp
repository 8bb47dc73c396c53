// All-frequency wavelet transfer (Ng, Ramamoorthi & Hanrahan 2003): per-vertex
// visibility x cosine on a cube map, Haar-transformed, thresholded, quantised
// to int16 and stored by wavelet index (see prt/wavelet_transfer.h).
#include <prt/precompute.h>

#include <prt/error.h>

#include "progress_ticker.h"
#include "ray_scene.h"

#include <fmt/format.h>

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

namespace prt {

namespace {

void check_options(const WaveletOptions& o, const Mesh& mesh) {
  wavelet::check_resolution(o.cube_res, "--cube-res");
  if (!(o.threshold >= 0.0 && o.threshold < 1.0))
    throw Error(fmt::format("--threshold must be in [0, 1), got {:f}", o.threshold));
  detail::check_common_options(o.albedo, o.vertex_colors, o.threads, o.offset, mesh);
  if (mesh.vertex_count() >= std::numeric_limits<std::uint32_t>::max())
    throw Error(mesh.source + ": too many vertices for a wavelet transfer (at most 2^32 - 2)");
  if (o.tracer && o.comm && o.comm->size() > 1)
    throw Error("--device gpu runs in one process (one process drives the GPU): run it without mpirun, or use "
                "--device cpu under mpirun");
}

// Texel-centre directions and solid angles of the cube, shared by all vertices.
struct CubeTable {
  int r;
  std::vector<glm::vec3> dir;  // 6 r^2, unit
  std::vector<double> omega;   // 6 r^2
  explicit CubeTable(int res) : r(res), dir(wavelet::cube_size(res)), omega(wavelet::cube_size(res)) {
    for (int f = 0; f < 6; ++f)
      for (int v = 0; v < r; ++v)
        for (int u = 0; u < r; ++u) {
          const std::size_t j = (std::size_t(f) * r + v) * r + u;
          dir[j] = glm::vec3(cube_texel_direction(f, u, v, r));
          omega[j] = cube_texel_solid_angle(u, v, r);
        }
  }
};

// Dense t_i of vertex v into t (6 r^2 doubles). Returns false (t all zero)
// for a vertex without a normal.
bool trace_vertex(const detail::RayScene& scene, const Mesh& mesh, std::size_t v, const CubeTable& cube, float offset,
                  double* t) {
  const std::size_t n = cube.dir.size();
  std::fill(t, t + n, 0.0);
  const glm::vec3 nrm = mesh.normals[v];
  if (glm::dot(nrm, nrm) == 0.0f) return false;
  const glm::vec3 origin = mesh.positions[v] + offset * nrm;
  glm::vec3 batch[8];
  std::uint32_t index[8];
  double weight[8];
  int count = 0;
  auto flush = [&] {
    const std::uint32_t occluded = scene.occluded8(origin, batch, count, offset);
    for (int i = 0; i < count; ++i)
      if (!(occluded & (1u << i))) t[index[i]] = weight[i];
    count = 0;
  };
  for (std::size_t j = 0; j < n; ++j) {
    const float c = glm::dot(nrm, cube.dir[j]);
    if (c <= 0.0f) continue;  // below the horizon: no ray, t = 0
    batch[count] = cube.dir[j];
    index[count] = std::uint32_t(j);
    weight[count++] = double(c) * cube.omega[j] / M_PI;
    if (count == 8) flush();
  }
  if (count) flush();
  return true;
}

struct Entry {
  std::uint32_t j;
  std::int16_t q;
};

// Haar transform, threshold and quantisation of one vertex's dense t (in
// place). Appends kept entries (ascending j) to `out`; returns the scale.
float compress_vertex(double* t, int r, double threshold, std::vector<std::pair<double, std::uint32_t>>& order,
                      std::vector<Entry>& out) {
  const std::size_t rr = std::size_t(r) * r, n = 6 * rr;
  for (int f = 0; f < 6; ++f) wavelet::haar_forward(t + f * rr, r);
  order.clear();
  double energy = 0.0, maxabs = 0.0;
  for (std::size_t j = 0; j < n; ++j)
    if (t[j] != 0.0) {
      order.emplace_back(std::abs(t[j]), std::uint32_t(j));
      energy += t[j] * t[j];
      maxabs = std::max(maxabs, std::abs(t[j]));
    }
  if (order.empty()) return 0.0f;
  std::sort(order.begin(), order.end());  // |c| ascending, then index: a fixed order
  const double budget = threshold * threshold * energy;
  double dropped = 0.0;
  std::size_t first_kept = 0;
  for (; first_kept < order.size(); ++first_kept) {
    const double e = order[first_kept].first * order[first_kept].first;
    if (dropped + e > budget) break;
    dropped += e;
  }
  for (std::size_t i = 0; i < first_kept; ++i) t[order[i].second] = 0.0;
  const float scale = float(maxabs / 32767.0);
  const double inv = 1.0 / double(scale);
  for (std::size_t j = 0; j < n; ++j) {
    if (t[j] == 0.0) continue;
    const double q = std::clamp(std::round(t[j] * inv), -32767.0, 32767.0);
    if (q != 0.0) out.push_back({std::uint32_t(j), std::int16_t(q)});
  }
  return scale;
}

float offset_of(const WaveletOptions& o, const Mesh& mesh) {
  return float(o.offset > 0 ? o.offset : detail::default_ray_offset(mesh));
}

// Dense t_i of a point with normal `nrm` into t (6 r^2 doubles) from a
// tracer's closest hits of its rays (`hits`, one per texel direction, a miss
// below the horizon): trace_vertex's t, a ray that hits nothing visible.
// Returns false (t all zero) for a zero normal.
bool hits_vertex(glm::vec3 nrm, const RayHit* hits, const CubeTable& cube, double* t) {
  const std::size_t n = cube.dir.size();
  std::fill(t, t + n, 0.0);
  if (glm::dot(nrm, nrm) == 0.0f) return false;
  for (std::size_t j = 0; j < n; ++j) {
    const float c = glm::dot(nrm, cube.dir[j]);
    if (c <= 0.0f) continue;  // below the horizon: no ray, t = 0
    if (!hits[j].hit()) t[j] = double(c) * cube.omega[j] / M_PI;
  }
  return true;
}

// The occlusion job of the points [p0, p1) of `mesh` along the cube's texel
// directions (trace_hits: no basis, no weight).
OcclusionJob cube_job(const Mesh& mesh, std::size_t p0, std::size_t p1, const CubeTable& cube, float offset) {
  OcclusionJob job;
  job.positions = std::span<const glm::vec3>(mesh.positions.data() + p0, p1 - p0);
  job.normals = std::span<const glm::vec3>(mesh.normals.data() + p0, p1 - p0);
  job.directions = cube.dir;
  job.offset = offset;
  return job;
}

// One worker's buffers: a vertex's dense t and compress_vertex's order.
struct CubeScratch {
  std::vector<double> t;
  std::vector<std::pair<double, std::uint32_t>> order;
  explicit CubeScratch(std::size_t n) : t(n) { order.reserve(n); }
};

// Pass 1 of this rank's vertices [r0, r1) of `mesh`: per block of kCubeGrain
// vertices (block b: r0 + b kCubeGrain on), the kept entries in vertex order;
// each vertex's scale and count into wt.
constexpr std::size_t kCubeGrain = 32;
struct CubePass {
  const Mesh& mesh;
  const WaveletOptions& o;
  const CubeTable& cube;
  float offset;
  std::size_t r0, r1;
  WaveletTransfer& wt;
  std::vector<std::vector<Entry>>& block_entries;
};

// Vertex v's dense t (in s.t) compressed into `entries`, wt's scale and count.
void keep_vertex(const CubePass& p, std::size_t v, CubeScratch& s, std::vector<Entry>& entries) {
  const std::size_t before = entries.size();
  p.wt.vertex_scale[v] = compress_vertex(s.t.data(), p.cube.r, p.o.threshold, s.order, entries);
  p.wt.vertex_kept[v] = std::uint32_t(entries.size() - before);
}

// Pass 1 with Embree on the CPU's threads, a block per task.
void trace_blocks(const CubePass& p, const Mesh& occluders, const Progress& progress) {
  const detail::RayScene scene(occluders);
  detail::ProgressTicker ticker(progress, p.r1 - p.r0, "rays");
  tbb::parallel_for(std::size_t(0), p.block_entries.size(), [&](std::size_t b) {
    detail::enable_ftz_daz();
    if (ticker.cancelled()) return;
    CubeScratch s(p.cube.dir.size());
    std::vector<Entry>& entries = p.block_entries[b];
    const std::size_t v0 = p.r0 + b * kCubeGrain, v1 = std::min(p.r1, v0 + kCubeGrain);
    for (std::size_t v = v0; v < v1; ++v)
      if (trace_vertex(scene, p.mesh, v, p.cube, p.offset, s.t.data())) keep_vertex(p, v, s, entries);
    entries.shrink_to_fit();
    ticker.tick(v1 - v0);
  });
  ticker.finish();
}

// Pass 1 with WaveletOptions::tracer: its chunks of closest hits taken on
// the worker threads, a block per task (a block a chunk splits continues in
// the next chunk, so its entries stay in vertex order).
void trace_hit_blocks(const PointTracer& tracer, const CubePass& p, const Progress& progress) {
  const std::size_t M = p.cube.dir.size(), own = p.r1 - p.r0;
  detail::ProgressTicker ticker(progress, own, "rays (GPU)");
  tracer.trace_hits(cube_job(p.mesh, p.r0, p.r1, p.cube, p.offset), [&](const HitChunk& ch) {
    if (ch.count == 0) return !ticker.cancelled();
    const std::size_t g0 = ch.first / kCubeGrain, g1 = (ch.first + ch.count - 1) / kCubeGrain + 1;
    tbb::parallel_for(g0, g1, [&](std::size_t g) {
      detail::enable_ftz_daz();
      CubeScratch s(M);
      std::vector<Entry>& entries = p.block_entries[g];
      const std::size_t i0 = std::max(ch.first, g * kCubeGrain);
      const std::size_t i1 = std::min(ch.first + ch.count, (g + 1) * kCubeGrain);
      for (std::size_t i = i0; i < i1; ++i) {
        const std::size_t v = p.r0 + i;
        if (hits_vertex(p.mesh.normals[v], ch.hits.data() + (i - ch.first) * M, p.cube, s.t.data()))
          keep_vertex(p, v, s, entries);
      }
      if (i1 == std::min(own, (g + 1) * kCubeGrain)) entries.shrink_to_fit();
    });
    ticker.tick(ch.count);
    return !ticker.cancelled();
  });
  ticker.finish();
}

// The kept entries of every rank's vertices in vertex order on rank 0 (and
// every rank's scales there, every rank's counts everywhere), from this
// rank's blocks (emptied); false on the other ranks.
bool gather_entries(const Communicator& comm, WaveletTransfer& wt, std::vector<std::vector<Entry>>& block_entries,
                    std::vector<Entry>& flat) {
  std::size_t own = 0;
  for (const auto& e : block_entries) own += e.size();
  flat.reserve(own);
  for (auto& e : block_entries) {
    flat.insert(flat.end(), e.begin(), e.end());
    std::vector<Entry>().swap(e);
  }
  if (comm.size() == 1) return true;
  const std::size_t V = wt.vertices;
  comm.all_gather(wt.vertex_kept.data(), rank_blocks(V, sizeof(std::uint32_t), comm));
  const std::vector<std::size_t> sb = rank_blocks(V, sizeof(float), comm);
  comm.gather_to_root(reinterpret_cast<char*>(wt.vertex_scale.data()) + sb[std::size_t(comm.rank())],
                      wt.vertex_scale.data(), sb);
  std::vector<std::size_t> eb(std::size_t(comm.size()) + 1, 0);
  for (int q = 0; q < comm.size(); ++q) {
    std::size_t kept = 0;
    for (std::size_t v = range_begin(V, q, comm.size()); v < range_begin(V, q + 1, comm.size()); ++v)
      kept += wt.vertex_kept[v];
    eb[std::size_t(q) + 1] = eb[std::size_t(q)] + kept * sizeof(Entry);
  }
  std::vector<Entry> all(comm.rank() == 0 ? eb.back() / sizeof(Entry) : 0);
  comm.gather_to_root(flat.data(), all.data(), eb);
  if (comm.rank() != 0) return false;
  flat.swap(all);
  return true;
}

// Pass 2: the entries (in vertex order) transposed into wt's columns.
// Walking vertices in order keeps every column sorted by vertex.
void transpose_entries(const std::vector<Entry>& flat, WaveletTransfer& wt) {
  const std::size_t n = wt.coeff_count();
  wt.col_offsets.assign(n + 1, 0);
  for (const Entry& e : flat) ++wt.col_offsets[e.j + 1];
  for (std::size_t j = 0; j < n; ++j) wt.col_offsets[j + 1] += wt.col_offsets[j];
  const std::size_t total = wt.col_offsets[n];
  wt.col_vertices.resize(total);
  wt.col_values.resize(total);
  std::vector<std::uint64_t> cursor(wt.col_offsets.begin(), wt.col_offsets.end() - 1);
  std::size_t k = 0;
  for (std::size_t v = 0; v < wt.vertices; ++v)
    for (std::uint32_t i = 0; i < wt.vertex_kept[v]; ++i, ++k) {
      const std::uint64_t pos = cursor[flat[k].j]++;
      wt.col_vertices[pos] = std::uint32_t(v);
      wt.col_values[pos] = flat[k].q;
    }
}

// The header fields of the transfer of `mesh`'s V vertices, scales and
// counts zero.
WaveletTransfer empty_transfer(const Mesh& mesh, const WaveletOptions& o) {
  const std::size_t V = mesh.vertex_count();
  WaveletTransfer wt;
  wt.cube_res = o.cube_res;
  wt.vertices = V;
  wt.mesh_hash = mesh.hash();
  wt.threshold = o.threshold;
  wt.albedo = o.albedo;
  wt.vertex_colors = o.vertex_colors;
  if (o.vertex_colors) {
    wt.vertex_albedo.resize(V);
    for (std::size_t v = 0; v < V; ++v) wt.vertex_albedo[v] = glm::clamp(mesh.colors[v], 0.0f, 1.0f);
  }
  wt.vertex_scale.assign(V, 0.0f);
  wt.vertex_kept.assign(V, 0);
  return wt;
}

// The transfer at the vertices of `mesh` (their positions, normals and, with
// vertex_colors, colours), occluded by `occluders`.
WaveletTransfer compute_wavelet_impl(const Mesh& occluders, const Mesh& mesh, const WaveletOptions& o,
                                     const Progress& progress) {
  check_options(o, mesh);
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

  WaveletTransfer wt = empty_transfer(mesh, o);
  const std::size_t V = wt.vertices;
  const CubeTable cube(o.cube_res);
  // This rank's vertices: [r0, r1) (prt/communicator.h).
  const Communicator& comm = o.comm ? *o.comm : single_process();
  const std::size_t r0 = range_begin(V, comm.rank(), comm.size()), r1 = range_begin(V, comm.rank() + 1, comm.size());
  std::vector<std::vector<Entry>> block_entries((r1 - r0 + kCubeGrain - 1) / kCubeGrain);
  const CubePass pass{mesh, o, cube, offset_of(o, occluders), r0, r1, wt, block_entries};
  if (o.tracer)
    trace_hit_blocks(*o.tracer, pass, progress);
  else
    trace_blocks(pass, occluders, progress);

  std::vector<Entry> flat;
  if (!gather_entries(comm, wt, block_entries, flat)) return WaveletTransfer{};
  transpose_entries(flat, wt);
  return wt;
}

// wavelet_texel_transfer with WaveletOptions::tracer: t of the listed
// vertices (in range) into t, [k][6 r^2].
void texel_transfer_hits(const PointTracer& tracer, const Mesh& mesh, std::span<const std::uint32_t> vertices,
                         const CubeTable& cube, float offset, double* t) {
  Mesh points;
  for (const std::uint32_t v : vertices) {
    points.positions.push_back(mesh.positions[v]);
    points.normals.push_back(mesh.normals[v]);
  }
  const std::size_t n = cube.dir.size();
  tracer.trace_hits(cube_job(points, 0, vertices.size(), cube, offset), [&](const HitChunk& ch) {
    for (std::size_t i = 0; i < ch.count; ++i)
      hits_vertex(points.normals[ch.first + i], ch.hits.data() + i * n, cube, t + (ch.first + i) * n);
    return true;
  });
}

}  // namespace

WaveletTransfer compute_wavelet_transfer(const Mesh& mesh, const WaveletOptions& o, const Progress& progress) {
  return compute_wavelet_impl(mesh, mesh, o, progress);
}

WaveletTransfer compute_wavelet_at_points(const Mesh& occluders, const Mesh& points, const WaveletOptions& o,
                                          const Progress& progress) {
  detail::check_common_options(o.albedo, false, o.threads, o.offset, occluders);
  WaveletTransfer wt = compute_wavelet_impl(occluders, points, o, progress);
  wt.mesh_hash = occluders.hash();
  return wt;
}

std::vector<double> wavelet_texel_transfer(const Mesh& mesh, const WaveletOptions& o,
                                           std::span<const std::uint32_t> vertices) {
  check_options(o, mesh);
  const CubeTable cube(o.cube_res);
  const std::size_t n = cube.dir.size();
  for (const std::uint32_t v : vertices)
    if (v >= mesh.vertex_count()) throw Error(fmt::format("vertex {} out of range", v));
  detail::enable_ftz_daz();
  std::vector<double> t(vertices.size() * n);
  if (o.tracer) {
    texel_transfer_hits(*o.tracer, mesh, vertices, cube, offset_of(o, mesh), t.data());
    return t;
  }
  const detail::RayScene scene(mesh);
  for (std::size_t k = 0; k < vertices.size(); ++k)
    trace_vertex(scene, mesh, vertices[k], cube, offset_of(o, mesh), t.data() + k * n);
  return t;
}

}  // namespace prt
