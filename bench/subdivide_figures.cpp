// The figures of docs/PRECOMPUTE.md, "Subdividing coarse meshes": for each
// mesh and TOL, the refined mesh's vertices and rounds, its time against a
// plain precompute of the coarse mesh (both in this process), the edges'
// transfer differences before and after (the metric of TOL), and the error
// of the transfer drawn inside the triangles (interpolated from the
// corners, as a renderer does) against the transfer traced there, at
// random points of the surface (area-uniform; each with the corners'
// interpolated normal).
//   prt_subdivide_figures MESH... [--tol T]... [--bands N] [--samples S] [--points P] [--threads N]
//                         [--max-vertices N] (default 0: 4x each mesh's)
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/sh.h>
#include <prt/transfer.h>

#include <fmt/core.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

using namespace prt;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// SubdivideOptions::tolerance's metric, its scale from the coarse mesh's rows.
struct Metric {
  std::vector<double> w;
  int channels = 1;
  std::size_t stride = 0;
  double ref = 0;
  Metric(const Transfer& t, const Mesh& m) : channels(t.channels), stride(t.stride()) {
    w.resize(std::size_t(t.bands) * t.bands);
    for (int l = 0; l < t.bands; ++l)
      for (int k = -l; k <= l; ++k) w[std::size_t(sh::index(l, k))] = 1.0 / ((l + 1.0) * (l + 1.0));
    const std::vector<float> rows = dense_transfer(t, m);
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t v = 0; v < m.vertex_count(); ++v)
      if (m.normals[v] != glm::vec3(0.0f)) sum += square(rows.data() + v * stride, nullptr), ++n;
    ref = std::sqrt(sum / double(std::max<std::size_t>(n, 1)));
  }
  double square(const float* a, const double* b) const {
    double s = 0;
    for (int c = 0; c < channels; ++c)
      for (std::size_t k = 0; k < w.size(); ++k) {
        const double d = a[std::size_t(c) * w.size() + k] - (b ? b[std::size_t(c) * w.size() + k] : 0.0);
        s += w[k] * d * d;
      }
    return s / channels;
  }
  double distance(const float* a, const double* b) const { return std::sqrt(square(a, b)) / ref; }
};

// The largest and the RMS difference over the edges with both ends' normals.
std::pair<double, double> edge_differences(const Transfer& t, const Mesh& m, const Metric& metric) {
  const std::vector<float> rows = dense_transfer(t, m);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const glm::uvec3& tri : m.triangles)
    for (int k = 0; k < 3; ++k) edges.emplace_back(std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3]));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  double worst = 0, sum = 0;
  std::size_t n = 0;
  std::vector<double> b(metric.stride);
  for (const auto& [a, c] : edges) {
    if (m.normals[a] == glm::vec3(0.0f) || m.normals[c] == glm::vec3(0.0f)) continue;
    for (std::size_t k = 0; k < metric.stride; ++k) b[k] = rows[c * metric.stride + k];
    const double d = metric.distance(rows.data() + a * metric.stride, b.data());
    worst = std::max(worst, d);
    sum += d * d;
    ++n;
  }
  return {worst, std::sqrt(sum / double(std::max<std::size_t>(n, 1)))};
}

// Random points of the coarse mesh's surface, area-uniform: the triangle,
// its barycentrics, position and interpolated normal.
struct Samples {
  std::vector<std::uint32_t> tri;
  std::vector<glm::dvec3> bary;
  SamplePoints points;
};

Samples sample_surface(const Mesh& m, std::size_t count) {
  std::vector<double> cdf;
  double total = 0;
  for (const glm::uvec3& t : m.triangles) {
    const glm::dvec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
    total += 0.5 * glm::length(glm::cross(b - a, c - a));
    cdf.push_back(total);
  }
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Samples s;
  while (s.tri.size() < count) {
    const std::size_t t = std::size_t(std::lower_bound(cdf.begin(), cdf.end(), u(rng) * total) - cdf.begin());
    if (t >= m.triangles.size()) continue;
    const double r1 = std::sqrt(u(rng)), r2 = u(rng);
    const glm::dvec3 w(1 - r1, r1 * (1 - r2), r1 * r2);
    const glm::uvec3 c = m.triangles[t];
    const glm::dvec3 n = w.x * glm::dvec3(m.normals[c.x]) + w.y * glm::dvec3(m.normals[c.y]) + w.z * glm::dvec3(m.normals[c.z]);
    if (!(glm::length(n) > 1e-6)) continue;
    s.tri.push_back(std::uint32_t(t));
    s.bary.push_back(w);
    s.points.positions.emplace_back(w.x * glm::dvec3(m.positions[c.x]) + w.y * glm::dvec3(m.positions[c.y]) +
                                    w.z * glm::dvec3(m.positions[c.z]));
    s.points.normals.emplace_back(glm::normalize(n));
  }
  return s;
}

