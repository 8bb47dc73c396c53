// The dipole's surface integral (prt/subsurface_scatter.h): the sources in
// an octree of area-weighted clusters, each receiver summing clusters whole
// where they subtend a small solid angle (Jensen & Buhler 2002) and points
// one by one elsewhere.
#include <prt/error.h>
#include <prt/subsurface_scatter.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>

namespace prt {

std::vector<double> vertex_areas(const Mesh& mesh) {
  std::vector<double> area(mesh.positions.size(), 0.0);
  for (const glm::uvec3& t : mesh.triangles) {
    const glm::dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
    const double third = glm::length(glm::cross(b - a, c - a)) / 6.0;
    area[t.x] += third;
    area[t.y] += third;
    area[t.z] += third;
  }
  return area;
}

namespace {

// A cluster of source points: order[first, first + count), its children
// nodes[child, child + children) (none: a leaf), its area and area-weighted
// centre; sums[node * nc + k] = sum of A_i in[i][k] over its points.
struct Node {
  glm::dvec3 centre{0.0};
  double area = 0.0;
  std::uint32_t first = 0, count = 0;
  std::uint32_t child = 0, children = 0;
};

// Leaves hold at most this many points: below it a cluster's aggregate
// costs about what its points do.
constexpr std::uint32_t kLeafPoints = 8;
constexpr int kMaxDepth = 32;  // coincident points stop the splitting here

struct Octree {
  std::vector<Node> nodes;
  std::vector<std::uint32_t> order;
  std::vector<double> sums;
};

// Splits `n` into up to 8 children by its points' box centre; false (a leaf)
// when they would all land in one.
bool split(Octree& t, std::uint32_t n, const std::vector<glm::dvec3>& pos) {
  const Node node = t.nodes[n];
  auto* first = t.order.data() + node.first;
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (std::uint32_t i = 0; i < node.count; ++i) {
    lo = glm::min(lo, pos[first[i]]);
    hi = glm::max(hi, pos[first[i]]);
  }
  const glm::dvec3 mid = 0.5 * (lo + hi);
  const auto octant = [&](std::uint32_t p) {
    return (pos[p].x > mid.x ? 1 : 0) | (pos[p].y > mid.y ? 2 : 0) | (pos[p].z > mid.z ? 4 : 0);
  };
  std::array<std::uint32_t, 9> start{};
  for (std::uint32_t i = 0; i < node.count; ++i) ++start[std::size_t(octant(first[i])) + 1];
  if (*std::max_element(start.begin(), start.end()) == node.count) return false;
  for (std::size_t o = 1; o < start.size(); ++o) start[o] += start[o - 1];
  std::vector<std::uint32_t> sorted(node.count);
  std::array<std::uint32_t, 8> at{};
  for (std::uint32_t i = 0; i < node.count; ++i) {
    const int o = octant(first[i]);
    sorted[start[std::size_t(o)] + at[std::size_t(o)]++] = first[i];
  }
  std::copy(sorted.begin(), sorted.end(), first);
  t.nodes[n].child = std::uint32_t(t.nodes.size());
  for (std::size_t o = 0; o < 8; ++o) {
    const std::uint32_t count = start[o + 1] - start[o];
    if (count == 0) continue;
    Node c;
    c.first = node.first + start[o];
    c.count = count;
    t.nodes.push_back(c);
    ++t.nodes[n].children;
  }
  return true;
}

Octree build_octree(const std::vector<glm::dvec3>& pos, const std::vector<double>& area, std::span<const float> in,
                    int nc) {
  Octree t;
  for (std::uint32_t i = 0; i < pos.size(); ++i)
    if (area[i] > 0) t.order.push_back(i);
  Node root;
  root.count = std::uint32_t(t.order.size());
  t.nodes.push_back(root);
  std::vector<int> depth{0};
  for (std::uint32_t n = 0; n < t.nodes.size(); ++n)  // children come after their parent
    if (t.nodes[n].count > kLeafPoints && depth[n] < kMaxDepth && split(t, n, pos))
      depth.resize(t.nodes.size(), depth[n] + 1);
  // The aggregates, children before parents.
  t.sums.assign(t.nodes.size() * std::size_t(nc), 0.0);
  for (std::size_t n = t.nodes.size(); n-- > 0;) {
    Node& node = t.nodes[n];
    double* s = t.sums.data() + n * std::size_t(nc);
    glm::dvec3 weighted(0.0);
    if (node.children == 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        const std::uint32_t p = t.order[i];
        node.area += area[p];
        weighted += area[p] * pos[p];
        for (int k = 0; k < nc; ++k) s[k] += area[p] * double(in[std::size_t(p) * std::size_t(nc) + std::size_t(k)]);
      }
    } else {
      for (std::uint32_t c = node.child; c < node.child + node.children; ++c) {
        node.area += t.nodes[c].area;
        weighted += t.nodes[c].area * t.nodes[c].centre;
        for (int k = 0; k < nc; ++k) s[k] += t.sums[std::size_t(c) * std::size_t(nc) + std::size_t(k)];
      }
    }
    node.centre = node.area > 0 ? weighted / node.area : glm::dvec3(0.0);
  }
  return t;
}

}  // namespace

