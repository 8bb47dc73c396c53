// The dipole's surface integral (prt/subsurface_scatter.h): the sources in
// an octree of area-weighted clusters, each receiver summing clusters whole
// where they subtend a small solid angle (Jensen & Buhler 2002) and points
// one by one elsewhere.
#include <prt/error.h>
#include <prt/subsurface_scatter.h>

#include "progress_ticker.h"
#include "subsurface_samples.h"

#include <fmt/format.h>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
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
#include <numeric>

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
  double m2 = 0.0;  // the area-weighted mean squared distance of its sources' spread from the centre
  glm::dvec3 normal{0.0};  // the area-weighted mean of its sources' normals (shorter where they disagree)
  double radius = 0.0;  // of a sphere about the centre holding its sources (each to its extent)
  std::uint32_t first = 0, count = 0;
  std::uint32_t child = 0, children = 0;
};

// Leaves hold at most this many points: below it a cluster's aggregate
// costs about what its points do.
constexpr std::uint32_t kLeafPoints = 4;
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

// `extent`: how far each source's weight reaches from its centre (a node's
// radius holds its sources whole).
Octree build_octree(const std::vector<glm::dvec3>& pos, std::span<const double> area, std::span<const double> m2,
                    const std::vector<glm::dvec3>& normal, std::span<const double> extent, std::span<const float> in,
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
    double squares = 0.0;  // sum of A (m2 + |x|^2)
    if (node.children == 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        const std::uint32_t p = t.order[i];
        node.area += area[p];
        weighted += area[p] * pos[p];
        squares += area[p] * (m2[p] + glm::dot(pos[p], pos[p]));
        node.normal += area[p] * normal[p];
        for (int k = 0; k < nc; ++k) s[k] += area[p] * double(in[std::size_t(p) * std::size_t(nc) + std::size_t(k)]);
      }
    } else {
      for (std::uint32_t c = node.child; c < node.child + node.children; ++c) {
        node.area += t.nodes[c].area;
        weighted += t.nodes[c].area * t.nodes[c].centre;
        squares += t.nodes[c].area * (t.nodes[c].m2 + glm::dot(t.nodes[c].centre, t.nodes[c].centre));
        node.normal += t.nodes[c].area * t.nodes[c].normal;
        for (int k = 0; k < nc; ++k) s[k] += t.sums[std::size_t(c) * std::size_t(nc) + std::size_t(k)];
      }
    }
    node.centre = node.area > 0 ? weighted / node.area : glm::dvec3(0.0);
    node.m2 = node.area > 0 ? std::max(squares / node.area - glm::dot(node.centre, node.centre), 0.0) : 0.0;
    if (node.area > 0) node.normal /= node.area;
    if (node.children == 0)
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i)
        node.radius = std::max(node.radius, glm::length(pos[t.order[i]] - node.centre) + extent[t.order[i]]);
    else
      for (std::uint32_t c = node.child; c < node.child + node.children; ++c)
        node.radius = std::max(node.radius, t.nodes[c].radius + glm::length(t.nodes[c].centre - node.centre));
  }
  return t;
}

}  // namespace

namespace {

// Gauss-Legendre on [0, 1], 4 nodes: the radial rule of the disc average
// (in the squared radius, so each node stands for an equal share of area).
constexpr std::array<double, 4> kDiscNodes = {0.0694318442029737, 0.3300094782075719, 0.6699905217924281,
                                              0.9305681557970263};
constexpr std::array<double, 4> kDiscWeights = {0.1739274225687269, 0.3260725774312731, 0.3260725774312731,
                                                0.1739274225687269};
// A source closer than this many of its disc radii is averaged over its disc
// (docs/SUBSURFACE.md "Near sources"); farther, its point value with the
// disc's second-order term.
constexpr double kNearDiscs = 3.0;

// The three channels' profiles tabulated at r = reach t^2 for t in [0, 1]
// (dense where the profile peaks, at r = 0) and interpolated linearly in t:
// a lookup instead of each channel's two exponentials. Per entry, per
// channel: R_d, its 2-D Laplacian, and F1(r) = int_0^r R_d s ds (the
// disc's closed form over 2 pi) that integrates R_d over a wedge,
// dR_d / dr, and F2(r) = int_0^r R_d s^2 ds (Simpson's rule between
// entries) that integrates R_d times the distance over a wedge in the
// plane. 16,384 entries keep the
// interpolation within 2e-5 of the profile (tests/test_subsurface_scatter.cpp).
class ProfileTable {
 public:
  static constexpr std::size_t kColumns = 15;  // R_d, Laplacian, slope, F1, F2; three channels each
  ProfileTable(const std::array<Dipole, 3>& d, double reach_mm)
      : reach_(std::max(reach_mm, 1e-30)), scale_((kEntries - 1) / std::sqrt(reach_)) {
    far_.resize(std::size_t(kEntries) * kFar);
    near_.resize(std::size_t(kEntries) * kNear);
    double prev_r = 0.0;
    for (int i = 0; i < kEntries; ++i) {
      const double t = double(i) / (kEntries - 1), r = reach_ * t * t;
      float* e = far_.data() + std::size_t(i) * kFar;
      double* m = near_.data() + std::size_t(i) * kNear;
      for (std::size_t c = 0; c < 3; ++c) {
        e[c] = float(d[c].rd(r));
        e[3 + c] = float(d[c].laplacian(r));
        e[6 + c] = float(d[c].slope(r));
        m[c] = d[c].disc(r) / (2 * std::numbers::pi);
        if (i == 0) continue;  // F2(0) = 0; then Simpson's rule between entries
        const auto g = [&](double x) { return d[c].rd(x) * x * x; };
        m[3 + c] = m[3 + c - kNear] + (r - prev_r) / 6 * (g(prev_r) + 4 * g(0.5 * (prev_r + r)) + g(r));
      }
      prev_r = r;
    }
  }
  // R_d per channel at r mm.
  glm::dvec3 value(double r) const {
    double f[kColumns];
    lookup(r, f, 0, 3);
    return {f[0], f[1], f[2]};
  }
  // The mean of R_d over a source spread in a plane about a point r away,
  // with mean squared radius m2, to second order (isotropic): R_d + m2 / 4
  // times R_d(|y - o|)'s 2-D Laplacian in y over that plane, which is
  // Laplacian(R_d) inplane + (2 / r) dR_d/dr (1 - inplane), `inplane` the
  // share of r^2 along the plane (1: the receiver in it; 0: straight above
  // the source). A uniform disc of radius rho: m2 = rho^2 / 2.
  glm::dvec3 point_mean(double r, double m2, double inplane = 1.0) const {
    double f[kColumns];
    lookup(r, f, 0, 9);
    const double a = m2 / 4 * inplane, b = r > 0 ? m2 / 2 / r * (1 - inplane) : 0.0;
    return {f[0] + a * f[3] + b * f[6], f[1] + a * f[4] + b * f[7], f[2] + a * f[5] + b * f[8]};
  }
  // F1 per channel at r mm.
  glm::dvec3 f1(double r) const {
    double f[kColumns];
    lookup(r, f, 9, 12);
    return {f[9], f[10], f[11]};
  }
  // F1 and F2 per channel at r mm.
  void moments(double r, glm::dvec3& f1, glm::dvec3& f2) const {
    double f[kColumns];
    lookup(r, f, 9, 15);
    f1 = {f[9], f[10], f[11]};
    f2 = {f[12], f[13], f[14]};
  }

