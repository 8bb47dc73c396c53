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

FrameKind rule_kind(const TangentRule& r, std::uint32_t v) {
  return r.a == v ? FrameKind::Normal : r.a == r.b ? FrameKind::Edge : FrameKind::Uv;
}

namespace {

// Every vertex's unit UV tangent in its tangent plane, or zero: the
// per-triangle dP/du (the direction of increasing u), each projected into
// the vertex's tangent plane and normalised, summed with the corner angles
// as weights; kept where they agree (kUvTangentAgreement).
std::vector<glm::dvec3> uv_tangents(const Mesh& mesh) {
  const std::size_t V = mesh.vertex_count();
  std::vector<glm::dvec3> sum(V, glm::dvec3(0.0));
  std::vector<double> weight(V, 0.0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const glm::uvec3& tri = mesh.triangles[f];
    const glm::dvec3 p[3] = {glm::dvec3(mesh.positions[tri[0]]), glm::dvec3(mesh.positions[tri[1]]),
                             glm::dvec3(mesh.positions[tri[2]])};
    const glm::dvec2 u[3] = {glm::dvec2(mesh.corner_uvs[3 * f]), glm::dvec2(mesh.corner_uvs[3 * f + 1]),
                             glm::dvec2(mesh.corner_uvs[3 * f + 2])};
    const glm::dvec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
    const glm::dvec2 d1 = u[1] - u[0], d2 = u[2] - u[0];
    const double det = d1.x * d2.y - d2.x * d1.y;
    if (!(det != 0) || !(glm::length(glm::cross(e1, e2)) > 0)) continue;  // no UV area or no area
    const glm::dvec3 T = (e1 * d2.y - e2 * d1.y) / det;                   // dP/du
    const double tl = glm::length(T);
    if (!(tl > 0) || !std::isfinite(tl)) continue;
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t v = tri[c];
      const glm::dvec3 n(mesh.normals[v]);
      if (n == glm::dvec3(0.0)) continue;
      const glm::dvec3 proj = T - glm::dot(T, n) * n;
      const double pl = glm::length(proj);
      if (!(pl >= kFrameEdgeMin * tl)) continue;
      const glm::dvec3 a = p[(c + 1) % 3] - p[c], b = p[(c + 2) % 3] - p[c];
      const double angle = std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
      sum[v] += angle * proj / pl;
      weight[v] += angle;
    }
  }
  for (std::size_t v = 0; v < V; ++v) {
    const double len = glm::length(sum[v]);
    sum[v] = weight[v] > 0 && len >= kUvTangentAgreement * weight[v] ? sum[v] / len : glm::dvec3(0.0);
  }
  return sum;
}

}  // namespace

VertexFrames vertex_frames(const Mesh& mesh) {
  const std::size_t V = mesh.vertex_count();
  PRT_CHECK_OP(mesh.normals.size(), ==, V);
  PRT_CHECK(mesh.corner_uvs.empty() || mesh.corner_uvs.size() == 3 * mesh.triangles.size());
  std::vector<TangentRule> rules(V);
  std::vector<bool> set(V, false);
  for (std::size_t v = 0; v < V; ++v) rules[v] = {std::uint32_t(v), std::uint32_t(v), 0.0f, 0.0f};
  const auto pos = [&](std::uint32_t v) { return glm::dvec3(mesh.positions[v]); };
  // The UV tangent, as weights of the edges to the other two corners of the
  // vertex's first triangle (file order) whose edges, projected into the
  // tangent plane, span it: T = wa pe_next + wb pe_prev.
  if (!mesh.corner_uvs.empty()) {
    const std::vector<glm::dvec3> T = uv_tangents(mesh);
    for (const glm::uvec3& tri : mesh.triangles)
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t v = tri[c], a = tri[(c + 1) % 3], b = tri[(c + 2) % 3];
        if (set[v] || T[v] == glm::dvec3(0.0)) continue;
        const glm::dvec3 n(mesh.normals[v]), e1 = pos(a) - pos(v), e2 = pos(b) - pos(v);
        const glm::dvec3 p1 = e1 - glm::dot(e1, n) * n, p2 = e2 - glm::dot(e2, n) * n;
        const glm::dvec3 x = glm::cross(p1, p2);
        const double xx = glm::dot(x, x);
        if (!(std::sqrt(xx) >= kFrameEdgeMin * glm::length(e1) * glm::length(e2)) || !(xx > 0)) continue;
        rules[v] = {a, b, float(glm::dot(glm::cross(T[v], p2), x) / xx), float(glm::dot(glm::cross(p1, T[v]), x) / xx)};
        set[v] = true;
      }
  }
  // The edge rule: triangles in file order; in each, the edge to the next
  // corner then to the previous one; the first whose part in the tangent
  // plane is long enough.
  for (const glm::uvec3& tri : mesh.triangles)
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t v = tri[c];
      if (set[v]) continue;
      const glm::dvec3 n(mesh.normals[v]);
      if (n == glm::dvec3(0.0)) continue;
      for (const std::uint32_t w : {tri[(c + 1) % 3], tri[(c + 2) % 3]}) {
        const glm::dvec3 e = pos(w) - pos(v);
        const double len = glm::length(e);
        const double plen = glm::length(e - glm::dot(e, n) * n);
        if (!(len > 0) || !(plen >= kFrameEdgeMin * len)) continue;
        rules[v] = {w, w, 1.0f, 0.0f};
        set[v] = true;
        break;
      }
    }
  // The rest frames are the rules evaluated at rest: the same code as a pose.
  return posed_frames(mesh, rules);
}

