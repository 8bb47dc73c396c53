// Local deformable transfer (prt/zh_transfer.h): vertex frames, posing.
#include <prt/zh_transfer.h>

#include <prt/error.h>
#include <prt/hash.h>
#include <prt/sh.h>
#include <prt/zh.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace prt {

namespace {

// Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT 2017): a
// right-handed basis from a unit normal alone, continuous but at n.z = -1.
glm::mat3 normal_basis(const glm::vec3& n) {
  const float s = std::copysign(1.0f, n.z);
  const float a = -1.0f / (s + n.z), b = n.x * n.y * a;
  const glm::vec3 t(1.0f + s * n.x * n.x * a, s * b, -s * n.x);
  const glm::vec3 u(b, s + n.y * n.y * a, -n.y);
  return glm::mat3(t, u, n);
}

}  // namespace

VertexFrames vertex_frames(const Mesh& mesh) {
  const std::size_t V = mesh.vertex_count();
  VertexFrames f;
  f.frames.assign(V, glm::mat3(1.0f));
  f.kinds.assign(V, FrameKind::None);
  f.edge.resize(V);
  for (std::size_t v = 0; v < V; ++v) f.edge[v] = std::uint32_t(v);
  PRT_CHECK_OP(mesh.normals.size(), ==, V);
  // Triangles in file order; in each, the edge to the next corner then to the
  // previous one; the first whose part in the tangent plane is long enough.
  for (const glm::uvec3& tri : mesh.triangles)
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t v = tri[c];
      if (f.kinds[v] != FrameKind::None) continue;
      const glm::vec3 n = mesh.normals[v];
      if (n == glm::vec3(0.0f)) continue;
      for (const std::uint32_t w : {tri[(c + 1) % 3], tri[(c + 2) % 3]}) {
        const glm::dvec3 e = glm::dvec3(mesh.positions[w]) - glm::dvec3(mesh.positions[v]);
        const double len = glm::length(e);
        const glm::dvec3 nd(n);
        const glm::dvec3 p = e - glm::dot(e, nd) * nd;
        const double plen = glm::length(p);
        if (!(len > 0) || !(plen >= kFrameEdgeMin * len)) continue;
        const glm::dvec3 t = p / plen;
        f.frames[v] = glm::mat3(glm::vec3(t), glm::vec3(glm::cross(nd, t)), n);
        f.kinds[v] = FrameKind::Edge;
        f.edge[v] = w;
        break;
      }
    }
  for (std::size_t v = 0; v < V; ++v)
    if (f.kinds[v] == FrameKind::None && mesh.normals[v] != glm::vec3(0.0f)) {
      f.frames[v] = normal_basis(mesh.normals[v]);
      f.kinds[v] = FrameKind::Normal;
    }
  return f;
}

std::uint64_t topology_hash(const Mesh& mesh) {
  Hasher h;
  h.add_value(std::uint64_t(mesh.vertex_count()));
  h.add(mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3));
  return h.digest();
}

std::size_t ZhTransfer::analytic_vertices() const {
  return std::size_t(std::count(slots.begin(), slots.end(), kAnalytic));
}

std::string zh_transfer_problem(const ZhTransfer& t) {
  if (t.bands < 1 || t.bands > zh::kMaxBands) return fmt::format("bands is {}; must be 1 to {}", t.bands, zh::kMaxBands);
  if (t.lobes < 1 || t.lobes > zh::kMaxLobes) return fmt::format("lobes is {}; must be 1 to {}", t.lobes, zh::kMaxLobes);
  if (t.channels != 1 && t.channels != 3) return fmt::format("channels is {}; must be 1 or 3", t.channels);
  if (std::uint32_t(t.mode) > std::uint32_t(TransferMode::Interreflected))
    return fmt::format("unknown mode {}", std::uint32_t(t.mode));
  if (t.bounces < 0 || t.samples < 0) return "bounces and samples must be at least 0";
  if (!albedo_in_range(t.albedo)) return "albedo outside [0, 1]";
  if (t.vertices == 0) return "no vertices";
  if (!std::isfinite(t.fit_error) || t.fit_error < 0) return "fit error is not a finite value >= 0";
  std::size_t stored = t.vertices;
  if (!t.slots.empty()) {
    if (t.slots.size() != t.vertices)
      return fmt::format("{} slots for {} vertices", t.slots.size(), t.vertices);
    std::uint32_t next = 0;
    for (std::size_t v = 0; v < t.vertices; ++v) {
      if (t.slots[v] == ZhTransfer::kAnalytic) continue;
      if (t.slots[v] != next) return fmt::format("slot of vertex {} is {}; expected {}", v, t.slots[v], next);
      ++next;
    }
    stored = next;
  }
  if (t.axes.size() != stored * t.axes_stride())
    return fmt::format("{} axis values for {} stored vertices of {} lobes (expected {})", t.axes.size(), stored,
                       t.lobes, stored * t.axes_stride());
  if (t.coeffs.size() != stored * t.coeffs_stride())
    return fmt::format("{} coefficients for {} stored vertices (expected {})", t.coeffs.size(), stored,
                       stored * t.coeffs_stride());
  // Unit axes: the fit writes them normalised in double and rounded to
  // float (|a| within a few 1e-7 of 1); 1e-3 leaves room for any careful
  // writer and still refuses a zero or unnormalised axis.
  for (std::size_t i = 0; i < t.axes.size(); i += 3) {
    const double x = t.axes[i], y = t.axes[i + 1], z = t.axes[i + 2];
    const double len = std::sqrt(x * x + y * y + z * z);
    if (!(std::abs(len - 1.0) <= 1e-3))
      return fmt::format("axis {} of stored vertex {} is not a unit vector (length {})", (i / 3) % t.lobes,
                         i / t.axes_stride(), len);
  }
  for (std::size_t i = 0; i < t.coeffs.size(); ++i)
    if (!std::isfinite(t.coeffs[i]))
      return fmt::format("coefficient {} of stored vertex {} is not finite", i % t.coeffs_stride(), i / t.coeffs_stride());
  if (!t.rest_ao.empty() && t.rest_ao.size() != t.vertices)
    return fmt::format("{} rest occlusion values for {} vertices (one per vertex, or none)", t.rest_ao.size(),
                       t.vertices);
  for (std::size_t v = 0; v < t.rest_ao.size(); ++v)
    if (!(t.rest_ao[v] >= 0.0f && t.rest_ao[v] <= 1.0f))
      return fmt::format("rest occlusion of vertex {} is {}; must be in [0, 1]", v, t.rest_ao[v]);
  return {};
}