 private:
  static constexpr int kEntries = 16384;
  // The columns every source reads (R_d, Laplacian, slope) in floats, 0.6
  // MB that stay in cache (float's 6e-8 is far below the interpolation's
  // 2e-5); the near field's F1 and F2, whose differences cancel, in doubles.
  static constexpr std::size_t kFar = 9, kNear = 6;
  // Columns [from, to) at r into f[from, to): [0, 9) from the far table,
  // [9, 15) from the near one.
  void lookup(double r, double* f, std::size_t from, std::size_t to) const {
    const double t = r > 0 ? std::min(std::sqrt(r) * scale_, double(kEntries - 1)) : 0.0;  // NaN: 0
    const int i = std::min(int(t), kEntries - 2);
    const double u = t - i;
    const float* a = far_.data() + std::size_t(i) * kFar;
    for (std::size_t k = from; k < std::min(to, kFar); ++k) f[k] = double(a[k]) + u * (double(a[k + kFar]) - double(a[k]));
    const double* b = near_.data() + std::size_t(i) * kNear;
    for (std::size_t k = std::max(from, kFar); k < to; ++k)
      f[k] = b[k - kFar] + u * (b[k - kFar + kNear] - b[k - kFar]);
  }
  double reach_, scale_;
  std::vector<float> far_;
  std::vector<double> near_;
};

// The angular rule of a wedge: Gauss-Legendre, 4 nodes on each side of
// the edge's nearest point.
constexpr const std::array<double, 4>& kWedgeNodes = kDiscNodes;
constexpr const std::array<double, 4>& kWedgeWeights = kDiscWeights;

// W[j] = int over triangle p (mm) of R_d(|x - o|) b_j(x) dA, b_j its corners'
// barycentric functions (so sum_j W[j] E_j is the profile's integral over
// the triangle of irradiance linear across it), per channel. With q the
// receiver o projected onto the triangle's plane and h its height over it,
// |x - o|^2 = |x - q|^2 + h^2, and b_j(x) = b_j(q) + grad b_j . (x - q):
//   W[j] = b_j(q) I0 + grad b_j . I1,
//   I0 = int R_d dA, I1 = int R_d (x - q) dA = the boundary integral of
//   F1_h(|x - q|) times the edges' outward normals (R_d (x - q) is the
//   gradient of F1_h(|x - q|), F1_h(s) = int_0^s R_d(sqrt(t^2 + h^2)) t dt
//   = F1(sqrt(s^2 + h^2)) - F1(|h|), the table's disc),
// I0 as the signed sum of the three wedges (q, p_k, p_k+1), each in polar
// coordinates about q: int dphi F1_h(r(phi)), Gauss-Legendre in the angle
// split where r(phi) is least. I1, for a triangle whose plane passes within
// kFlat of the profile's width of o (the receiver's own triangles), from
// the same wedges: int dphi e(phi) F2(r(phi)), F2 = int_0^r R_d s^2 ds; for
// the others, by Gauss-Legendre along each edge in t = t* + a sinh(v) about
// the edge's point nearest q (nodes dense where F1_h changes, over the
// profile's width there). Exact but for the rules (and, in the plane, h).
constexpr std::array<double, 8> kEdgeNodes = {0.0198550717512319, 0.1016667612931866, 0.2372337950418355,
                                              0.4082826787521751, 0.5917173212478249, 0.7627662049581645,
                                              0.8983332387068134, 0.9801449282487681};
constexpr std::array<double, 8> kEdgeWeights = {0.0506142681451881, 0.1111905172266872, 0.1568533229389436,
                                                0.1813418916891810, 0.1813418916891810, 0.1568533229389436,
                                                0.1111905172266872, 0.0506142681451881};

constexpr int kEdgePieces = 2;  // the rule on each of two halves of the mapped edge

// int over a uniform disc of radius rho (mm) of R_d(|x - o|) dA, per
// channel, o at distance d (mm) from the disc's centre along its plane and
// h over it: in polar coordinates about o's projection q,
//   int dphi [F1(sqrt(s^2 + h^2)) - F1(|h|)]
// between the boundary's distances s from q in each direction (the
// profile's peak at q is inside F1, not sampled). q inside the disc:
// Gauss-Legendre on [0, pi/2] and [pi/2, pi] (s has a kink at pi/2 when q
// is on the rim); outside: in theta, sin phi = (rho / d) sin theta, which
// takes the square root at the tangent directions away. The points path's
// near field: a texel of a translucent lightmap over another's receiver
// (a box's bottom on the floor under it) or beside it.
glm::dvec3 disc_integral(const ProfileTable& table, double d, double h, double rho) {
  const glm::dvec3 base = table.f1(std::abs(h));
  const auto F = [&](double s) { return table.f1(std::sqrt(s * s + h * h)) - base; };
  glm::dvec3 sum(0.0);
  const double half_pi = 0.5 * std::numbers::pi;
  if (d <= rho) {
    for (int part = 0; part < 2; ++part)
      for (std::size_t k = 0; k < kEdgeNodes.size(); ++k) {
        const double phi = (part + kEdgeNodes[k]) * half_pi, sn = std::sin(phi);
        const double s = -d * std::cos(phi) + std::sqrt(std::max(0.0, rho * rho - d * d * sn * sn));
        sum += (kEdgeWeights[k] * half_pi) * F(s);
      }
  } else {
    for (std::size_t k = 0; k < kEdgeNodes.size(); ++k) {
      const double theta = kEdgeNodes[k] * half_pi, sn = rho / d * std::sin(theta);
      const double cphi = std::sqrt(std::max(0.0, 1.0 - sn * sn)), root = rho * std::cos(theta);
      const double jacobian = rho / d * std::cos(theta) / cphi;  // dphi / dtheta
      sum += (kEdgeWeights[k] * half_pi * jacobian) * (F(d * cphi + root) - F(d * cphi - root));
    }
  }
  return 2.0 * sum;  // the other half of the angles, by symmetry
}
// A triangle whose plane passes this close to the receiver, in the
// profile's narrowest width, is taken as through it for I1 (F2's planar
// moment; the error is of order (h / z_r)^2 of that term).
constexpr double kFlat = 0.05;
// An edge at least this far from the receiver, relative to its length,
// sees F1_h change smoothly along it: one piece.
constexpr double kEdgeSmooth = 0.25;

// I1's part along one edge a + t edge (t in [0, 1], length L): the
// integral of F1_h(|x - q|) times the edge's outward normal
// cross(edge, n) / L, Gauss-Legendre in t = t* + a sinh(v) about the edge's
// point t* nearest q (a: the profile's width there over L).
template <typename F1h>
void edge_integral(double width, double h, const glm::dvec3& a3, const glm::dvec3& edge, double L,
                   const glm::dvec3& n, const glm::dvec3& q, const F1h& f1h, std::array<glm::dvec3, 3>& I1) {
  const glm::dvec3 out = glm::cross(edge, n) / L;
  const double ts = std::clamp(glm::dot(q - a3, edge) / (L * L), 0.0, 1.0);
  const double gap = glm::length(q - (a3 + ts * edge));
  const double scale = std::max(std::sqrt(gap * gap + h * h), width) / L;
  glm::dvec3 along(0.0);
  for (int side = 0; side < 2; ++side) {  // towards a (t < t*), towards b
    const double part = side == 0 ? ts : 1.0 - ts, sign = side == 0 ? -1.0 : 1.0;
    if (!(part > 0)) continue;
    const double vmax = std::asinh(part / scale);
    // Where F1_h changes within the edge (the receiver near its line),
    // the mapped edge in two pieces; else one.
    const int pieces = scale < kEdgeSmooth ? kEdgePieces : 1;
    for (int piece = 0; piece < pieces; ++piece)
      for (std::size_t g = 0; g < kEdgeNodes.size(); ++g) {
        const double v = vmax * (piece + kEdgeNodes[g]) / pieces, ev = std::exp(v);
        const double t = ts + sign * scale * 0.5 * (ev - 1 / ev);  // sinh
        along += vmax / pieces * kEdgeWeights[g] * scale * 0.5 * (ev + 1 / ev) * L *
                 f1h(glm::length(a3 + t * edge - q));
      }
  }
  for (std::size_t c = 0; c < 3; ++c) I1[c] += along[int(c)] * out;
}

// The nodes of the angular rule over the wedge (q, a3, b3) in the plane
// of unit normal n (q in it): fn(wt, r, e) for each, e the unit direction
// in the plane at its angle, r the distance from q to the edge a3 b3 along
// e, wt its weight, signed by the wedge's orientation about n
// (Gauss-Legendre split where r is least). Nothing when q is on the
// edge's line (no area).
template <class Fn>
void wedge_nodes(const glm::dvec3& q, const glm::dvec3& n, const glm::dvec3& a3, const glm::dvec3& b3, Fn&& fn) {
  const glm::dvec3 u = a3 - q, w = b3 - q;
  const double lu = glm::length(u);
  if (!(lu > 0)) return;
  const glm::dvec3 e1 = u / lu, e2 = glm::cross(n, e1);
  const glm::dvec2 a(lu, 0.0), b(glm::dot(w, e1), glm::dot(w, e2)), d = b - a;
  const double ad = a.x * d.y - a.y * d.x;  // r(phi) = (a x d) / (e(phi) x d)
  if (!(std::abs(ad) > 1e-12 * lu * glm::length(d))) return;
  const double theta = std::atan2(b.y, b.x);  // signed: the wedge's orientation about n
  const glm::dvec2 foot = a - glm::dot(a, d) / glm::dot(d, d) * d;
  const double phi_n = std::atan2(foot.y, foot.x);
  const bool split = theta > 0 ? phi_n > 0 && phi_n < theta : phi_n < 0 && phi_n > theta;
  const double cuts[3] = {0.0, split ? phi_n : 0.5 * theta, theta};
  for (int s = 0; s < 2; ++s) {
    const double lo = cuts[s], span = cuts[s + 1] - cuts[s];
    for (std::size_t g = 0; g < kWedgeNodes.size(); ++g) {
      const double phi = lo + span * kWedgeNodes[g];
      const double c = std::cos(phi), sn = std::sin(phi), r = ad / (c * d.y - sn * d.x);
      if (!(r > 0 && r < INFINITY)) continue;  // rounding at a wedge's edge: no area there
      fn(span * kWedgeWeights[g], r, c * e1 + sn * e2);
    }
  }
}

// int over a convex planar polygon p[0..count) (mm) of R_d(|x - o|) dA per
// channel: the signed sum of its edges' wedges about o's projection onto
// its plane (as triangle_weights' I0). A translucent lightmap's texel
// footprint (prt/lightmap.h texel_footprints).
glm::dvec3 polygon_integral(const ProfileTable& table, const glm::dvec3& o, const glm::dvec3* p, std::size_t count) {
  glm::dvec3 normal(0.0);  // Newell's: the polygon's orientation
  for (std::size_t i = 0; i < count; ++i) normal += glm::cross(p[i], p[(i + 1) % count]);
  const double len = glm::length(normal);
  if (!(len > 0)) return glm::dvec3(0.0);
  const glm::dvec3 n = normal / len;
  const double h = glm::dot(o - p[0], n);
  const glm::dvec3 q = o - h * n, base = table.f1(std::abs(h));
  glm::dvec3 I0(0.0);
  for (std::size_t i = 0; i < count; ++i)
    wedge_nodes(q, n, p[i], p[(i + 1) % count], [&](double wt, double r, const glm::dvec3&) {
      I0 += wt * (table.f1(std::sqrt(r * r + h * h)) - base);
    });
  return I0;
}

void triangle_weights(const ProfileTable& table, double width, const glm::dvec3& o,
                      const std::array<glm::dvec3, 3>& p, std::array<glm::dvec3, 3>& W) {
  W.fill(glm::dvec3(0.0));
  const glm::dvec3 cr = glm::cross(p[1] - p[0], p[2] - p[0]);
  const double area2 = glm::length(cr);
  if (!(area2 > 0)) return;
  const glm::dvec3 n = cr / area2;
  const double h = glm::dot(o - p[0], n);
  const glm::dvec3 q = o - h * n;
  const glm::dvec3 base = table.f1(std::abs(h));
  const auto f1h = [&](double r) { return table.f1(std::sqrt(r * r + h * h)) - base; };
  // In the plane (the receiver's own triangles, and where the surface is
  // flat enough): I1 from the wedges too, int dphi e(phi) F2(r(phi)).
  const bool flat = std::abs(h) < kFlat * width;
  glm::dvec3 I0(0.0);
  std::array<glm::dvec3, 3> I1{};  // per channel: the vector integral
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 a3 = p[std::size_t(k)], b3 = p[std::size_t((k + 1) % 3)];
    const glm::dvec3 edge = b3 - a3;
    const double L = glm::length(edge);
    if (!(L > 0)) continue;
    if (!flat) edge_integral(width, h, a3, edge, L, n, q, f1h, I1);
    // I0: the wedge (q, a, b).
    wedge_nodes(q, n, a3, b3, [&](double wt, double r, const glm::dvec3& e) {
      if (!flat) {
        I0 += wt * f1h(r);
        return;
      }
      glm::dvec3 f1, f2;
      table.moments(std::sqrt(r * r + h * h), f1, f2);
      I0 += wt * (f1 - base);
      for (std::size_t ch = 0; ch < 3; ++ch) I1[ch] += wt * f2[int(ch)] * e;
    });
  }
  for (std::size_t j = 0; j < 3; ++j) {
    const glm::dvec3 grad = glm::cross(n, p[(j + 2) % 3] - p[(j + 1) % 3]) / area2;
    const double at = glm::dot(grad, q - p[(j + 1) % 3]);
    for (std::size_t c = 0; c < 3; ++c) W[j][int(c)] = at * I0[int(c)] + glm::dot(grad, I1[c]);
  }
}

}  // namespace