VertexFrames posed_frames(const Mesh& posed, const std::vector<TangentRule>& rules) {
  const std::size_t V = posed.vertex_count();
  PRT_CHECK_OP(posed.normals.size(), ==, V);
  PRT_CHECK_OP(rules.size(), ==, V);
  VertexFrames f;
  f.frames.assign(V, glm::mat3(1.0f));
  f.kinds.assign(V, FrameKind::None);
  f.rules = rules;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, V, 1024), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t v = range.begin(); v < range.end(); ++v) {
      const glm::vec3 n = posed.normals[v];
      if (n == glm::vec3(0.0f)) continue;
      const TangentRule& r = rules[v];
      PRT_CHECK(r.a < V && r.b < V);
      f.kinds[v] = FrameKind::Normal;
      f.frames[v] = normal_basis(n);
      if (r.a == v) continue;
      const glm::dvec3 p(posed.positions[v]), nd(n);
      const glm::dvec3 e =
          double(r.wa) * (glm::dvec3(posed.positions[r.a]) - p) + double(r.wb) * (glm::dvec3(posed.positions[r.b]) - p);
      const double len = glm::length(e);
      const glm::dvec3 proj = e - glm::dot(e, nd) * nd;
      const double plen = glm::length(proj);
      if (!(len > 0) || !(plen >= kFrameEdgeMin * len)) continue;
      const glm::dvec3 t = proj / plen;
      f.frames[v] = glm::mat3(glm::vec3(t), glm::vec3(glm::cross(nd, t)), n);
      f.kinds[v] = rule_kind(r, std::uint32_t(v));
    }
  });
  return f;
}

std::uint64_t topology_hash(const Mesh& mesh) {
  Hasher h;
  h.add_value(std::uint64_t(mesh.vertex_count()));
  h.add(mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3));
  return h.digest();
}

TangentCounts tangent_counts(const ZhTransfer& t) {
  TangentCounts c;
  for (std::size_t v = 0; v < t.tangents.size(); ++v) switch (rule_kind(t.tangents[v], std::uint32_t(v))) {
      case FrameKind::Uv: ++c.uv; break;
      case FrameKind::Edge: ++c.edge; break;
      default: ++c.none; break;
    }
  return c;
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
  if (t.tangents.size() != t.vertices)
    return fmt::format("{} tangent rules for {} vertices (one per vertex)", t.tangents.size(), t.vertices);
  for (std::size_t v = 0; v < t.vertices; ++v) {
    const TangentRule& r = t.tangents[v];
    if (r.a >= t.vertices || r.b >= t.vertices)
      return fmt::format("the tangent rule of vertex {} names vertex {}, out of range ({} vertices)", v,
                         std::max(r.a, r.b), t.vertices);
    if (!std::isfinite(r.wa) || !std::isfinite(r.wb))
      return fmt::format("the tangent rule of vertex {} has a non-finite weight", v);
    const bool none = r.a == v, edge = !none && r.a == r.b;
    if ((none && (r.b != v || r.wa != 0 || r.wb != 0)) || (!none && r.b == v) || (edge && r.wb != 0))
      return fmt::format("the tangent rule of vertex {} (neighbours {} and {}, weights {} and {}) is none of the "
                         "edge rule (a = b, wb = 0), a UV rule (a, b and the vertex distinct) or no tangent (a = b = "
                         "the vertex, weights 0)",
                         v, r.a, r.b, r.wa, r.wb);
  }
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
  const VertexFrames frames = posed_frames(posed, t.tangents);
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
      report->uv += k == FrameKind::Uv;
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
  out.header() = t.header();
  out.mesh_hash = posed.hash();
  out.shading_hash = shading_hash(posed, t.vertex_colors);
  return out;
}

}  // namespace prt