// A uniform grid over the refined mesh's triangles (by bounding box), to
// find the one a point of the coarse surface lies in.
class TriangleGrid {
 public:
  explicit TriangleGrid(const Mesh& m) : m_(m) {
    lo_ = glm::dvec3(m.bounds_min());
    const glm::dvec3 hi = glm::dvec3(m.bounds_max());
    const int res = std::max(1, int(std::cbrt(double(m.triangles.size()))));
    res_ = glm::ivec3(res);
    cell_ = glm::max((hi - lo_) / double(res), glm::dvec3(1e-12));
    cells_.resize(std::size_t(res) * res * res);
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      glm::dvec3 a(m.positions[m.triangles[t].x]), b(m.positions[m.triangles[t].y]), c(m.positions[m.triangles[t].z]);
      const glm::ivec3 i0 = index(glm::min(a, glm::min(b, c))), i1 = index(glm::max(a, glm::max(b, c)));
      for (int z = i0.z; z <= i1.z; ++z)
        for (int y = i0.y; y <= i1.y; ++y)
          for (int x = i0.x; x <= i1.x; ++x) cells_[flat({x, y, z})].push_back(std::uint32_t(t));
    }
  }
  // The triangle coplanar with `normal`'s face holding p, and p's barycentrics in it (-1: none).
  long find(const glm::dvec3& p, const glm::dvec3& face_normal, glm::dvec3& w) const {
    const double scale = glm::length(cell_);
    for (std::uint32_t t : cells_[flat(index(p))]) {
      const glm::uvec3 c = m_.triangles[t];
      const glm::dvec3 a(m_.positions[c.x]), b(m_.positions[c.y]), d(m_.positions[c.z]);
      const glm::dvec3 n = glm::cross(b - a, d - a);
      const double len = glm::length(n);
      if (!(len > 0) || glm::dot(n / len, face_normal) < 0.9999) continue;
      if (std::abs(glm::dot(p - a, n / len)) > 1e-6 * scale) continue;
      const double wb = glm::dot(glm::cross(p - a, d - a), n) / (len * len);
      const double wc = glm::dot(glm::cross(b - a, p - a), n) / (len * len);
      if (wb < -1e-7 || wc < -1e-7 || wb + wc > 1 + 1e-7) continue;
      w = glm::dvec3(1 - wb - wc, wb, wc);
      return long(t);
    }
    return -1;
  }

 private:
  glm::ivec3 index(const glm::dvec3& p) const {
    return glm::clamp(glm::ivec3(glm::floor((p - lo_) / cell_)), glm::ivec3(0), res_ - 1);
  }
  std::size_t flat(const glm::ivec3& i) const {
    return (std::size_t(i.z) * std::size_t(res_.y) + std::size_t(i.y)) * std::size_t(res_.x) + std::size_t(i.x);
  }
  const Mesh& m_;
  glm::dvec3 lo_, cell_;
  glm::ivec3 res_;
  std::vector<std::vector<std::uint32_t>> cells_;
};