namespace {

// Past this distance (mm) the profile adds at most kReachShare of the
// total reflectance R_d,total whatever the surface there: the smallest D
// (each channel's, the largest of three) with R_d(D) times the whole area
// `area_mm2` at most kReachShare R_d,total. A cluster wholly beyond it is
// skipped.
constexpr double kReachShare = 1e-6;
double profile_reach(const std::array<Dipole, 3>& dipole, double area_mm2) {
  double reach = 0.0;
  for (const Dipole& d : dipole) {
    const double bound = kReachShare * d.total();
    double lo = 0.0, hi = d.z_v;
    while (d.rd(hi) * area_mm2 > bound && hi < 1e12) hi *= 2;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (d.rd(mid) * area_mm2 > bound ? lo : hi) = mid;
    }
    reach = std::max(reach, hi);
  }
  return reach;
}

// Each vertex's triangles: triangles[offsets[v], offsets[v + 1]).
struct Incidence {
  std::vector<std::uint32_t> offsets, triangles;
};

Incidence incidence(const Mesh& mesh) {
  Incidence in;
  in.offsets.assign(mesh.positions.size() + 1, 0);
  for (const glm::uvec3& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) ++in.offsets[t[c] + 1];
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) in.offsets[v + 1] += in.offsets[v];
  in.triangles.resize(in.offsets.back());
  std::vector<std::uint32_t> at(in.offsets.begin(), in.offsets.end() - 1);
  for (std::uint32_t i = 0; i < mesh.triangles.size(); ++i)
    for (int c = 0; c < 3; ++c) in.triangles[at[mesh.triangles[i][c]]++] = i;
  return in;
}