std::vector<float> subsurface_scatter(const Mesh& mesh, const SubsurfaceMaterial& material,
                                      std::span<const float> in, int nc, const SubsurfaceScatterOptions& o) {
  check_subsurface_material(material, "subsurface material");
  if (!(std::isfinite(o.length_scale) && o.length_scale > 0))
    throw Error(fmt::format("the length scale must be > 0 (mm per mesh unit), got {}", o.length_scale));
  if (!(std::isfinite(o.max_solid_angle) && o.max_solid_angle >= 0))
    throw Error(fmt::format("the largest solid angle of a cluster taken whole must be >= 0, got {}", o.max_solid_angle));
  const std::size_t V = mesh.positions.size();
  if (nc < 1 || in.size() != V * std::size_t(nc))
    throw Error(fmt::format("subsurface scatter: {} floats of irradiance for {} vertices x {} coefficients", in.size(),
                            V, nc));
  std::vector<glm::dvec3> pos(V);
  for (std::size_t i = 0; i < V; ++i) pos[i] = glm::dvec3(mesh.positions[i]);
  const std::vector<double> area = vertex_areas(mesh);
  const Octree tree = build_octree(pos, area, in, nc);
  const std::array<Dipole, 3> dipole = {Dipole(material.sigma_a.x, material.sigma_s.x, material.eta),
                                        Dipole(material.sigma_a.y, material.sigma_s.y, material.eta),
                                        Dipole(material.sigma_a.z, material.sigma_s.z, material.eta)};
  const double S = o.length_scale, S2 = S * S, eps = o.max_solid_angle;
  for (const std::uint32_t r : o.receivers)
    if (r >= V) throw Error(fmt::format("subsurface scatter: receiver {} of a mesh of {} vertices", r, V));
  const std::size_t stride = 3 * std::size_t(nc), R = o.receivers.empty() ? V : o.receivers.size();
  std::vector<float> out(R * stride, 0.0f);
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, R, 64), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<double> acc(stride);
    std::vector<std::uint32_t> stack;
    for (std::size_t row = range.begin(); row < range.end(); ++row) {
      const std::size_t v = o.receivers.empty() ? row : o.receivers[row];
      std::fill(acc.begin(), acc.end(), 0.0);
      // Adds weight x R_d(S d) per channel times `rows` (nc values).
      const auto add = [&](double d, double weight, const auto* rows) {
        for (int c = 0; c < 3; ++c) {
          const double r = weight * dipole[std::size_t(c)].rd(S * d);
          for (int k = 0; k < nc; ++k) acc[std::size_t(c) * std::size_t(nc) + std::size_t(k)] += r * double(rows[k]);
        }
      };
      stack.assign(1, 0);
      while (!tree.order.empty() && !stack.empty()) {
        const Node& node = tree.nodes[stack.back()];
        const std::size_t n = stack.back();
        stack.pop_back();
        if (node.children == 0) {
          for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
            const std::uint32_t p = tree.order[i];
            add(glm::length(pos[v] - pos[p]), S2 * area[p], in.data() + std::size_t(p) * std::size_t(nc));
          }
          continue;
        }
        const double d2 = glm::dot(pos[v] - node.centre, pos[v] - node.centre);
        if (node.area < eps * d2) {  // small seen from here: the cluster whole
          add(std::sqrt(d2), S2, tree.sums.data() + n * std::size_t(nc));
          continue;
        }
        for (std::uint32_t c = node.child; c < node.child + node.children; ++c) stack.push_back(c);
      }
      for (std::size_t q = 0; q < stride; ++q) out[row * stride + q] = float(acc[q] / std::numbers::pi);
    }
  });
  return out;
}

Transfer compute_subsurface_transfer(const Mesh& mesh, const TransferOptions& options,
                                     const SubsurfaceMaterial& material, const SubsurfaceScatterOptions& scatter) {
  check_subsurface_material(material, "subsurface material");
  if (!scatter.receivers.empty())
    throw Error("compute_subsurface_transfer: every vertex receives (SubsurfaceScatterOptions::receivers must be empty)");
  TransferOptions o = options;
  o.mode = TransferMode::Shadowed;
  o.bounces = 0;
  o.albedo = glm::vec3(1.0f);
  o.vertex_colors = false;
  o.transmission_eta = material.eta;
  Transfer t = compute_transfer(mesh, o);
  PRT_CHECK(t.channels == 1 && t.analytic_vertices() == 0);
  const int nc = t.bands * t.bands;
  std::vector<float> in(t.vertices * std::size_t(nc));
  for (std::size_t v = 0; v < t.vertices; ++v)
    for (int k = 0; k < nc; ++k)  // pi S: the transmitted irradiance's rows
      in[v * std::size_t(nc) + std::size_t(k)] = float(std::numbers::pi * t.coeffs[t.row(v) * std::size_t(nc) + std::size_t(k)]);
  t.coeffs = subsurface_scatter(mesh, material, in, nc, scatter);
  t.channels = 3;
  t.slots.clear();
  return t;
}

}  // namespace prt
