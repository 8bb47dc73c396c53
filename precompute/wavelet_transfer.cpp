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

}  // namespace

namespace {

// The transfer at the vertices of `mesh` (their positions, normals and, with
// vertex_colors, colours), occluded by `occluders`.
WaveletTransfer compute_wavelet_impl(const Mesh& occluders, const Mesh& mesh, const WaveletOptions& o,
                                     const Progress& progress) {
  check_options(o, mesh);
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

  const int r = o.cube_res;
  const std::size_t V = mesh.vertex_count(), n = wavelet::cube_size(r);
  WaveletTransfer wt;
  wt.cube_res = r;
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

  const CubeTable cube(r);
  const float offset = offset_of(o, occluders);
  const detail::RayScene scene(occluders);
  // This rank's vertices: [r0, r1) (prt/communicator.h).
  const Communicator& comm = o.comm ? *o.comm : single_process();
  const std::size_t r0 = range_begin(V, comm.rank(), comm.size()), r1 = range_begin(V, comm.rank() + 1, comm.size());

  // Pass 1: per block of vertices, the kept entries in vertex order.
  constexpr std::size_t kGrain = 32;
  const std::size_t blocks = (r1 - r0 + kGrain - 1) / kGrain;
  std::vector<std::vector<Entry>> block_entries(blocks);
  detail::ProgressTicker ticker(progress, r1 - r0, "rays");
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
    detail::enable_ftz_daz();
    if (ticker.cancelled()) return;
    std::vector<double> t(n);
    std::vector<std::pair<double, std::uint32_t>> order;
    order.reserve(n);
    std::vector<Entry>& entries = block_entries[b];
    const std::size_t v0 = r0 + b * kGrain, v1 = std::min(r1, v0 + kGrain);
    for (std::size_t v = v0; v < v1; ++v) {
      if (!trace_vertex(scene, mesh, v, cube, offset, t.data())) continue;
      const std::size_t before = entries.size();
      wt.vertex_scale[v] = compress_vertex(t.data(), r, o.threshold, order, entries);
      wt.vertex_kept[v] = std::uint32_t(entries.size() - before);
    }
    entries.shrink_to_fit();
    ticker.tick(v1 - v0);
  });
  ticker.finish();

  // This rank's entries in vertex order; then every rank's, on rank 0.
  std::size_t own = 0;
  for (const auto& e : block_entries) own += e.size();
  std::vector<Entry> flat;
  flat.reserve(own);
  for (auto& e : block_entries) {
    flat.insert(flat.end(), e.begin(), e.end());
    std::vector<Entry>().swap(e);
  }
  if (comm.size() > 1) {
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
    if (comm.rank() != 0) return WaveletTransfer{};
    flat.swap(all);
  }

  // Pass 2: transpose into columns. Walking vertices in order keeps every
  // column sorted by vertex.
  wt.col_offsets.assign(n + 1, 0);
  for (const Entry& e : flat) ++wt.col_offsets[e.j + 1];
  for (std::size_t j = 0; j < n; ++j) wt.col_offsets[j + 1] += wt.col_offsets[j];
  const std::size_t total = wt.col_offsets[n];
  wt.col_vertices.resize(total);
  wt.col_values.resize(total);
  std::vector<std::uint64_t> cursor(wt.col_offsets.begin(), wt.col_offsets.end() - 1);
  std::size_t k = 0;
  for (std::size_t v = 0; v < V; ++v)
    for (std::uint32_t i = 0; i < wt.vertex_kept[v]; ++i, ++k) {
      const std::uint64_t pos = cursor[flat[k].j]++;
      wt.col_vertices[pos] = std::uint32_t(v);
      wt.col_values[pos] = flat[k].q;
    }
  return wt;
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
  const detail::RayScene scene(mesh);
  const std::size_t n = cube.dir.size();
  detail::enable_ftz_daz();
  std::vector<double> t(vertices.size() * n);
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    if (vertices[k] >= mesh.vertex_count()) throw Error(fmt::format("vertex {} out of range", vertices[k]));
    trace_vertex(scene, mesh, vertices[k], cube, offset_of(o, mesh), t.data() + k * n);
  }
  return t;
}

}  // namespace prt