// Each source's far-field stand-in: its weight's centre and mean squared
// radius about it (mesh units). A vertex of a mesh weighs each of its
// triangles by its barycentric hat b_j (the integral of irradiance linear
// across triangles): over a triangle with edges e1, e2 from the vertex,
// int b_j = A / 3, int b_j (x - x_j) = A (e1 + e2) / 12 and
// int b_j |x - x_j|^2 = A (e1^2 + e2^2 + e1 . e2) / 30.
struct Sources {
  std::vector<glm::dvec3> centre;
  std::vector<double> m2;
  std::vector<glm::dvec3> normal;  // the plane of the spread (unit; 0: taken as the receiver's)
  std::vector<double> extent;      // the farthest its weight reaches from the centre
};

Sources hat_sources(const Mesh& mesh, std::span<const double> areas) {
  const std::size_t V = mesh.positions.size();
  Sources s;
  s.centre.assign(V, glm::dvec3(0.0));
  s.m2.assign(V, 0.0);
  s.normal.assign(V, glm::dvec3(0.0));
  for (const glm::uvec3& t : mesh.triangles) {
    const glm::dvec3 p[3] = {glm::dvec3(mesh.positions[t.x]), glm::dvec3(mesh.positions[t.y]),
                             glm::dvec3(mesh.positions[t.z])};
    const double A = 0.5 * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    for (int c = 0; c < 3; ++c) {
      const glm::dvec3 e1 = p[(c + 1) % 3] - p[c], e2 = p[(c + 2) % 3] - p[c];
      s.centre[t[c]] += A / 12 * (e1 + e2);
      s.m2[t[c]] += A / 30 * (glm::dot(e1, e1) + glm::dot(e2, e2) + glm::dot(e1, e2));
      s.normal[t[c]] += glm::cross(p[1] - p[0], p[2] - p[0]);  // twice the area times the face's normal
    }
  }
  for (std::size_t v = 0; v < V; ++v) {
    const glm::dvec3 offset = areas[v] > 0 ? s.centre[v] / areas[v] : glm::dvec3(0.0);
    s.m2[v] = areas[v] > 0 ? std::max(s.m2[v] / areas[v] - glm::dot(offset, offset), 0.0) : 0.0;
    s.centre[v] = glm::dvec3(mesh.positions[v]) + offset;
    const double len = glm::length(s.normal[v]);
    s.normal[v] = len > 0 ? s.normal[v] / len : glm::dvec3(0.0);
  }
  s.extent.assign(V, 0.0);
  for (const glm::uvec3& t : mesh.triangles)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k)
        s.extent[t[c]] = std::max(s.extent[t[c]], glm::length(glm::dvec3(mesh.positions[t[k]]) - s.centre[t[c]]));
  return s;
}