// RMS (and 95th percentile) over the samples of the difference between the
// transfer interpolated from `m`'s corners and the traced one.
std::pair<double, double> point_error(const Transfer& t, const Mesh& m, const Mesh& coarse, const Samples& s,
                                      const Transfer& traced, const Metric& metric) {
  const std::vector<float> rows = dense_transfer(t, m);
  const TriangleGrid grid(m);
  std::vector<double> errors;
  std::vector<float> interp(metric.stride);
  std::vector<double> truth(metric.stride);
  for (std::size_t i = 0; i < s.tri.size(); ++i) {
    const glm::uvec3 c0 = coarse.triangles[s.tri[i]];
    const glm::dvec3 a(coarse.positions[c0.x]), b(coarse.positions[c0.y]), d(coarse.positions[c0.z]);
    const glm::dvec3 face = glm::normalize(glm::cross(b - a, d - a));
    const glm::dvec3 p = s.bary[i].x * a + s.bary[i].y * b + s.bary[i].z * d;
    glm::dvec3 w;
    const long t_in = grid.find(p, face, w);
    if (t_in < 0) continue;
    const glm::uvec3 c = m.triangles[std::size_t(t_in)];
    for (std::size_t k = 0; k < metric.stride; ++k) {
      interp[k] = float(w.x * rows[c.x * metric.stride + k] + w.y * rows[c.y * metric.stride + k] +
                        w.z * rows[c.z * metric.stride + k]);
      truth[k] = traced.coeffs[i * metric.stride + k];
    }
    errors.push_back(metric.distance(interp.data(), truth.data()));
  }
  double sum = 0;
  for (double e : errors) sum += e * e;
  std::sort(errors.begin(), errors.end());
  return {std::sqrt(sum / double(std::max<std::size_t>(errors.size(), 1))),
          errors.empty() ? 0.0 : errors[std::size_t(0.95 * double(errors.size() - 1))]};
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> meshes;
  std::vector<double> tols;
  TransferOptions o;
  std::size_t points = 20000, max_vertices = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        fmt::print(stderr, "{} needs a value\n", arg);
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--tol") tols.push_back(std::stod(value()));
    else if (arg == "--bands") o.bands = std::stoi(value());
    else if (arg == "--samples") o.samples = std::stoi(value());
    else if (arg == "--points") points = std::stoul(value());
    else if (arg == "--threads") o.threads = std::stoi(value());
    else if (arg == "--max-vertices") max_vertices = std::stoul(value());
    else meshes.push_back(arg);
  }
  if (meshes.empty()) {
    fmt::print(stderr, "usage: prt_subdivide_figures MESH... [--tol T]... [--bands N] [--samples S] [--points P] "
                       "[--threads N] [--max-vertices N]\n");
    return 2;
  }
  if (tols.empty()) tols = {0.05, 0.02};
  o.albedo = glm::vec3(0.8f);
  fmt::print("{} bands, {} samples, albedo 0.8, shadowed; inside the triangles: {} random points\n\n", o.bands, o.samples,
             points);
  fmt::print("| mesh | TOL | vertices | rounds | edges split | time (x coarse, x refined) | edge difference max / RMS "
             "| inside the triangles RMS / p95 |\n|---|---|---|---|---|---|---|---|\n");
  for (const std::string& path : meshes) {
    const Mesh m = load_mesh(path);
    auto t0 = std::chrono::steady_clock::now();
    const Transfer plain = compute_transfer(m, o);
    const double plain_s = seconds_since(t0);
    const Metric metric(plain, m);
    const auto before = edge_differences(plain, m, metric);
    const Samples s = sample_surface(m, points);
    const Transfer traced = compute_point_transfer(m, s.points, o);
    const auto inside_before = point_error(plain, m, m, s, traced, metric);
    const std::string name = std::filesystem::path(path).filename().string();
    fmt::print("| {} | (coarse) | {} | - | - | {:.2f} s | {:.3f} / {:.3f} | {:.4f} / {:.4f} |\n", name, m.vertex_count(), plain_s,
               before.first, before.second, inside_before.first, inside_before.second);
    // tol 0: every edge split once (uniform midpoint subdivision, one round), for comparison.
    std::vector<double> runs = tols;
    runs.push_back(0);
    for (double tol : runs) {
      SubdivideOptions so;
      so.tolerance = tol > 0 ? tol : 1e-9;
      so.max_vertices = tol > 0 ? max_vertices : 100 * m.vertex_count();
      if (tol == 0) so.max_rounds = 1;
      SubdivideReport r;
      const Subdivided d = subdivide_for_transfer(m, o, so, {}, &r);
      t0 = std::chrono::steady_clock::now();
      const Transfer refined_plain = compute_transfer(d.mesh, o);
      const double refined_s = seconds_since(t0);
      const auto after = edge_differences(d.transfer, d.mesh, metric);
      const auto inside = point_error(d.transfer, d.mesh, m, s, traced, metric);
      fmt::print("| {} | {} | {} -> {}{} | {} | {} | {:.2f} s ({:.1f}x, {:.1f}x) | {:.3f} / {:.3f} | {:.4f} / {:.4f} |\n",
                 name, tol > 0 ? fmt::format("{}", tol) : std::string("uniform"), r.input_vertices, r.vertices,
                 r.capped ? " (capped)" : "", r.rounds, r.split_edges, r.seconds, r.seconds / plain_s,
                 r.seconds / refined_s, after.first, after.second, inside.first, inside.second);
      if (refined_plain.coeffs != d.transfer.coeffs) fmt::print(stderr, "{}: the refined transfer is not compute_transfer's\n", name);
    }
  }
  return 0;
}