void check_pose(const ZhTransfer& t, const Mesh& posed, const std::string& what) {
  if (posed.vertex_count() != t.vertices || topology_hash(posed) != t.topology_hash)
    throw Error(fmt::format("{} cannot pose {}: a pose must have the rest pose's {} vertices and its triangles "
                            "(topology hash 0x{:016x}); {} has {} vertices, topology hash 0x{:016x}",
                            posed.source, what, t.vertices, t.topology_hash, posed.source, posed.vertex_count(),
                            topology_hash(posed)));
  if (t.vertex_colors && posed.colors.size() != posed.vertex_count())
    throw Error(fmt::format("{} uses vertex colours as albedo, but the pose {} has none", what, posed.source));
}

std::vector<float> posed_transfer(const ZhTransfer& t, const Mesh& posed, PoseReport* report) {
  if (auto p = zh_transfer_problem(t); !p.empty()) throw Error("posing a zonal-harmonic transfer: " + p);
  check_pose(t, posed, "the zonal-harmonic transfer");
  const VertexFrames frames = vertex_frames(posed);
  const int n = t.bands, K = t.lobes, C = t.channels, nc = n * n;
  const std::size_t out_stride = std::size_t(C) * nc;
  std::vector<float> out(t.vertices * out_stride, 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, t.vertices, 256), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<double> axes(std::size_t(K) * 3), g(std::size_t(K) * n), lobe_sh(static_cast<std::size_t>(nc)), row(out_stride);
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      if (frames.kinds[v] == FrameKind::None) continue;  // no posed frame: zero transfer
      float* o = out.data() + v * out_stride;
      if (t.is_analytic(v)) {
        const glm::vec3 rho = t.vertex_colors ? glm::clamp(posed.colors[v], 0.0f, 1.0f) : t.albedo;
        analytic_transfer(n, C, posed.normals[v], rho, row.data());
        for (std::size_t k = 0; k < out_stride; ++k) o[k] = float(row[k]);
        continue;
      }
      const std::size_t s = t.row(v);
      const glm::mat3& F = frames.frames[v];
      const float* a = t.axes.data() + s * t.axes_stride();
      for (int i = 0; i < K; ++i) {
        const glm::dvec3 w = glm::dmat3(F) * glm::dvec3(a[3 * i], a[3 * i + 1], a[3 * i + 2]);
        const double len = glm::length(w);
        for (int c = 0; c < 3; ++c) axes[std::size_t(3 * i + c)] = w[c] / len;
      }
      const float* gc = t.coeffs.data() + s * t.coeffs_stride();
      for (int c = 0; c < C; ++c) {
        for (std::size_t k = 0; k < g.size(); ++k) g[k] = gc[std::size_t(c) * K * n + k];
        zh::to_sh<double>(n, K, axes.data(), g.data(), lobe_sh.data());
        for (int k = 0; k < nc; ++k) o[std::size_t(c) * nc + k] = float(lobe_sh[std::size_t(k)]);
      }
    }
  });
  if (report) {
    *report = {};
    for (FrameKind k : frames.kinds) {
      report->no_frame += k == FrameKind::None;
      report->normal_only += k == FrameKind::Normal;
    }
  }
  return out;
}

std::vector<float> dynamic_ao_factor(const ZhTransfer& t, const Mesh& posed, const DynamicAoOptions& options) {
  if (t.rest_ao.size() != t.vertices)
    throw Error("the zonal-harmonic transfer holds no rest occlusion: compute it with prt precompute --basis zh "
                "--dynamic-ao (prt::dynamic_ao of the rest pose)");
  check_pose(t, posed, "the zonal-harmonic transfer");
  std::vector<float> f = dynamic_ao(posed, options);
  for (std::size_t v = 0; v < f.size(); ++v) f[v] = (f[v] + kAoFloor) / (t.rest_ao[v] + kAoFloor);
  return f;
}

Transfer posed_as_transfer(const ZhTransfer& t, const Mesh& posed, PoseReport* report) {
  Transfer out;
  out.coeffs = posed_transfer(t, posed, report);
  out.bands = t.bands;
  out.channels = t.channels;
  out.mode = t.mode;
  out.bounces = t.bounces;
  out.samples = t.samples;
  out.albedo = t.albedo;
  out.vertex_colors = t.vertex_colors;
  out.seed = t.seed;
  out.vertices = t.vertices;
  out.mesh_hash = posed.hash();
  out.shading_hash = shading_hash(posed, t.vertex_colors);
  return out;
}

}  // namespace prt