// Points without triangles: each a uniform disc of its area about itself.
Sources disc_sources(const std::vector<glm::dvec3>& pos, std::span<const double> areas) {
  Sources s;
  s.centre = pos;
  s.normal.assign(pos.size(), glm::dvec3(0.0));
  s.m2.resize(pos.size());
  for (std::size_t i = 0; i < pos.size(); ++i) s.m2[i] = areas[i] / (2 * std::numbers::pi);
  s.extent.resize(pos.size());
  for (std::size_t i = 0; i < pos.size(); ++i) s.extent[i] = std::sqrt(areas[i] / std::numbers::pi);
  return s;
}

// Texels with their footprints (prt/lightmap.h): each reaches its farthest
// corner; an octree node holds that reach and a receiver within three of
// it integrates the footprint. Throws prt::Error for footprints of another
// texel count.
void widen_to_footprints(const TexelFootprints& f, const std::vector<glm::dvec3>& pos, Sources& src) {
  if (f.texel_polygons.size() != pos.size() + 1 || f.texel_polygons.back() + 1 != f.polygon_corners.size() ||
      f.polygon_corners.back() != f.corners.size())
    throw Error(fmt::format("subsurface scatter: texel footprints for {} texels, given {} points",
                            f.texel_polygons.empty() ? 0 : f.texel_polygons.size() - 1, pos.size()));
  for (std::size_t i = 0; i < pos.size(); ++i)
    for (std::uint32_t j = f.polygon_corners[f.texel_polygons[i]]; j < f.polygon_corners[f.texel_polygons[i + 1]]; ++j)
      src.extent[i] = std::max(src.extent[i], glm::length(glm::dvec3(f.corners[j]) - pos[i]));
}

// int over texel p's footprint of R_d(|x - o|) dA per channel (o in mesh
// units, S mm a unit; `corners` scratch).
glm::dvec3 footprint_integral(const ProfileTable& table, const TexelFootprints& f, std::uint32_t p, double S,
                              const glm::dvec3& o, std::vector<glm::dvec3>& corners) {
  glm::dvec3 sum(0.0);
  for (std::uint32_t k = f.texel_polygons[p]; k < f.texel_polygons[p + 1]; ++k) {
    corners.clear();
    for (std::uint32_t j = f.polygon_corners[k]; j < f.polygon_corners[k + 1]; ++j)
      corners.push_back(S * glm::dvec3(f.corners[j]));
    sum += polygon_integral(table, S * o, corners.data(), corners.size());
  }
  return sum;
}

// What subsurface_scatter refuses; the channels `in` holds (1 or 3).
int check_scatter(std::size_t V, std::size_t areas, const SubsurfaceMaterial& material, std::size_t in, int nc,
                  const SubsurfaceScatterOptions& o) {
  check_subsurface_material(material, "subsurface material");
  if (!(std::isfinite(o.length_scale) && o.length_scale > 0))
    throw Error(fmt::format("the length scale must be > 0 (mm per mesh unit), got {}", o.length_scale));
  if (!(std::isfinite(o.max_solid_angle) && o.max_solid_angle >= 0))
    throw Error(fmt::format("the largest solid angle of a cluster taken whole must be >= 0, got {}", o.max_solid_angle));
  if (areas != V) throw Error(fmt::format("subsurface scatter: {} areas for {} points", areas, V));
  const int in_channels = nc >= 1 && in == V * 3 * std::size_t(nc) ? 3 : 1;
  if (nc < 1 || in != V * std::size_t(in_channels) * std::size_t(nc))
    throw Error(fmt::format("subsurface scatter: {} floats of irradiance for {} points x {} coefficients (1 or 3 "
                            "channels)",
                            in, V, nc));
  for (const std::uint32_t r : o.receivers)
    if (r >= V) throw Error(fmt::format("subsurface scatter: receiver {} of {} points", r, V));
  return in_channels;
}

// Rows of three channels, [point][channel][k], as one when the three are
// equal everywhere (the direct light's: the rays are weighed alike in every
// channel), so that the sum over points carries a third of the numbers.
std::vector<float> grey_rows(std::vector<float> rows, int nc) {
  const std::size_t n = std::size_t(nc), P = rows.size() / (3 * n);
  if (rows.size() != 3 * n * P) return rows;
  for (std::size_t p = 0; p < P; ++p)
    for (std::size_t k = 0; k < n; ++k)
      if (rows[(3 * p + 1) * n + k] != rows[3 * p * n + k] || rows[(3 * p + 2) * n + k] != rows[3 * p * n + k]) return rows;
  std::vector<float> grey(P * n);
  for (std::size_t p = 0; p < P; ++p) std::copy_n(rows.begin() + std::ptrdiff_t(3 * p * n), n, grey.begin() + std::ptrdiff_t(p * n));
  return grey;
}

// The spread term (m2 / 4 times the Laplacian) is the second order of the
// profile's change across a cluster; the fourth, about (sigma_tr rho)^4 /
// 64 of the cluster's weight for a cluster of radius rho, is what the solid
// angle alone does not bound: a cluster several decay lengths wide a few
// away (docs/SUBSURFACE.md "Clusters"). One decay length bounds it by 1.6%
// of a cluster's weight; half and two measured alike on the tube, where
// none was 15.2% off against 7.2% with every pair.
constexpr double kClusterSpan = 1.0;
// A source whose own weight reaches farther than this many decay lengths
// (a big triangle's hat, a big texel) is integrated exactly at any distance:
// across it the profile changes by e^4 and more, which no spread term
// follows (models/wall-on-floor.gltf at 25 mm a unit, triangles 100 mm
// across against 4-8.5 mm: 40% off against the reference, 22% with this).
// Smaller ones keep the spread term: on the tube at marble's few-percent
// scale (hats 2-4 decay lengths), the exact integral at one decay length
// changed the error by 0.07 points at 20x the time.
constexpr double kWideSource = 4.0;

// The receivers' positions (`points`, else the sources `index` names, else
// every source) into `at`, and the order they are visited in: out_row[r]
// the r-th one's row. Sources in the tree's order (neighbours walk the
// same nodes), then those without area; `points` in their order.
std::vector<std::size_t> receiver_order(const std::vector<glm::dvec3>& pos, const Octree& tree,
                                        std::vector<std::uint32_t> index, std::span<const glm::dvec3> points,
                                        std::vector<glm::dvec3>& at) {
  const std::size_t V = pos.size();
  if (points.empty() && index.empty()) {
    index.resize(V);
    std::iota(index.begin(), index.end(), 0u);
  }
  const std::size_t R = points.empty() ? index.size() : points.size();
  std::vector<std::size_t> out_row(R);
  std::iota(out_row.begin(), out_row.end(), std::size_t(0));
  at.assign(points.begin(), points.end());
  if (!points.empty()) return out_row;
  std::vector<std::uint32_t> place(V, std::uint32_t(tree.order.size()));
  for (std::size_t i = 0; i < tree.order.size(); ++i) place[tree.order[i]] = std::uint32_t(i);
  std::stable_sort(out_row.begin(), out_row.end(),
                   [&](std::size_t a, std::size_t b) { return place[index[a]] < place[index[b]]; });
  at.resize(R);
  for (std::size_t r = 0; r < R; ++r) at[r] = pos[index[r]];
  return out_row;
}

// A source in the sum over points, its weight's constant parts in mm.
struct Leaf {
  glm::dvec3 centre, normal;
  double area, m2, rho, near2;  // S^2 A, S^2 m2, the disc radius (mm), (3 rho / S)^2 in mesh units
  bool wide;  // reaches kWideSource decay lengths: integrated exactly wherever it is (no spread term)
};

// The sum over points; `mesh` (whose vertices the points are) gives the
// near field by its triangles, else by discs.
std::vector<float> scatter_impl(std::span<const glm::vec3> positions, std::span<const double> areas, const Mesh* mesh,
                                const SubsurfaceMaterial& material, std::span<const float> in, int nc,
                                const SubsurfaceScatterOptions& o, const Progress& progress = {},
                                const char* phase = "subsurface", std::span<const glm::dvec3> points = {},
                                const TexelFootprints* footprints = nullptr) {
  const std::size_t V = positions.size();
  const int in_channels = check_scatter(V, areas.size(), material, in.size(), nc, o);
  std::vector<glm::dvec3> pos(V);
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (std::size_t i = 0; i < V; ++i) {
    pos[i] = glm::dvec3(positions[i]);
    lo = glm::min(lo, pos[i]);
    hi = glm::max(hi, pos[i]);
  }
  Sources src = mesh ? hat_sources(*mesh, areas) : disc_sources(pos, areas);
  if (footprints) widen_to_footprints(*footprints, pos, src);
  const std::size_t in_stride = std::size_t(in_channels) * std::size_t(nc);
  const Octree tree = build_octree(src.centre, areas, src.m2, src.normal, src.extent, in, int(in_stride));
  const std::array<Dipole, 3> dipole = {Dipole(material.sigma_a.x, material.sigma_s.x, material.eta),
                                        Dipole(material.sigma_a.y, material.sigma_s.y, material.eta),
                                        Dipole(material.sigma_a.z, material.sigma_s.z, material.eta)};
  const double S = o.length_scale, S2 = S * S, eps = o.max_solid_angle;
  const ProfileTable table(dipole, V ? 1.001 * S * glm::length(hi - lo) : 1.0);
  const double width = std::min({dipole[0].z_r, dipole[1].z_r, dipole[2].z_r});  // the profile's narrowest, mm
  const std::size_t stride = 3 * std::size_t(nc), R = !points.empty() ? points.size() : o.receivers.empty() ? V : o.receivers.size();
  std::vector<float> out(R * stride, 0.0f);
  // A cluster is taken whole only within kClusterSpan decay lengths of the
  // fastest-decaying channel (mesh units).
  const double cluster_span = kClusterSpan / (S * std::max({dipole[0].sigma_tr, dipole[1].sigma_tr, dipole[2].sigma_tr}));
  const double reach = profile_reach(dipole, tree.nodes.empty() ? 0.0 : S2 * tree.nodes[0].area) / S;  // mesh units
  const Incidence inc = mesh ? incidence(*mesh) : Incidence{};
  // The sources in the tree's order (a leaf's points and rows side by side).
  std::vector<Leaf> leaf(tree.order.size());
  std::vector<float> rows(tree.order.size() * in_stride);
  for (std::size_t i = 0; i < tree.order.size(); ++i) {
    const std::uint32_t p = tree.order[i];
    const double area = S2 * areas[p], rho = std::sqrt(area / std::numbers::pi);
    const double near = kNearDiscs * (footprints ? src.extent[p] : rho / S);  // mesh units
    leaf[i] = {src.centre[p], src.normal[p], area, S2 * src.m2[p], rho, near * near,
               src.extent[p] > kWideSource * cluster_span};
    std::copy_n(in.data() + std::size_t(p) * in_stride, in_stride, rows.data() + i * in_stride);
  }
  std::vector<glm::dvec3> receiver;
  const std::vector<std::size_t> out_row = receiver_order(pos, tree, o.receivers, points, receiver);
  detail::ProgressTicker ticker(progress, R, phase);
  ticker.start();
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, R, 64), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<double> acc(stride);
    std::vector<std::uint32_t> stack, near;
    std::vector<glm::dvec3> hats, corners;
    for (std::size_t r = range.begin(); r < range.end(); ++r) {
      const std::size_t row = out_row[r];
      const glm::dvec3 o_pos = receiver[row];
      std::fill(acc.begin(), acc.end(), 0.0);
      // Adds w[c] (mm^2 times R_d, per channel) times `rows` (in_stride values).
      const auto add = [&](const glm::dvec3& w, const auto* __restrict source) {
        if (in_channels == 1) {  // one row for the three channels: one pass over it
          double* __restrict a0 = acc.data();
          double* __restrict a1 = a0 + nc;
          double* __restrict a2 = a1 + nc;
          for (int k = 0; k < nc; ++k) {
            const double x = double(source[k]);
            a0[k] += w.x * x;
            a1[k] += w.y * x;
            a2[k] += w.z * x;
          }
          return;
        }
        for (int c = 0; c < 3; ++c) {
          const auto* x = source + (in_channels == 3 ? std::size_t(c) * std::size_t(nc) : 0);
          double* a = acc.data() + std::size_t(c) * std::size_t(nc);
          for (int k = 0; k < nc; ++k) a[k] += w[c] * double(x[k]);
        }
      };
      // The weight S^2 A_i R_d of the source at tree.order[i]
      // (docs/SUBSURFACE.md "Near sources").
      const auto point_weight = [&](std::uint32_t i) {
        const Leaf& l = leaf[i];
        const glm::dvec3 to = o_pos - l.centre;
        const double d2 = glm::dot(to, to), d = S * std::sqrt(d2), g = glm::dot(to, l.normal);
        const double inplane = d2 > 0 ? 1.0 - g * g / d2 : 1.0;
        if (mesh) {  // the near ones' triangles are integrated below
          if (d2 < l.near2 || l.wide) near.push_back(tree.order[i]);
          return l.area * table.point_mean(d, l.m2, inplane);
        }
        if (!(d2 < l.near2 || l.wide)) return l.area * table.point_mean(d, l.m2);
        if (!footprints) return disc_integral(table, S * std::sqrt(std::max(0.0, d2 - g * g)), S * g, l.rho);
        return footprint_integral(table, *footprints, tree.order[i], S, o_pos, corners);
      };
      // Each near vertex's weight integrated over its triangles
      // (triangle_weights: its hat b_j), in place of its point value. Whole
      // hats only: a vertex whose triangles were integrated in part would
      // lose the symmetry that makes its point value second-order.
      const auto near_field = [&](std::vector<std::uint32_t>& verts) {
        std::sort(verts.begin(), verts.end());
        std::vector<std::uint32_t>& tris = stack;
        tris.clear();
        for (const std::uint32_t p : verts)
          tris.insert(tris.end(), inc.triangles.begin() + inc.offsets[p], inc.triangles.begin() + inc.offsets[p + 1]);
        std::sort(tris.begin(), tris.end());
        tris.erase(std::unique(tris.begin(), tris.end()), tris.end());
        hats.assign(verts.size(), glm::dvec3(0.0));
        std::array<glm::dvec3, 3> W;
        for (const std::uint32_t t : tris) {
          const glm::uvec3 tri = mesh->triangles[t];
          triangle_weights(table, width, S * o_pos, {S * pos[tri.x], S * pos[tri.y], S * pos[tri.z]}, W);
          for (int c = 0; c < 3; ++c) {
            const auto at = std::lower_bound(verts.begin(), verts.end(), tri[c]);
            if (at != verts.end() && *at == tri[c]) hats[std::size_t(at - verts.begin())] += W[std::size_t(c)];
          }
        }
        for (std::size_t i = 0; i < verts.size(); ++i) {
          const std::uint32_t j = verts[i];
          const glm::dvec3 to = o_pos - src.centre[j];
          const double d2 = glm::dot(to, to), g = glm::dot(to, src.normal[j]);
          const double point = S2 * areas[j], inplane = d2 > 0 ? 1.0 - g * g / d2 : 1.0;
          add(hats[i] - point * table.point_mean(S * std::sqrt(d2), S2 * src.m2[j], inplane),
              in.data() + std::size_t(j) * in_stride);
        }
      };
      stack.assign(1, 0);
      near.clear();
      while (!tree.order.empty() && !stack.empty()) {
        const Node& node = tree.nodes[stack.back()];
        const std::size_t n = stack.back();
        stack.pop_back();
        if (node.children == 0) {
          for (std::uint32_t i = node.first; i < node.first + node.count; ++i)
            add(point_weight(i), rows.data() + std::size_t(i) * in_stride);
          continue;
        }
        const double d2 = glm::dot(o_pos - node.centre, o_pos - node.centre);
        if (node.radius + reach < std::sqrt(d2)) continue;  // beyond the profile's reach
        if (node.area < eps * d2 && node.radius < cluster_span) {  // small seen from here, narrow for the profile: whole
          const double g = glm::dot(o_pos - node.centre, node.normal), inplane = d2 > 0 ? 1.0 - g * g / d2 : 1.0;
          add(S2 * table.point_mean(S * std::sqrt(d2), S2 * node.m2, inplane), tree.sums.data() + n * in_stride);
          continue;
        }
        for (std::uint32_t c = node.child; c < node.child + node.children; ++c) stack.push_back(c);
      }
      if (mesh) near_field(near);
      for (std::size_t q = 0; q < stride; ++q) out[row * stride + q] = float(acc[q] / std::numbers::pi);
    }
    ticker.tick(range.size());
  });
  ticker.finish();
  return out;
}

}  // namespace

std::vector<float> subsurface_scatter(std::span<const glm::vec3> positions, std::span<const double> areas,
                                      const SubsurfaceMaterial& material, std::span<const float> in, int nc,
                                      const SubsurfaceScatterOptions& o) {
  return scatter_impl(positions, areas, nullptr, material, in, nc, o);
}

std::vector<float> subsurface_scatter(const Mesh& mesh, const SubsurfaceMaterial& material, std::span<const float> in,
                                      int nc, const SubsurfaceScatterOptions& o) {
  const std::vector<double> area = vertex_areas(mesh);
  return scatter_impl(mesh.positions, area, &mesh, material, in, nc, o);
}

// Each split quadruples a triangle's sources: four levels are 256 points
// where there was one.
constexpr int kMaxSplitLevels = 4;

namespace {

void check_subsurface_options(const TransferOptions& options, const SubsurfaceMaterial& material,
                              const SubsurfaceScatterOptions& scatter) {
  check_subsurface_material(material, "subsurface material");
  if (!scatter.receivers.empty())
    throw Error("compute_subsurface_transfer: every vertex receives (SubsurfaceScatterOptions::receivers must be empty)");
  if (options.mode == TransferMode::Unshadowed)
    throw Error("a translucent material's transfer is shadowed or interreflected: the light entering a vertex is "
                "traced (unshadowed light would pass through the object's other side)");
  if (options.glossy) throw Error("a translucent material's exit radiance is view-independent: no glossy matrices");
  if (options.light_bounce) throw Error("--light-bounce: the lights' bounce is diffuse; a translucent transfer keeps no operator");
  // Checked before any ray (subsurface_scatter checks them again).
  if (!(std::isfinite(scatter.length_scale) && scatter.length_scale > 0))
    throw Error(fmt::format("the length scale must be > 0 (mm per mesh unit), got {}", scatter.length_scale));
  if (!(scatter.split_difference >= 0) || scatter.split_levels < 0 || scatter.split_levels > kMaxSplitLevels)
    throw Error(fmt::format("irradiance samples: a triangle is split where its corners differ by more than a share >= 0 "
                            "(got {}), up to 0 to {} times (got {})",
                            scatter.split_difference, kMaxSplitLevels, scatter.split_levels));
}

}  // namespace

Transfer compute_subsurface_transfer(const Mesh& mesh, const TransferOptions& options,
                                     const SubsurfaceMaterial& material, const SubsurfaceScatterOptions& scatter,
                                     const Progress& progress) {
  check_subsurface_options(options, material, scatter);
  TransferOptions o = options;
  if (o.mode == TransferMode::Shadowed) o.bounces = 0;
  o.albedo = glm::vec3(1.0f);
  o.vertex_colors = false;
  o.transmission_eta = material.eta;
  const std::vector<double> area = vertex_areas(mesh);
  const int nc = o.bands * o.bands;
  int pass = 0;
  o.between_bounces = [&](std::vector<float>& rows) {  // E_t / pi -> L_o, the surface integral
    if (pass++ == 0) {  // the direct light, with irradiance samples between the vertices
      detail::IrradianceSamples s =
          detail::irradiance_samples(mesh, std::move(rows), o, scatter.split_difference, scatter.split_levels, progress);
      if (scatter.added_samples) *scatter.added_samples = s.added;
      s.rows = grey_rows(std::move(s.rows), nc);
      for (float& x : s.rows) x = float(std::numbers::pi * x);
      SubsurfaceScatterOptions so = scatter;
      so.receivers.resize(mesh.vertex_count());
      std::iota(so.receivers.begin(), so.receivers.end(), 0u);
      rows = scatter_impl(s.sources.positions, vertex_areas(s.sources), &s.sources, material, s.rows, nc, so, progress,
                          "subsurface");
      return;
    }
    for (float& x : rows) x = float(std::numbers::pi * x);
    const std::string phase = fmt::format("subsurface, bounce {}", pass - 1);
    rows = scatter_impl(mesh.positions, area, &mesh, material, grey_rows(std::move(rows), nc), nc, scatter, progress,
                        phase.c_str());
  };
  Transfer t = compute_transfer(mesh, o, progress);
  if (t.vertices == 0) return t;  // another rank's
  PRT_CHECK(t.channels == 3 && t.analytic_vertices() == 0);
  t.subsurface = SubsurfaceRecord{material, scatter.length_scale};
  return t;
}

LightmapTransfer compute_subsurface_lightmap(const Scene& scene, const LightmapTexels& texels,
                                             const TransferOptions& options, const SubsurfaceMaterial& material,
                                             const SubsurfaceScatterOptions& scatter, const Progress& progress) {
  check_subsurface_options(options, material, scatter);
  const std::size_t P = texels.layout.texels.size();
  if (texels.triangle.size() != P || texels.barycentric.size() != P || texels.area.size() != P)
    throw Error("lightmap texels: triangle, barycentric and area must have one entry per covered texel (lightmap_texels "
                "fills them)");
  // Each texel is a source of the area it covers and a receiver, at its
  // point on its triangle, and traced from there too: a texel that
  // move_texels_out_of_geometry moved (under a box standing on the floor,
  // say) would bring its visible neighbour's light into the sum as its own,
  // light that does not enter there (measured: 8.4% off against the
  // reference beside such a box, 2.2% traced where it lies).
  const std::vector<glm::vec3> at = texel_surface_points(scene.mesh, texels);
  const std::vector<double> area(texels.area.begin(), texels.area.end());
  // Near a receiver, each texel's own surface is integrated (a uniform disc
  // of its area was 22% off beside a box's bright bottom edge).
  const TexelFootprints footprints = texel_footprints(scene, texels);
  LightmapTexels lit = texels;
  lit.positions = at;
  std::fill(lit.albedo.begin(), lit.albedo.end(), glm::vec3(1.0f));  // the material's reflectance is its profile
  TransferOptions o = options;
  if (o.mode == TransferMode::Shadowed) o.bounces = 0;
  o.transmission_eta = material.eta;
  const int nc = o.bands * o.bands;
  int pass = 0;
  o.between_bounces = [&](std::vector<float>& rows) {  // E_t / pi -> L_o, the surface integral over the texels
    for (float& x : rows) x = float(std::numbers::pi * x);
    const std::string phase = pass++ == 0 ? "subsurface" : fmt::format("subsurface, bounce {}", pass - 1);
    rows = scatter_impl(at, area, nullptr, material, grey_rows(std::move(rows), nc), nc, scatter, progress, phase.c_str(),
                        {}, &footprints);
  };
  LightmapTransfer out = compute_lightmap_transfer(scene, lit, o, progress);
  if (out.transfer.vertices == 0) return out;  // another rank's
  PRT_CHECK(out.transfer.channels == 3 && out.transfer.analytic_vertices() == 0);
  out.transfer.subsurface = SubsurfaceRecord{material, scatter.length_scale};
  return out;
}

}  // namespace prt
