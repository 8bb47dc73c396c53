// Lightmap UVs made by prt (prt/unwrap.h): charts grown over each object's
// welded surface by normal, flattened by a planar projection or least-squares
// conformal maps with bounded stretch (split until they are), and packed by a
// raster packer into an atlas at one texel density; and atlas_stats, the
// figures of any UV set as an atlas.

#include <prt/unwrap.h>

#include "atlas_raster.h"

#include <prt/error.h>
#include <prt/lightmap.h>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <type_traits>
#include <unordered_map>
#include <utility>

namespace prt {
// Named (not only anonymous) so that the unity build's batches, which put
// scene/lightmap.cpp's helpers beside these, never mix the two.
namespace unwrap_detail {
namespace {

constexpr std::uint32_t kNone = 0xffffffffu;
// A chart's triangles keep their texel density within this factor of the
// chart's mean (and so of the atlas's): three.js's unwrapUVs' bound, less a
// ten-thousandth for the UVs' rounding to float.
constexpr double kAreaLimit = 2.0 * (1 - 1e-4);
// A chart whose area is less than this share of its bounding rectangle's
// (an arc, a long bent strip: a tube's charts) is cut in two. Measured on
// six of the shared meshes at 1024 x 1024: 0.4 gave texels 1 to 11%
// smaller than no cut (knot1 the most) for 13 to 56% more charts; 0.5, 0.3
// to 7% smaller again for 30 to 90% more charts again.
constexpr double kMinFill = 0.4;
// Faces whose area is at most this share of their longest edge squared are
// degenerate (no area, or slivers whose shape is float rounding: a height
// of 2e-9 of the edge, far below a float's relative precision, 1.2e-7).
constexpr double kSliver = 1e-9;

using Tri = std::array<std::uint32_t, 3>;

// ---- Faces of the scene, welded by position within each object ------------

struct Faces {
  std::vector<Tri> weld;               // per face corner: its welded vertex (per object: charts never mix objects)
  std::vector<glm::dvec3> normal;      // unit; 0 for degenerate faces
  std::vector<double> area;            // world units squared
  std::vector<std::uint8_t> degenerate;
  std::vector<Tri> neighbour;          // across edge k (corner k to k+1), or kNone
  std::vector<glm::dvec3> position;    // per welded vertex
};

// A triangle's object (0 for a scene without objects).
std::uint32_t object_of(const Scene& scene, std::size_t t) {
  return scene.objects.empty() || scene.triangle_object.size() != scene.mesh.triangles.size() ? 0 : scene.triangle_object[t];
}

using atlas_raster::canonical_bits;

struct WeldKey {
  std::uint32_t object, x, y, z;
  bool operator==(const WeldKey&) const = default;
};
struct WeldHash {
  std::size_t operator()(const WeldKey& k) const {
    std::uint64_t h = (std::uint64_t(k.object) << 32 | k.x) * 0x9E3779B97F4A7C15ull;
    h ^= (std::uint64_t(k.y) << 32 | k.z) + 0x7F4A7C159E3779B9ull + (h << 6) + (h >> 2);
    return std::size_t(h ^ (h >> 31));
  }
};

// Pairs the faces across each welded edge: two half-edges of opposite
// direction; where more than two faces meet (non-manifold), each half-edge
// with the opposite one whose face's normal is closest.
void pair_edges(Faces& f) {
  struct HalfEdge {
    std::uint64_t key;
    std::uint32_t face, k, a;
  };
  std::vector<HalfEdge> edges;
  edges.reserve(f.weld.size() * 3);
  for (std::uint32_t t = 0; t < f.weld.size(); ++t) {
    if (f.degenerate[t]) continue;
    for (std::uint32_t k = 0; k < 3; ++k) {
      const std::uint32_t a = f.weld[t][k], b = f.weld[t][(k + 1) % 3];
      edges.push_back({(std::uint64_t(std::min(a, b)) << 32) | std::max(a, b), t, k, a});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : x.face != y.face ? x.face < y.face : x.k < y.k;
  });
  std::vector<std::uint8_t> used;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j].key == edges[i].key) ++j;
    used.assign(j - i, 0);
    for (std::size_t x = i; x < j; ++x) {
      if (used[x - i]) continue;
      std::size_t best = j;
      double best_dot = -2;
      for (std::size_t y = i; y < j; ++y) {
        if (y == x || used[y - i] || edges[y].a == edges[x].a || edges[y].face == edges[x].face) continue;
        const double d = glm::dot(f.normal[edges[x].face], f.normal[edges[y].face]);
        if (d > best_dot) best_dot = d, best = y;
      }
      if (best == j) continue;
      used[x - i] = used[best - i] = 1;
      f.neighbour[edges[x].face][edges[x].k] = edges[best].face;
      f.neighbour[edges[best].face][edges[best].k] = edges[x].face;
    }
    i = j;
  }
}

Faces build_faces(const Scene& scene) {
  const Mesh& mesh = scene.mesh;
  const std::size_t T = mesh.triangles.size();
  Faces f;
  f.weld.resize(T);
  f.normal.assign(T, glm::dvec3(0.0));
  f.area.assign(T, 0.0);
  f.degenerate.assign(T, 0);
  f.neighbour.assign(T, Tri{kNone, kNone, kNone});
  std::unordered_map<WeldKey, std::uint32_t, WeldHash> welds;
  welds.reserve(mesh.positions.size() + 16);
  for (std::size_t t = 0; t < T; ++t) {
    const std::uint32_t o = object_of(scene, t);
    glm::dvec3 p[3];
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 q = mesh.positions[mesh.triangles[t][k]];
      const auto [it, fresh] = welds.emplace(WeldKey{o, canonical_bits(q.x), canonical_bits(q.y), canonical_bits(q.z)},
                                             std::uint32_t(f.position.size()));
      if (fresh) f.position.emplace_back(q);
      f.weld[t][k] = it->second;
      p[k] = glm::dvec3(q);
    }
    const glm::dvec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
    const double longest = std::max({glm::dot(p[1] - p[0], p[1] - p[0]), glm::dot(p[2] - p[1], p[2] - p[1]),
                                     glm::dot(p[0] - p[2], p[0] - p[2])});
    f.area[t] = 0.5 * glm::length(n);
    const bool distinct = f.weld[t][0] != f.weld[t][1] && f.weld[t][1] != f.weld[t][2] && f.weld[t][2] != f.weld[t][0];
    if (distinct && f.area[t] > kSliver * longest && std::isfinite(f.area[t]))
      f.normal[t] = n / (2.0 * f.area[t]);
    else
      f.degenerate[t] = 1;
  }
  pair_edges(f);
  return f;
}

// ---- Charts grown by normal -------------------------------------------------

// Face sets: from the largest unassigned face, every face reached across
// paired edges whose normal is within the angle of the seed's.
std::vector<std::vector<std::uint32_t>> grow_charts(const Faces& f, double cos_limit) {
  const std::size_t T = f.weld.size();
  std::vector<std::uint32_t> order;
  for (std::uint32_t t = 0; t < T; ++t)
    if (!f.degenerate[t]) order.push_back(t);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return f.area[a] != f.area[b] ? f.area[a] > f.area[b] : a < b; });
  std::vector<std::uint8_t> assigned(T, 0);
  std::vector<std::vector<std::uint32_t>> charts;
  for (const std::uint32_t seed : order) {
    if (assigned[seed]) continue;
    std::vector<std::uint32_t> faces{seed};
    assigned[seed] = 1;
    const glm::dvec3 n = f.normal[seed];
    for (std::size_t i = 0; i < faces.size(); ++i)
      for (const std::uint32_t nb : f.neighbour[faces[i]])
        if (nb != kNone && !assigned[nb] && glm::dot(f.normal[nb], n) >= cos_limit) {
          assigned[nb] = 1;
          faces.push_back(nb);
        }
    charts.push_back(std::move(faces));
  }
  return charts;
}

// ---- Flattening --------------------------------------------------------------

struct Chart {
  std::vector<std::uint32_t> faces;
  std::vector<std::uint32_t> welds;  // local vertex -> welded vertex, increasing
  std::vector<Tri> tris;             // per face: its local vertices
  std::vector<glm::dvec2> uv;        // per local vertex (world units once finished)
  double area3 = 0;                  // world area
  glm::dvec2 extent{0.0};            // of uv once finished (its minimum at 0)
};

Chart make_chart(std::vector<std::uint32_t> faces, const Faces& f) {
  Chart c;
  for (const std::uint32_t t : faces)
    for (const std::uint32_t w : f.weld[t]) c.welds.push_back(w);
  std::sort(c.welds.begin(), c.welds.end());
  c.welds.erase(std::unique(c.welds.begin(), c.welds.end()), c.welds.end());
  c.tris.reserve(faces.size());
  for (const std::uint32_t t : faces) {
    Tri local;
    for (int k = 0; k < 3; ++k)
      local[k] = std::uint32_t(std::lower_bound(c.welds.begin(), c.welds.end(), f.weld[t][k]) - c.welds.begin());
    c.tris.push_back(local);
    c.area3 += f.area[t];
  }
  c.faces = std::move(faces);
  c.uv.assign(c.welds.size(), glm::dvec2(0.0));
  return c;
}

// The area-weighted mean normal of a chart's faces (the first face's where they cancel).
glm::dvec3 mean_normal(const std::vector<std::uint32_t>& faces, const Faces& f) {
  glm::dvec3 m(0.0);
  double area = 0;
  for (const std::uint32_t t : faces) m += f.area[t] * f.normal[t], area += f.area[t];
  const double len = glm::length(m);
  return len > 1e-12 * area ? m / len : f.normal[faces[0]];
}

// A right-handed frame (t1, t2, n) around unit normal n.
void tangent_frame(const glm::dvec3& n, glm::dvec3& t1, glm::dvec3& t2) {
  const glm::dvec3 axis = std::abs(n.x) < 0.8 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  t1 = glm::normalize(glm::cross(axis, n));
  t2 = glm::cross(n, t1);
}

void planar(Chart& c, const Faces& f) {
  const glm::dvec3 n = mean_normal(c.faces, f);
  glm::dvec3 t1, t2;
  tangent_frame(n, t1, t2);
  const glm::dvec3 origin = f.position[c.welds[0]];
  for (std::size_t i = 0; i < c.welds.size(); ++i) {
    const glm::dvec3 d = f.position[c.welds[i]] - origin;
    c.uv[i] = {glm::dot(d, t1), glm::dot(d, t2)};
  }
}

// sigma_max / sigma_min of the linear map taking triangle p (space) to q
// (the plane), and `ratio`, q's area over p's (negative when it flips);
// infinity for a map without area.
double triangle_stretch(const glm::dvec3 p[3], const glm::dvec2 q[3], double& ratio) {
  const glm::dvec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  const double len = glm::length(e1), area2 = glm::length(glm::cross(e1, e2));
  const double x2 = glm::dot(e2, e1) / len, y2 = area2 / len;
  const glm::dvec2 jx = (q[1] - q[0]) / len, jy = (q[2] - q[0] - jx * x2) / y2;
  const double det = jx.x * jy.y - jx.y * jy.x, frob = glm::dot(jx, jx) + glm::dot(jy, jy);
  ratio = det;
  if (!(std::abs(det) > 0) || !std::isfinite(det)) return std::numeric_limits<double>::infinity();
  const double k = frob / std::abs(det);
  return 0.5 * (k + std::sqrt(std::max(k * k - 4.0, 0.0)));
}

// Strict interior intersection of two triangles (separating axes; shared
// edges and corners do not intersect).
bool triangles_overlap(const glm::dvec2 a[3], const glm::dvec2 b[3], double eps) {
  for (const glm::dvec2* t : {a, b})
    for (int j = 0; j < 3; ++j) {
      const glm::dvec2 n(t[j].y - t[(j + 1) % 3].y, t[(j + 1) % 3].x - t[j].x);
      double min_a = std::numeric_limits<double>::infinity(), max_a = -min_a, min_b = min_a, max_b = -min_a;
      for (int k = 0; k < 3; ++k) {
        const double da = glm::dot(a[k], n), db = glm::dot(b[k], n);
        min_a = std::min(min_a, da), max_a = std::max(max_a, da);
        min_b = std::min(min_b, db), max_b = std::max(max_b, db);
      }
      if (std::min(max_a, max_b) - std::max(min_a, min_b) <= eps * glm::length(n)) return false;
    }
  return true;
}

// Whether two of the chart's triangles overlap in UV: a grid of about one
// triangle per cell, each pair tested once, in the first cell both cover.
bool self_overlap(const Chart& c) {
  const std::size_t n = c.tris.size();
  if (n < 2) return false;
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (const glm::dvec2& q : c.uv) lo = glm::min(lo, q), hi = glm::max(hi, q);
  const double extent = std::max(hi.x - lo.x, hi.y - lo.y);
  if (!(extent > 0)) return true;
  const int g = std::max(1, int(std::ceil(std::sqrt(double(n)))));
  const double scale = g / extent * (1 - 1e-9);
  std::vector<std::array<int, 4>> box(n);  // cells x0, y0, x1, y1
  std::vector<std::uint32_t> start(std::size_t(g) * g + 1, 0);
  for (std::size_t t = 0; t < n; ++t) {
    glm::dvec2 a = c.uv[c.tris[t][0]], b = a;
    for (int k = 1; k < 3; ++k) a = glm::min(a, c.uv[c.tris[t][k]]), b = glm::max(b, c.uv[c.tris[t][k]]);
    const auto cell = [&](double v, double o) { return std::clamp(int((v - o) * scale), 0, g - 1); };
    box[t] = {cell(a.x, lo.x), cell(a.y, lo.y), cell(b.x, lo.x), cell(b.y, lo.y)};
    for (int y = box[t][1]; y <= box[t][3]; ++y)
      for (int x = box[t][0]; x <= box[t][2]; ++x) ++start[std::size_t(y) * g + x + 1];
  }
  for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
  std::vector<std::uint32_t> items(start.back()), fill(start.begin(), start.end() - 1);
  for (std::size_t t = 0; t < n; ++t)
    for (int y = box[t][1]; y <= box[t][3]; ++y)
      for (int x = box[t][0]; x <= box[t][2]; ++x) items[fill[std::size_t(y) * g + x]++] = std::uint32_t(t);
  const double eps = 1e-12 * extent;
  for (int y = 0; y < g; ++y)
    for (int x = 0; x < g; ++x) {
      const std::size_t cell = std::size_t(y) * g + x;
      for (std::uint32_t i = start[cell]; i < start[cell + 1]; ++i)
        for (std::uint32_t j = i + 1; j < start[cell + 1]; ++j) {
          const std::array<int, 4>&A = box[items[i]], &B = box[items[j]];
          if (std::max(A[0], B[0]) != x || std::max(A[1], B[1]) != y) continue;  // tested in another cell
          if (A[2] < B[0] || B[2] < A[0] || A[3] < B[1] || B[3] < A[1]) continue;
          const Tri &ti = c.tris[items[i]], &tj = c.tris[items[j]];
          const glm::dvec2 qa[3] = {c.uv[ti[0]], c.uv[ti[1]], c.uv[ti[2]]};
          const glm::dvec2 qb[3] = {c.uv[tj[0]], c.uv[tj[1]], c.uv[tj[2]]};
          if (triangles_overlap(qa, qb, eps)) return true;
        }
    }
  return false;
}

// Whether the chart's map is a lightmap's: no triangle folds, none stretches
// past max_stretch, none's density leaves [1/2, 2] of the chart's mean, and
// no two overlap.
bool acceptable(const Chart& c, const Faces& f, double max_stretch) {
  double uv_area = 0;
  std::vector<double> ratio(c.tris.size());
  for (std::size_t i = 0; i < c.tris.size(); ++i) {
    const std::uint32_t t = c.faces[i];
    const glm::dvec3 p[3] = {f.position[f.weld[t][0]], f.position[f.weld[t][1]], f.position[f.weld[t][2]]};
    const glm::dvec2 q[3] = {c.uv[c.tris[i][0]], c.uv[c.tris[i][1]], c.uv[c.tris[i][2]]};
    const double s = triangle_stretch(p, q, ratio[i]);
    if (!(ratio[i] > 0) || !(s <= max_stretch)) return false;
    uv_area += ratio[i] * f.area[t];
  }
  const double mean = uv_area / c.area3;
  for (const double r : ratio)
    if (!(r >= mean / kAreaLimit && r <= mean * kAreaLimit)) return false;
  return !self_overlap(c);
}

// The two local vertices farthest apart (a double sweep).
std::pair<std::uint32_t, std::uint32_t> far_pair(const Chart& c, const Faces& f) {
  const auto farthest = [&](std::uint32_t from) {
    std::uint32_t best = from;
    double d = -1;
    for (std::uint32_t i = 0; i < c.welds.size(); ++i) {
      const glm::dvec3 e = f.position[c.welds[i]] - f.position[c.welds[from]];
      if (glm::dot(e, e) > d) d = glm::dot(e, e), best = i;
    }
    return best;
  };
  const std::uint32_t a = farthest(0);
  return {a, farthest(a)};
}

// Least squares conformal maps (Levy et al. 2002): per triangle, the
// Cauchy-Riemann residuals of (u, v) over its own orthonormal frame, weighted
// by its area; two vertices pinned; the normal equations by sparse LDL^T.
bool lscm(Chart& c, const Faces& f) {
  const std::size_t n = c.welds.size();
  if (n < 3) return false;
  const auto [pa, pb] = far_pair(c, f);
  if (pa == pb) return false;
  const double dist = glm::length(f.position[c.welds[pb]] - f.position[c.welds[pa]]);
  std::vector<int> var(n, -1);
  int free_vars = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (i != pa && i != pb) var[i] = 2 * free_vars++;
  const auto pinned = [&](std::uint32_t i) { return i == pa ? glm::dvec2(0.0) : glm::dvec2(dist, 0.0); };
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(c.tris.size() * 12);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(Eigen::Index(2 * c.tris.size()));
  for (std::size_t i = 0; i < c.tris.size(); ++i) {
    const std::uint32_t t = c.faces[i];
    const glm::dvec3 p0 = f.position[f.weld[t][0]], e1 = f.position[f.weld[t][1]] - p0, e2 = f.position[f.weld[t][2]] - p0;
    const double len = glm::length(e1), area2 = glm::length(glm::cross(e1, e2));
    const double x[3] = {0, len, glm::dot(e2, e1) / len}, y[3] = {0, 0, area2 / len};
    const double w = std::sqrt(0.5 * area2) / area2;  // sqrt(area) x the gradients' 1 / (2 area)
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      const double gx = (y[k1] - y[k2]) * w, gy = (x[k2] - x[k1]) * w;
      const Eigen::Index r1 = Eigen::Index(2 * i), r2 = r1 + 1;
      const std::uint32_t v = c.tris[i][k];
      // r1 = du/dx - dv/dy, r2 = du/dy + dv/dx
      if (var[v] < 0) {
        const glm::dvec2 q = pinned(v);
        rhs[r1] -= gx * q.x - gy * q.y;
        rhs[r2] -= gy * q.x + gx * q.y;
      } else {
        triplets.emplace_back(r1, var[v], gx);
        triplets.emplace_back(r1, var[v] + 1, -gy);
        triplets.emplace_back(r2, var[v], gy);
        triplets.emplace_back(r2, var[v] + 1, gx);
      }
    }
  }
  Eigen::SparseMatrix<double> A(Eigen::Index(2 * c.tris.size()), 2 * free_vars);
  A.setFromTriplets(triplets.begin(), triplets.end());
  const Eigen::SparseMatrix<double> At = A.transpose();
  const Eigen::SparseMatrix<double> M = At * A;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(M);
  if (solver.info() != Eigen::Success) return false;
  const Eigen::VectorXd sol = solver.solve(At * rhs);
  if (solver.info() != Eigen::Success || !sol.allFinite()) return false;
  for (std::uint32_t i = 0; i < n; ++i)
    c.uv[i] = var[i] < 0 ? pinned(i) : glm::dvec2(sol[var[i]], sol[var[i] + 1]);
  return true;
}

// The connected pieces (across paired edges) of each side of a chart's
// faces (side[i] for c.faces[i]).
std::vector<std::vector<std::uint32_t>> pieces(const Chart& c, const Faces& f, const std::vector<std::uint8_t>& side) {
  const std::size_t n = c.faces.size();
  std::vector<std::uint32_t> sorted(c.faces);
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::uint8_t> side_of(n), done(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    side_of[std::lower_bound(sorted.begin(), sorted.end(), c.faces[i]) - sorted.begin()] = side[i];
  const auto index = [&](std::uint32_t t) {
    const auto it = std::lower_bound(sorted.begin(), sorted.end(), t);
    return it != sorted.end() && *it == t ? std::size_t(it - sorted.begin()) : n;
  };
  std::vector<std::vector<std::uint32_t>> parts;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t s = index(c.faces[i]);
    if (done[s]) continue;
    done[s] = 1;
    std::vector<std::uint32_t> piece{c.faces[i]};
    for (std::size_t k = 0; k < piece.size(); ++k)
      for (const std::uint32_t nb : f.neighbour[piece[k]]) {
        const std::size_t j = nb == kNone ? n : index(nb);
        if (j < n && !done[j] && side_of[j] == side_of[s]) done[j] = 1, piece.push_back(nb);
      }
    parts.push_back(std::move(piece));
  }
  return parts;
}

// Splits a chart in two: by the sign of its normals' deviation along their
// principal direction; where the normals agree, by the faces' centroids
// along their principal axis; then by halves. Each part's connected pieces.
std::vector<std::vector<std::uint32_t>> split_chart(const Chart& c, const Faces& f) {
  const std::size_t n = c.faces.size();
  std::vector<std::uint8_t> side(n, 0);
  const auto principal = [&](const std::vector<glm::dvec3>& v, glm::dvec3& mean) {
    mean = glm::dvec3(0.0);
    double wsum = 0;
    for (std::size_t i = 0; i < n; ++i) mean += f.area[c.faces[i]] * v[i], wsum += f.area[c.faces[i]];
    mean /= wsum;
    double cov[3][3] = {};
    for (std::size_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) cov[a][b] += f.area[c.faces[i]] * (v[i][a] - mean[a]) * (v[i][b] - mean[b]);
    glm::dvec3 axis(1.0, 0.7, 0.3);  // power iteration from a fixed start
    for (int it = 0; it < 64; ++it) {
      glm::dvec3 next(0.0);
      for (int a = 0; a < 3; ++a) next[a] = cov[a][0] * axis.x + cov[a][1] * axis.y + cov[a][2] * axis.z;
      const double len = glm::length(next);
      if (!(len > 0)) return glm::dvec3(0.0);
      axis = next / len;
    }
    return axis;
  };
  const auto try_split = [&](const std::vector<glm::dvec3>& v) {
    glm::dvec3 mean;
    const glm::dvec3 axis = principal(v, mean);
    std::size_t ones = 0;
    for (std::size_t i = 0; i < n; ++i) ones += side[i] = glm::dot(v[i] - mean, axis) > 0;
    return ones > 0 && ones < n;
  };
  std::vector<glm::dvec3> normals(n), centroids(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t t = c.faces[i];
    normals[i] = f.normal[t];
    centroids[i] = (f.position[f.weld[t][0]] + f.position[f.weld[t][1]] + f.position[f.weld[t][2]]) / 3.0;
  }
  if (!try_split(normals) && !try_split(centroids))
    for (std::size_t i = 0; i < n; ++i) side[i] = i >= n / 2;
  return pieces(c, f, side);
}

// Convex hull (Andrew's monotone chain), counter-clockwise.
std::vector<glm::dvec2> convex_hull(std::vector<glm::dvec2> p) {
  std::sort(p.begin(), p.end(), [](const glm::dvec2& a, const glm::dvec2& b) { return a.x != b.x ? a.x < b.x : a.y < b.y; });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  std::vector<glm::dvec2> h(2 * p.size());
  std::size_t k = 0;
  const auto cross = [](const glm::dvec2& o, const glm::dvec2& a, const glm::dvec2& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
    h[k++] = p[i - 1];
  }
  h.resize(k - 1);
  return h;
}

// Scales a flattened chart to world units (its UV area its world area) and
// turns it to its smallest bounding rectangle (a hull edge's direction),
// the rectangle's corner at the origin.
void finish_chart(Chart& c) {
  double uv_area = 0;
  for (const Tri& t : c.tris) {
    const glm::dvec2 a = c.uv[t[0]], b = c.uv[t[1]], d = c.uv[t[2]];
    uv_area += 0.5 * ((b.x - a.x) * (d.y - a.y) - (d.x - a.x) * (b.y - a.y));
  }
  const double s = uv_area > 0 ? std::sqrt(c.area3 / uv_area) : 1.0;
  for (glm::dvec2& q : c.uv) q *= s;
  const std::vector<glm::dvec2> hull = convex_hull(c.uv);
  glm::dvec2 best_dir(1.0, 0.0);
  double best_area = std::numeric_limits<double>::infinity();
  const std::size_t step = std::max<std::size_t>(1, hull.size() / 256);
  for (std::size_t i = 0; i < hull.size(); i += step) {
    const glm::dvec2 e = hull[(i + 1) % hull.size()] - hull[i];
    const double len = glm::length(e);
    if (!(len > 0)) continue;
    const glm::dvec2 d = e / len, nrm(-d.y, d.x);
    double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
    for (const glm::dvec2& q : hull) {
      const double a = glm::dot(q, d), b = glm::dot(q, nrm);
      x0 = std::min(x0, a), x1 = std::max(x1, a), y0 = std::min(y0, b), y1 = std::max(y1, b);
    }
    if ((x1 - x0) * (y1 - y0) < best_area) best_area = (x1 - x0) * (y1 - y0), best_dir = d;
  }
  const glm::dvec2 nrm(-best_dir.y, best_dir.x);
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (glm::dvec2& q : c.uv) {
    q = glm::dvec2(glm::dot(q, best_dir), glm::dot(q, nrm));
    lo = glm::min(lo, q), hi = glm::max(hi, q);
  }
  for (glm::dvec2& q : c.uv) q -= lo;
  c.extent = hi - lo;
}

// Splits a chart that fills too little of its rectangle (an arc, a long
// bent strip) across its rectangle's long side, at the median of its area.
std::vector<std::vector<std::uint32_t>> split_long(const Chart& c, const Faces& f) {
  const std::size_t n = c.faces.size();
  const int axis = c.extent.x >= c.extent.y ? 0 : 1;
  std::vector<std::pair<double, double>> at(n);  // centroid along the axis, area
  double total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Tri& t = c.tris[i];
    at[i] = {(c.uv[t[0]][axis] + c.uv[t[1]][axis] + c.uv[t[2]][axis]) / 3.0, f.area[c.faces[i]]};
    total += at[i].second;
  }
  std::vector<std::pair<double, double>> sorted(at);
  std::sort(sorted.begin(), sorted.end());
  double median = sorted.back().first, sum = 0;
  for (const auto& [x, a] : sorted)
    if ((sum += a) >= 0.5 * total) {
      median = x;
      break;
    }
  std::vector<std::uint8_t> side(n);
  std::size_t ones = 0;
  for (std::size_t i = 0; i < n; ++i) ones += side[i] = at[i].first > median;
  if (ones == 0 || ones == n)
    for (std::size_t i = 0; i < n; ++i) side[i] = i >= n / 2;
  return pieces(c, f, side);
}

// Flattens one grown chart: planar projection, else LSCM, else split and
// again (a single triangle, planar onto its own plane, always passes); then
// a chart filling less than kMinFill of its rectangle is cut in two.
std::vector<Chart> flatten(std::vector<std::uint32_t> faces, const Faces& f, double max_stretch) {
  std::vector<Chart> out;
  std::vector<std::vector<std::uint32_t>> stack;
  stack.push_back(std::move(faces));
  while (!stack.empty()) {
    Chart c = make_chart(std::move(stack.back()), f);
    stack.pop_back();
    planar(c, f);
    std::vector<std::vector<std::uint32_t>> parts;
    if (c.faces.size() == 1 || acceptable(c, f, max_stretch) || (lscm(c, f) && acceptable(c, f, max_stretch))) {
      finish_chart(c);
      if (c.faces.size() == 1 || !(c.area3 < kMinFill * c.extent.x * c.extent.y)) {
        out.push_back(std::move(c));
        continue;
      }
      parts = split_long(c, f);
    } else {
      parts = split_chart(c, f);
    }
    for (auto it = parts.rbegin(); it != parts.rend(); ++it) stack.push_back(std::move(*it));
  }
  return out;
}

// The stretch bound charts are flattened to: a ten-thousandth inside the
// option's, for the UVs' rounding to float.
double chart_stretch(const UnwrapOptions& o) { return std::max(1 + 1e-9, o.max_stretch * (1 - 1e-4)); }

std::vector<Chart> make_charts(const Faces& f, const UnwrapOptions& o) {
  const double cos_limit = std::cos(o.max_chart_angle * M_PI / 180.0);
  const double max_stretch = chart_stretch(o);
  std::vector<std::vector<std::uint32_t>> grown = grow_charts(f, cos_limit);
  std::vector<std::vector<Chart>> flat(grown.size());
  tbb::parallel_for(std::size_t(0), grown.size(), [&](std::size_t i) {
    flat[i] = flatten(std::move(grown[i]), f, max_stretch);
  });
  std::vector<Chart> charts;
  for (auto& v : flat)
    for (Chart& c : v) charts.push_back(std::move(c));
  return charts;
}

// Pages (UnwrapOptions::pages != 1): a chart longer than a page at density
// d (a terrain at a fine texel) is cut across its long side at its area's
// median (split_long) and the parts flattened again, until every chart is
// shorter than `limit` texels. A cut whose parts are no shorter (a quad of
// two long triangles) is not made: the chart stays, and the packer refuses
// it as longer than a page. The charts keep their order, each cut chart's
// parts in its place.
void cut_to_page(std::vector<Chart>& charts, const Faces& f, double d, double limit, double max_stretch) {
  const auto longest = [](const Chart& c) { return std::max(c.extent.x, c.extent.y); };
  std::vector<Chart> out;
  out.reserve(charts.size());
  for (Chart& c : charts) {
    std::vector<Chart> stack;
    stack.push_back(std::move(c));
    while (!stack.empty()) {
      Chart x = std::move(stack.back());
      stack.pop_back();
      if (longest(x) * d < limit || x.faces.size() == 1) {
        out.push_back(std::move(x));
        continue;
      }
      std::vector<Chart> cut;
      for (std::vector<std::uint32_t>& part : split_long(x, f))
        for (Chart& p : flatten(std::move(part), f, max_stretch)) cut.push_back(std::move(p));
      double most = 0;
      for (const Chart& p : cut) most = std::max(most, longest(p));
      if (!(most < 0.9 * longest(x))) {
        out.push_back(std::move(x));
        continue;
      }
      for (auto it = cut.rbegin(); it != cut.rend(); ++it) stack.push_back(std::move(*it));
    }
  }
  charts = std::move(out);
}


// ---- Packing -----------------------------------------------------------------

using Span = std::pair<int, int>;  // columns [first, second)

// Rows of bits (a texel each): the atlas's occupied texels, a chart's footprint.
class BitRows {
 public:
  BitRows(int width, int height) : W(width), H(height), words((width + 63) / 64), bits(std::size_t(words) * height, 0) {}
  const int W, H;

  bool test(int y, int x) const { return (row(y)[x >> 6] >> (x & 63)) & 1; }
  int next_set(int y, int x) const { return scan(y, x, 0); }
  int next_clear(int y, int x) const { return scan(y, x, ~0ull); }
  // The last set bit in [x0, x1) of row y, or -1.
  int last_set(int y, int x0, int x1) const {
    const std::uint64_t* r = row(y);
    for (int w = (x1 - 1) >> 6; w >= (x0 >> 6); --w) {
      std::uint64_t word = r[w];
      if (w == ((x1 - 1) >> 6) && ((x1 - 1) & 63) != 63) word &= (2ull << ((x1 - 1) & 63)) - 1;
      if (w == (x0 >> 6)) word &= ~0ull << (x0 & 63);
      if (word) return w * 64 + 63 - std::countl_zero(word);
    }
    return -1;
  }
  void set(int y, int x0, int x1) {
    std::uint64_t* r = bits.data() + std::size_t(y) * words;
    for (int x = x0; x < x1;) {
      const int w = x >> 6, b = x & 63, n = std::min(64 - b, x1 - x);
      r[w] |= (n == 64 ? ~0ull : ((1ull << n) - 1)) << b;
      x += n;
    }
  }
  // fn(first, end) for each run of set bits in row y.
  template <class Fn>
  void for_each_run(int y, Fn&& fn) const {
    for (int x = next_set(y, 0); x < W;) {
      const int e = next_clear(y, x);
      fn(x, e);
      x = e < W ? next_set(y, e) : W;
    }
  }

 private:
  const std::uint64_t* row(int y) const { return bits.data() + std::size_t(y) * words; }
  // The first bit >= x of row y that differs from `skip`'s, or W.
  int scan(int y, int x, std::uint64_t skip) const {
    if (x >= W) return W;
    const std::uint64_t* r = row(y);
    int w = x >> 6;
    std::uint64_t word = (r[w] ^ skip) & (~0ull << (x & 63));
    while (!word) {
      if (++w >= words) return W;
      word = r[w] ^ skip;
    }
    return std::min(W, w * 64 + std::countr_zero(word));
  }
  int words;
  std::vector<std::uint64_t> bits;
};

// A chart's texels at one density and orientation (conservative: every
// texel a triangle touches, as lightmap_texels finds them, and those within
// a rounding's reach): rows of spans.
struct Footprint {
  int w = 0, h = 0;
  std::vector<std::uint32_t> rows;  // h + 1 offsets into spans
  std::vector<Span> spans;
  std::vector<int> widest;          // per row: its widest span
  std::size_t cells = 0;
  std::uint64_t hash = 0;           // of the shape (w, h, spans)

  bool operator==(const Footprint& o) const { return w == o.w && h == o.h && rows == o.rows && spans == o.spans; }

  void add_row(const std::vector<Span>& row) {
    if (rows.empty()) rows.push_back(0);
    int most = 0;
    for (const Span& s : row) most = std::max(most, s.second - s.first), cells += std::size_t(s.second - s.first);
    widest.push_back(most);
    spans.insert(spans.end(), row.begin(), row.end());
    rows.push_back(std::uint32_t(spans.size()));
    hash = (hash ^ (std::uint64_t(rows.size()) << 40 | std::uint64_t(w) << 20 | std::uint64_t(h))) * 0x100000001b3ull;
    for (const Span& s : row) hash = (hash ^ (std::uint64_t(std::uint32_t(s.first)) << 32 | std::uint32_t(s.second))) * 0x100000001b3ull;
  }
};

// Where a chart lies in the atlas: texel (x, y) of its footprint's corner,
// turned `turn` quarters (chart_texel).
struct Placement {
  int x = 0, y = 0, turn = 0, page = 0;
};

// A chart's point in texels at density d before its placement: its extent
// starts `margin` into its first texel, in a w0 x h0 footprint turned
// `turn` quarters about it ((x, y) to (h0 - y, x), (w0 - x, h0 - y), (y, w0 - x)).
glm::dvec2 chart_texel(const Chart& c, std::size_t i, double d, double margin, int turn, int w0, int h0) {
  const glm::dvec2 q = c.uv[i] * d + margin;
  switch (turn) {
    case 1: return {h0 - q.y, q.x};
    case 2: return {w0 - q.x, h0 - q.y};
    case 3: return {q.y, w0 - q.x};
    default: return q;
  }
}

// The x range of triangle q's part within rows [lo, hi]; false if none.
bool band_range(const glm::dvec2 q[3], double lo, double hi, double& x0, double& x1) {
  x0 = std::numeric_limits<double>::infinity(), x1 = -x0;
  for (int k = 0; k < 3; ++k) {
    const glm::dvec2 a = q[k], b = q[(k + 1) % 3];
    if (a.y >= lo && a.y <= hi) x0 = std::min(x0, a.x), x1 = std::max(x1, a.x);
    for (const double y : {lo, hi})
      if ((a.y - y) * (b.y - y) < 0) {
        const double x = a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x);
        x0 = std::min(x0, x), x1 = std::max(x1, x);
      }
  }
  return x0 <= x1;
}

// The chart's footprint (w0 x h0 texels) turned 0 to 3 quarters (as
// chart_texel turns its points): each texel a triangle, grown by eps, meets.
std::array<Footprint, 4> rasterise(const Chart& c, double d, double margin, int w0, int h0, double eps) {
  BitRows bits(w0, h0);
  for (const Tri& t : c.tris) {
    const glm::dvec2 q[3] = {chart_texel(c, t[0], d, margin, 0, w0, h0), chart_texel(c, t[1], d, margin, 0, w0, h0),
                             chart_texel(c, t[2], d, margin, 0, w0, h0)};
    const double ymin = std::min({q[0].y, q[1].y, q[2].y}), ymax = std::max({q[0].y, q[1].y, q[2].y});
    const int r0 = std::max(0, int(std::floor(ymin - eps))), r1 = std::min(h0 - 1, int(std::ceil(ymax + eps)) - 1);
    for (int r = r0; r <= r1; ++r) {
      double x0, x1;
      if (!band_range(q, r - eps, r + 1 + eps, x0, x1)) continue;
      const int a = std::max(0, int(std::floor(x0 - eps))), b = std::min(w0, int(std::ceil(x1 + eps)));
      if (b > a) bits.set(r, a, b);
    }
  }
  std::array<Footprint, 4> fp;
  std::vector<Span> row;
  // Turned t quarters, texel (x, y) of row `line` (line of the unturned texels).
  for (int turn = 0; turn < 4; ++turn) {
    const std::size_t rows = std::size_t(turn % 2 ? w0 : h0);
    fp[std::size_t(turn)].rows.reserve(rows + 1);
    fp[std::size_t(turn)].widest.reserve(rows);
    fp[std::size_t(turn)].spans.reserve(rows + 2);
  }
  const auto add = [&](int turn, int rows, int length, auto&& texel) {
    fp[std::size_t(turn)].w = length, fp[std::size_t(turn)].h = rows;
    for (int line = 0; line < rows; ++line) {
      row.clear();
      for (int k = 0; k < length; ++k) {
        if (!texel(line, k)) continue;
        if (!row.empty() && row.back().second == k)
          ++row.back().second;
        else
          row.emplace_back(k, k + 1);
      }
      fp[std::size_t(turn)].add_row(row);
    }
  };
  fp[0].w = w0, fp[0].h = h0;
  for (int y = 0; y < h0; ++y) {  // unturned: the runs of each row
    row.clear();
    bits.for_each_run(y, [&](int a, int e) { row.emplace_back(a, e); });
    fp[0].add_row(row);
  }
  add(1, w0, h0, [&](int line, int k) { return bits.test(h0 - 1 - k, line); });
  add(2, h0, w0, [&](int line, int k) { return bits.test(h0 - 1 - line, w0 - 1 - k); });
  add(3, w0, h0, [&](int line, int k) { return bits.test(k, w0 - 1 - line); });
  return fp;
}

// The atlas: occupied texels (charts grown by the padding), each row's
// longest free run, and per run length the first row with one (runs only
// shrink as charts are placed: rows above it never get one again).
class Atlas : public BitRows {
 public:
  Atlas(int width, int height)
      : BitRows(width, height), max_run(std::size_t(height), width), first(std::size_t(width) + 1, 0) {}
  int longest_run(int y) const { return max_run[std::size_t(y)]; }
  // The first row at or after y with a free run of at least w texels (H: none).
  int next_row_with(int y, int w) const {
    while (y < H && max_run[std::size_t(y)] < w) ++y;
    return y;
  }
  int first_row_with(int w) {
    int& r = first[std::size_t(std::clamp(w, 0, W))];
    return r = next_row_with(r, w);
  }
  void update_run(int y) {
    int best = 0;
    for (int x = next_clear(y, 0); x < W;) {
      const int e = next_set(y, x);
      best = std::max(best, e - x);
      x = e < W ? next_clear(y, e) : W;
    }
    max_run[std::size_t(y)] = best;
  }

 private:
  std::vector<int> max_run, first;
};

// Where row r of the footprint, its corner at column x of atlas row y + r,
// first meets no occupied texel, at x or after (W: nowhere).
int first_free_at(const Atlas& atlas, const Footprint& fp, int r, int x, int y) {
  for (std::uint32_t i = fp.rows[std::size_t(r)]; i < fp.rows[std::size_t(r) + 1]; ++i) {
    const auto [a, e] = fp.spans[i];
    const int c = atlas.last_set(y + r, x + a, x + e);
    if (c < 0) continue;
    // Past the occupied texel, to the first free run the span fits in.
    for (int s = c + 1;;) {
      s = atlas.next_clear(y + r, s);
      if (s >= atlas.W) return atlas.W;
      const int g = atlas.next_set(y + r, s);
      if (g - s >= e - a) return s - a;
      s = g + 1;
    }
  }
  return x;
}

// The first place (rows, then columns, from the border, at or after
// (from_y, from_x) where it is known not to fit earlier) where the
// footprint meets no occupied texel, on rows up to max_y; false if none.
// Rows whose free runs are all shorter than the footprint's row are
// skipped; the footprint's rows are checked round from the last one that
// blocked (blocks come in runs) until all pass at one column.
bool find_place(Atlas& atlas, const Footprint& fp, int border, int max_y, int from_y, int from_x, int& out_x,
                int& out_y) {
  const int last_x = atlas.W - border - fp.w, last_y = std::min(max_y, atlas.H - border - fp.h);
  int y = std::max(from_y, border);
  for (int k = 0; k < fp.h; ++k) y = std::max(y, atlas.first_row_with(fp.widest[std::size_t(k)]) - k);
  for (int r = 0; y <= last_y; ++y) {
    int k = 0;
    while (k < fp.h && atlas.longest_run(y + k) >= fp.widest[std::size_t(k)]) ++k;
    if (k < fp.h) {
      y = atlas.next_row_with(y + k + 1, fp.widest[std::size_t(k)]) - k - 1;
      continue;
    }
    for (int x = y == from_y ? std::max(from_x, border) : border, passed = 0; x <= last_x;) {
      const int next = first_free_at(atlas, fp, r, x, y);
      if (next == x) {
        if (++passed == fp.h) {
          out_x = x, out_y = y;
          return true;
        }
        r = r + 1 == fp.h ? 0 : r + 1;
      } else {
        x = next, passed = 0;
      }
    }
  }
  return false;
}

// Marks the footprint at (x, y), grown by the padding, occupied.
void occupy(Atlas& atlas, const Footprint& fp, int x, int y, int pad) {
  for (int r = 0; r < fp.h; ++r)
    for (std::uint32_t i = fp.rows[std::size_t(r)]; i < fp.rows[std::size_t(r) + 1]; ++i) {
      const int x0 = std::max(0, x + fp.spans[i].first - pad), x1 = std::min(atlas.W, x + fp.spans[i].second + pad);
      for (int row = std::max(0, y + r - pad); row <= std::min(atlas.H - 1, y + r + pad); ++row) atlas.set(row, x0, x1);
    }
  for (int row = std::max(0, y - pad); row <= std::min(atlas.H - 1, y + fp.h - 1 + pad); ++row) atlas.update_run(row);
}

// The charts' footprints at density d (four ways round), or false when a
// chart is longer than `limit` texels.
struct Footprints {
  double density = 0, margin = 0;
  std::vector<std::array<Footprint, 4>> fp;
  std::vector<std::array<std::uint8_t, 4>> twin;  // per chart and turn: 1 when an earlier turn's footprint is the same
  std::vector<int> w0, h0;                        // per chart: its unturned footprint's size
};

bool make_footprints(const std::vector<Chart>& charts, double d, double eps, int limit, Footprints& out) {
  out.density = d;
  out.margin = 2 * eps;
  out.fp.assign(charts.size(), {});
  out.twin.assign(charts.size(), {});
  out.w0.assign(charts.size(), 0);
  out.h0.assign(charts.size(), 0);
  for (std::size_t i = 0; i < charts.size(); ++i) {
    if (!(charts[i].extent.x * d < limit && charts[i].extent.y * d < limit)) return false;
    out.w0[i] = std::max(1, int(std::ceil(out.margin + charts[i].extent.x * d + eps)));
    out.h0[i] = std::max(1, int(std::ceil(out.margin + charts[i].extent.y * d + eps)));
  }
  tbb::parallel_for(std::size_t(0), charts.size(), [&](std::size_t i) {
    out.fp[i] = rasterise(charts[i], d, out.margin, out.w0[i], out.h0[i], eps);
    for (std::size_t t = 1; t < 4; ++t)
      for (std::size_t u = 0; u < t && !out.twin[i][t]; ++u) out.twin[i][t] = out.fp[i][t] == out.fp[i][u];
  });
  return true;
}

// Where each footprint shape (charts of one shape: a scene's repeated
// boxes) was last found: no later search for it finds a place earlier.
class Memo {
 public:
  std::pair<int, int>& at(const Footprint& fp) {
    auto& list = by_hash[fp.hash];
    for (auto& [seen, from] : list)
      if (*seen == fp) return from;
    list.emplace_back(&fp, std::pair<int, int>(0, 0));
    return list.back().second;
  }

 private:
  std::unordered_map<std::uint64_t, std::vector<std::pair<const Footprint*, std::pair<int, int>>>> by_hash;
};

// Where chart c first fits in `atlas` (scan order; any of four turns, the
// earliest): turn -1 when it does not.
Placement place_on(Atlas& atlas, Memo& memo, const Footprints& f, std::uint32_t c, int border) {
  Placement best{0, atlas.H, -1};
  // The turns with fewer rows first: they reach less deep, and bound the others' search.
  const int first = f.h0[c] <= f.w0[c] ? 0 : 1;
  for (const int turn : {first, first + 2, 1 - first, 3 - first}) {
    if (f.twin[c][std::size_t(turn)]) continue;
    const Footprint& fp = f.fp[c][std::size_t(turn)];
    std::pair<int, int>& from = memo.at(fp);
    int x = 0, y = 0;
    if (find_place(atlas, fp, border, best.y, from.first, from.second, x, y)) {
      from = {y, x};
      if (y < best.y || (y == best.y && (x < best.x || (x == best.x && turn < best.turn)))) best = Placement{x, y, turn};
    } else {
      from = {std::max(from.first, std::min(best.y, atlas.H - border - fp.h) + 1), 0};
    }
  }
  return best;
}

// Places every chart, largest first, each on the first page where it fits
// (place_on), a new page opened when it fits none, up to `max_pages`; false
// when one does not fit. `pages` (non-null) receives the pages used.
bool place_all(const Footprints& f, const std::vector<std::uint32_t>& order, int W, int H, int pad, int max_pages,
               std::vector<Placement>& at, int* pages = nullptr) {
  const int border = (pad + 1) / 2;
  std::vector<Atlas> atlas;
  std::vector<Memo> memo;  // references into a Memo are kept: no reallocation
  atlas.reserve(std::size_t(max_pages));
  memo.reserve(std::size_t(max_pages));
  at.assign(f.fp.size(), {});
  for (const std::uint32_t c : order) {
    Placement best{0, H, -1};
    for (int page = 0; best.turn < 0; ++page) {
      const bool fresh = page == int(atlas.size());
      if (fresh && page == max_pages) return false;
      if (fresh) atlas.emplace_back(W, H), memo.emplace_back();
      best = place_on(atlas[std::size_t(page)], memo[std::size_t(page)], f, c, border);
      best.page = page;
      if (best.turn < 0 && fresh) return false;  // it fits no page, even an empty one
    }
    at[c] = best;
    occupy(atlas[std::size_t(best.page)], f.fp[c][std::size_t(best.turn)], best.x, best.y, pad);
  }
  if (pages) *pages = std::max(1, int(atlas.size()));
  return true;
}

// Texels a UV rounded to float may move, at most: half a float's spacing
// below 1, in texels of the larger side; twice that kept.
// On pages past the first, u = page + u' rounds 16 times coarser (below
// kMaxLightmapPages = 10 < 16).
double rounding_reach(int size, int pages = 1) {
  return double(size) * std::ldexp(1.0, pages > 1 ? -18 : -22);
}

struct Layout {
  Footprints f;
  std::vector<Placement> at;
  int width = 0, height = 0, pages = 1;  // a page's size, and the pages
};

std::vector<std::uint32_t> packing_order(const std::vector<Chart>& charts) {
  std::vector<std::uint32_t> order(charts.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const double ea = charts[a].extent.x * charts[a].extent.y, eb = charts[b].extent.x * charts[b].extent.y;
    return ea != eb ? ea > eb : a < b;
  });
  return order;
}

double largest_extent(const std::vector<Chart>& charts) {
  double e = 0;
  for (const Chart& c : charts) e = std::max({e, c.extent.x, c.extent.y});
  return e;
}

// A packing at density d: its footprints and placements, or false.
bool pack_at(const std::vector<Chart>& charts, const std::vector<std::uint32_t>& order, double d, double eps,
             const UnwrapOptions& o, Layout& out) {
  const int border = (o.padding + 1) / 2;
  return make_footprints(charts, d, eps, std::max(o.width, o.height) - 2 * border, out.f) &&
         place_all(out.f, order, o.width, o.height, o.padding, o.pages, out.at);
}

// width x height: the largest density at which the charts fit. From the
// area bound `hi` (no denser packing can fit): 3/4 and 1/2 of it, then
// lower halves until one fits (down to each chart one texel), then the
// bracket's thirds until it is a thousandth wide. Two trials at a time
// (in parallel), the same two whatever the threads: deterministic.
Layout fit_atlas(const std::vector<Chart>& charts, const UnwrapOptions& o, const std::string& source) {
  const int W = o.width, H = o.height, pad = o.padding, border = (pad + 1) / 2;
  Layout best;
  best.width = W, best.height = H, best.pages = o.pages;
  if (charts.empty()) return best;
  const double eps = rounding_reach(std::max(W, H), o.pages);
  const std::vector<std::uint32_t> order = packing_order(charts);
  double area = 0;
  for (const Chart& c : charts) area += c.area3;
  const double usable = double(W - 2 * border) * double(H - 2 * border) * o.pages;
  const double hi = std::sqrt(std::max(usable, 0.0) / area), d_min = 0.9 / largest_extent(charts);
  const auto refuse = [&] {
    return Error(fmt::format("{}: its {} lightmap charts do not fit {} {}x{} with padding {} at any texel density "
                             "(each chart at least one texel, {} texels apart): give a larger atlas{} or a smaller "
                             "padding",
                             source, charts.size(), o.pages > 1 ? fmt::format("{} pages of", o.pages) : "a", W, H, pad,
                             pad, o.pages < kMaxLightmapPages ? ", more pages" : ""));
  };
  if (!(usable > 0)) throw refuse();
  // Trials at a < b: which fit; `best` the densest that did.
  double lo = 0, fail = hi;
  const auto trial = [&](double a, double b) {
    Layout la, lb;
    bool fa = false, fb = false;
    tbb::parallel_invoke([&] { fa = pack_at(charts, order, a, eps, o, la); },
                         [&] { fb = pack_at(charts, order, b, eps, o, lb); });
    if (fb)
      lo = b, best.f = std::move(lb.f), best.at = std::move(lb.at);
    else if (fa)
      lo = a, fail = b, best.f = std::move(la.f), best.at = std::move(la.at);
    else
      fail = a;
  };
  trial(0.5 * hi, 0.75 * hi);
  while (lo == 0) {
    if (fail <= d_min) throw refuse();
    const double next = std::max(d_min, 0.5 * fail);
    Layout l;
    if (pack_at(charts, order, next, eps, o, l))
      lo = next, best.f = std::move(l.f), best.at = std::move(l.at);
    else
      fail = next;
  }
  for (int i = 0; i < 16 && fail - lo > 1e-3 * lo; ++i) trial(lo + (fail - lo) / 3, lo + 2 * (fail - lo) / 3);
  return best;
}

// texel_size: the smallest square atlas (growing its side, then bisecting
// between the last that failed and the first that held), cut to the rows
// and columns it uses.
Layout size_atlas(const std::vector<Chart>& charts, const UnwrapOptions& o, const std::string& source) {
  const int pad = o.padding, border = (pad + 1) / 2, limit = kMaxLightmapSize - 2 * border;
  const double d = 1.0 / o.texel_size;
  Layout best;
  if (charts.empty()) {
    best.width = best.height = 1;
    return best;
  }
  double area = 0;
  for (const Chart& c : charts) area += c.area3;
  const auto refuse = [&](const std::string& why) {
    return Error(fmt::format("{}: texels of {:g} need {}, past the largest lightmap ({} x {} texels): give a larger "
                             "texel size, or lay them on pages (UnwrapOptions::pages 0; prt unwrap --pages auto "
                             "--lightmap WxH)",
                             source, o.texel_size, why, kMaxLightmapSize, kMaxLightmapSize));
  };
  if (!(area * d * d <= double(limit) * limit)) throw refuse(fmt::format("{:.3g} texels of surface", area * d * d));
  if (!make_footprints(charts, d, rounding_reach(kMaxLightmapSize), limit, best.f))
    throw refuse(fmt::format("{:.3g} texels for its largest chart", largest_extent(charts) * d));
  const std::vector<std::uint32_t> order = packing_order(charts);
  std::size_t cells = 0;
  int side = 1;
  for (const auto& fp : best.f.fp) cells += fp[0].cells, side = std::max(side, std::min(fp[0].w, fp[0].h));
  side = std::min(kMaxLightmapSize, std::max(side, int(std::ceil(std::sqrt(double(cells))))) + 2 * border);
  int failed = 0;
  std::vector<Placement> at;
  while (!place_all(best.f, order, side, side, pad, 1, at)) {
    if (side >= kMaxLightmapSize) throw refuse(fmt::format("more than {} x {} texels", side, side));
    failed = side;
    side = std::min(kMaxLightmapSize, std::max(side + 1, int(std::ceil(side * 1.06))));
  }
  best.at = at;
  for (int good = side; good - failed > 1;) {
    const int mid = failed + (good - failed) / 2;
    if (place_all(best.f, order, mid, mid, pad, 1, at))
      good = side = mid, best.at = at;
    else
      failed = mid;
  }
  int used_w = 0, used_h = 0;
  for (std::size_t c = 0; c < charts.size(); ++c) {
    const Footprint& fp = best.f.fp[c][std::size_t(best.at[c].turn)];
    used_w = std::max(used_w, best.at[c].x + fp.w), used_h = std::max(used_h, best.at[c].y + fp.h);
  }
  best.width = std::min(side, used_w + border);
  best.height = std::min(side, used_h + border);
  return best;
}

// texel_size with pages: width x height pages at that density, as many as
// the charts take (up to kMaxLightmapPages).
Layout page_atlas(const std::vector<Chart>& charts, const UnwrapOptions& o, const std::string& source) {
  const int W = o.width, H = o.height, pad = o.padding, border = (pad + 1) / 2;
  const double d = 1.0 / o.texel_size;
  Layout best;
  best.width = W, best.height = H;
  if (charts.empty()) return best;
  if (!make_footprints(charts, d, rounding_reach(std::max(W, H), kMaxLightmapPages), std::max(W, H) - 2 * border, best.f))
    throw Error(fmt::format("{}: texels of {:g} make a chart {:.3g} texels long, longer than a {}x{} page: give a "
                            "larger texel size or larger pages",
                            source, o.texel_size, largest_extent(charts) * d, W, H));
  if (!place_all(best.f, packing_order(charts), W, H, pad, kMaxLightmapPages, best.at, &best.pages))
    throw Error(fmt::format("{}: texels of {:g} need more than {} pages of {}x{} (or a chart fits no page): give a "
                            "larger texel size or larger pages",
                            source, o.texel_size, kMaxLightmapPages, W, H));
  return best;
}

// ---- The scene with the new UV set ---------------------------------------------

// Each triangle's corners as (vertex, group) pairs, group a chart, or for a
// triangle without area (no chart of its own) a group of its own whose
// corners sit on one point of a neighbouring chart (or on UV 0 without
// one). A chart's triangle whose UVs, rounded to float, fold or leave the
// stretch or area bounds (a sliver a fraction of a texel thin) is put on one
// point too: its neighbours cover its texels.
struct CornerUvs {
  std::vector<std::uint32_t> group;  // per corner
  std::vector<glm::vec2> uv;         // per corner
};

// Whether triangle t's float UVs keep the bounds, measured as atlas_stats measures them.
bool keeps_bounds(const Faces& f, std::size_t t, const glm::vec2 uv[3], const Layout& L, double max_stretch) {
  const glm::dvec2 size(L.width, L.height);
  const glm::dvec3 p[3] = {f.position[f.weld[t][0]], f.position[f.weld[t][1]], f.position[f.weld[t][2]]};
  const glm::dvec2 q[3] = {glm::dvec2(uv[0]) * size, glm::dvec2(uv[1]) * size, glm::dvec2(uv[2]) * size};
  double ratio = 0;
  const double stretch = triangle_stretch(p, q, ratio), mean = L.f.density * L.f.density;
  const double area2 = (q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y);
  return area2 > 1e-12 && ratio > 0 && stretch <= max_stretch && ratio >= mean / kAreaLimit && ratio <= mean * kAreaLimit;
}

CornerUvs corner_uvs(const Faces& f, const std::vector<Chart>& charts, const Layout& L, double max_stretch) {
  const std::size_t T = f.weld.size();
  std::vector<std::uint32_t> face_chart(T, kNone), face_slot(T, 0), weld_chart(f.position.size(), kNone);
  for (std::uint32_t c = 0; c < charts.size(); ++c)
    for (std::uint32_t i = 0; i < charts[c].faces.size(); ++i) face_chart[charts[c].faces[i]] = c, face_slot[charts[c].faces[i]] = i;
  for (std::size_t t = 0; t < T; ++t)
    if (face_chart[t] != kNone)
      for (const std::uint32_t w : f.weld[t])
        if (weld_chart[w] == kNone) weld_chart[w] = face_chart[t];
  // Every chart vertex's UV, rounded to float once and read from memory after.
  std::vector<std::vector<glm::vec2>> chart_uv(charts.size());
  for (std::uint32_t c = 0; c < charts.size(); ++c) {
    const Placement& p = L.at[c];
    chart_uv[c].resize(charts[c].welds.size());
    for (std::size_t i = 0; i < charts[c].welds.size(); ++i) {
      const glm::dvec2 q = chart_texel(charts[c], i, L.f.density, L.f.margin, p.turn, L.f.w0[c], L.f.h0[c]) + glm::dvec2(p.x, p.y);
      chart_uv[c][i] = glm::vec2(float(q.x / L.width + p.page), float(q.y / L.height));
    }
  }
  const auto uv_of = [&](std::uint32_t c, std::uint32_t local) { return chart_uv[c][local]; };
  const auto local_of = [&](std::uint32_t c, std::uint32_t w) {
    const auto& welds = charts[c].welds;
    const auto it = std::lower_bound(welds.begin(), welds.end(), w);
    return it != welds.end() && *it == w ? std::uint32_t(it - welds.begin()) : kNone;
  };
  CornerUvs out;
  out.group.resize(3 * T);
  out.uv.resize(3 * T);
  // Triangle t's corners on the point of chart c's vertex `anchor` (UV 0 without a chart).
  const auto collapse = [&](std::size_t t, std::uint32_t c, std::uint32_t anchor) {
    const glm::vec2 at = c == kNone ? glm::vec2(0.0f) : uv_of(c, anchor);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t local = c == kNone ? kNone : local_of(c, f.weld[t][k]);
      const bool on_chart = local != kNone && uv_of(c, local) == at;
      out.group[3 * t + k] = on_chart ? c : std::uint32_t(charts.size() + t);
      out.uv[3 * t + k] = at;
    }
  };
  for (std::size_t t = 0; t < T; ++t) {
    if (face_chart[t] != kNone) {
      const std::uint32_t c = face_chart[t];
      const Tri& local = charts[c].tris[face_slot[t]];
      const glm::vec2 uv[3] = {uv_of(c, local[0]), uv_of(c, local[1]), uv_of(c, local[2])};
      if (!keeps_bounds(f, t, uv, L, max_stretch)) {
        collapse(t, c, local[0]);
        continue;
      }
      for (int k = 0; k < 3; ++k) out.group[3 * t + k] = c, out.uv[3 * t + k] = uv[k];
      continue;
    }
    std::uint32_t c = kNone, anchor = kNone;
    for (int k = 0; k < 3 && c == kNone; ++k)
      if (weld_chart[f.weld[t][k]] != kNone) c = weld_chart[f.weld[t][k]], anchor = local_of(c, f.weld[t][k]);
    collapse(t, c, anchor);
  }
  return out;
}

// The scene's vertices split per (vertex, group), each object's contiguous,
// with the new UV set appended.
Scene assemble(const Scene& scene, const CornerUvs& corners) {
  const Mesh& in = scene.mesh;
  const std::size_t T = in.triangles.size(), objects = std::max<std::size_t>(scene.objects.size(), 1);
  std::vector<std::vector<std::uint32_t>> by_object(objects);
  for (std::uint32_t t = 0; t < T; ++t) by_object[object_of(scene, t)].push_back(t);
  Scene out;
  out.mesh.source = in.source;
  out.mesh.report = in.report;
  out.mesh.report.unreferenced_vertices = 0;
  out.mesh.corner_uvs = in.corner_uvs;
  out.mesh.triangles.resize(T);
  out.objects = scene.objects;
  std::vector<std::uint32_t> source;
  std::vector<glm::vec2> lightmap;
  std::unordered_map<std::uint64_t, std::uint32_t> index;
  index.reserve(T * 2);
  for (std::size_t o = 0; o < objects; ++o) {
    const std::size_t first = source.size();
    for (const std::uint32_t t : by_object[o])
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t v = in.triangles[t][k];
        const auto [it, fresh] = index.emplace((std::uint64_t(v) << 32) | corners.group[3 * t + k], std::uint32_t(source.size()));
        if (fresh) source.push_back(v), lightmap.push_back(corners.uv[3 * t + k]);
        out.mesh.triangles[t][k] = it->second;
      }
    if (!scene.objects.empty()) {
      out.objects[o].first_vertex = first;
      out.objects[o].vertex_count = source.size() - first;
      out.objects[o].uv_sets = int(scene.uv_sets.size()) + 1;
    }
  }
  const auto gather = [&](const auto& values) {
    std::remove_cvref_t<decltype(values)> v;
    if (values.size() != in.positions.size()) return v;
    v.reserve(source.size());
    for (const std::uint32_t s : source) v.push_back(values[s]);
    return v;
  };
  out.mesh.positions = gather(in.positions);
  out.mesh.normals = gather(in.normals);
  out.mesh.colors = gather(in.colors);
  for (const auto& set : scene.uv_sets) out.uv_sets.push_back(gather(set));
  out.uv_sets.push_back(std::move(lightmap));
  out.materials = scene.materials;
  out.textures = scene.textures;
  out.triangle_object = scene.triangle_object;
  out.lights = scene.lights;
  return out;
}

// The checks make_scene makes, on what unwrap_scene built (a failure is prt's bug).
void check_result(const Scene& s, int pages) {
  const std::size_t V = s.mesh.positions.size();
  bool ok = V > 0 && (s.mesh.normals.empty() || s.mesh.normals.size() == V) && (s.mesh.colors.empty() || s.mesh.colors.size() == V);
  for (const auto& set : s.uv_sets) ok = ok && set.size() == V;
  for (const glm::uvec3& t : s.mesh.triangles) ok = ok && t.x < V && t.y < V && t.z < V;
  for (const glm::vec2& q : s.uv_sets.back()) ok = ok && q.x >= 0.0f && q.x <= float(pages) && q.y >= 0.0f && q.y <= 1.0f;
  if (!ok) throw Error(s.mesh.source + ": unwrap made an inconsistent scene (a bug in prt)");
}

// ---- Atlas statistics --------------------------------------------------------------

// Per triangle with UV area (kNone for the others): its chart, triangles
// joined by an edge whose two ends share position and UV; `count` charts.
std::vector<std::uint32_t> uv_charts(const Scene& scene, const std::vector<glm::vec2>& uv, int W, int H, std::size_t& count) {
  const Mesh& mesh = scene.mesh;
  const std::size_t T = mesh.triangles.size();
  atlas_raster::UnionFind uf = atlas_raster::uv_charts(mesh, uv);
  std::vector<std::uint8_t> has_area(T, 0);
  for (std::uint32_t t = 0; t < T; ++t) has_area[t] = !atlas_raster::AtlasTriangle(uv, mesh.triangles[t], W, H).degenerate();
  std::vector<std::uint32_t> label(T, kNone), dense(T, kNone);
  count = 0;
  for (std::uint32_t t = 0; t < T; ++t) {
    if (!has_area[t]) continue;
    const std::uint32_t r = uf.find(t);
    if (dense[r] == kNone) dense[r] = std::uint32_t(count++);
    label[t] = dense[r];
  }
  return label;
}

// Per texel: the chart covering it (the first triangle's, in order), kNone
// for none; `shared` counts texels two charts cover. Rasterised in bands of
// rows, each band's texels written by one task (the result is the order's).
std::vector<std::uint32_t> texel_charts(const Scene& scene, const std::vector<glm::vec2>& uv, int W, int H,
                                        const std::vector<std::uint32_t>& chart, std::size_t& shared) {
  const std::size_t T = scene.mesh.triangles.size();
  std::vector<std::uint32_t> texel(std::size_t(W) * H, kNone);
  std::vector<std::uint8_t> twice(std::size_t(W) * H, 0);
  constexpr int kBand = 64;
  const int bands = (H + kBand - 1) / kBand;
  std::vector<std::vector<std::uint32_t>> in_band(static_cast<std::size_t>(bands));
  for (std::uint32_t t = 0; t < T; ++t) {
    if (chart[t] == kNone) continue;
    const atlas_raster::AtlasTriangle at(uv, scene.mesh.triangles[t], W, H);
    for (int b = at.y0 / kBand; b <= at.y1 / kBand; ++b) in_band[std::size_t(b)].push_back(t);
  }
  tbb::parallel_for(0, bands, [&](int b) {
    atlas_raster::Poly p0, p1;
    for (const std::uint32_t t : in_band[std::size_t(b)]) {
      atlas_raster::AtlasTriangle at(uv, scene.mesh.triangles[t], W, H);
      at.y0 = std::max(at.y0, b * kBand), at.y1 = std::min(at.y1, b * kBand + kBand - 1);
      at.for_each_part(p0, p1, [&](int x, int y, double, const glm::dvec2&, const atlas_raster::Poly&) {
        const std::size_t i = std::size_t(y) * W + x;
        if (texel[i] == kNone)
          texel[i] = chart[t];
        else if (texel[i] != chart[t])
          twice[i] = 1;
      });
    }
  });
  shared = std::size_t(std::count(twice.begin(), twice.end(), 1));
  return texel;
}

// The fewest texels between two charts' covered texels (Chebyshev): a
// breadth-first search from every covered texel at once, each texel taking
// its nearest chart; two neighbours of different charts at distances a and
// b put those charts a + b + 1 apart. Stops once no closer pair can come.
int min_gap(const std::vector<std::uint32_t>& texel, int W, int H) {
  std::vector<std::uint32_t> label(texel);
  std::vector<std::uint16_t> dist(label.size(), 0);
  std::vector<std::uint32_t> front, next;
  for (std::uint32_t i = 0; i < label.size(); ++i)
    if (label[i] != kNone) front.push_back(i);
  long best = long(W) + H + 1;
  for (long r = 0; !front.empty() && 2 * r < best && r < 65535; ++r) {
    next.clear();
    for (const std::uint32_t i : front) {
      const int x = int(i % std::uint32_t(W)), y = int(i / std::uint32_t(W));
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if ((dx == 0 && dy == 0) || xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
          const std::size_t j = std::size_t(yy) * W + xx;
          if (label[j] == kNone) {
            label[j] = label[i], dist[j] = std::uint16_t(r + 1);
            next.push_back(std::uint32_t(j));
          } else if (label[j] != label[i]) {
            best = std::min(best, r + long(dist[j]) + 1);
          }
        }
    }
    front.swap(next);
  }
  return best > long(W) + H ? W + H : int(std::max(0L, best - 1));
}

// Throws prt::Error naming the scene for options out of range, a scene
// with no room for another UV set, or one whose arrays disagree.
void check_input(const Scene& scene, const UnwrapOptions& o) {
  const std::string& source = scene.mesh.source;
  if (!(o.padding >= 0 && o.padding <= kMaxLightmapSize / 4))
    throw Error(fmt::format("{}: unwrap padding {} is outside 0..{} texels", source, o.padding, kMaxLightmapSize / 4));
  if (!(o.max_stretch >= 1 && std::isfinite(o.max_stretch)))
    throw Error(fmt::format("{}: unwrap max stretch {} must be a number >= 1 (1: conformal)", source, o.max_stretch));
  if (!(o.max_chart_angle > 0 && o.max_chart_angle <= 180))
    throw Error(fmt::format("{}: unwrap chart angle {} must be in (0, 180] degrees", source, o.max_chart_angle));
  if (!(o.texel_size >= 0 && std::isfinite(o.texel_size)))
    throw Error(fmt::format("{}: unwrap texel size {} must be a finite number >= 0", source, o.texel_size));
  if ((o.texel_size == 0 || o.pages != 1) &&
      (o.width < 1 || o.height < 1 || o.width > kMaxLightmapSize || o.height > kMaxLightmapSize))
    throw Error(fmt::format("{}: lightmap size {}x{} is outside 1..{}", source, o.width, o.height, kMaxLightmapSize));
  if (!(o.pages >= (o.texel_size > 0 ? 0 : 1) && o.pages <= kMaxLightmapPages && (o.texel_size == 0 || o.pages <= 1)))
    throw Error(fmt::format("{}: unwrap pages {} must be 1 to {} for an atlas of a given size, 0 (as many as the texel "
                            "size needs) or 1 with a texel size",
                            source, o.pages, kMaxLightmapPages));
  if (scene.uv_sets.size() > std::size_t(kMaxLightmapUvSet))
    throw Error(fmt::format("{}: has {} UV sets already; the lightmap UVs would be TEXCOORD_{}, past TEXCOORD_{} (the "
                            "highest a lightmap is laid out in)",
                            source, scene.uv_sets.size(), scene.uv_sets.size(), kMaxLightmapUvSet));
  if (scene.mesh.triangles.empty()) throw Error(source + ": no triangles to unwrap");
  for (const auto& set : scene.uv_sets)
    if (set.size() != scene.mesh.positions.size()) throw Error(source + ": a UV set's size is not the vertex count");
  for (std::size_t t = 0; t < scene.mesh.triangles.size(); ++t) {
    const glm::uvec3 tri = scene.mesh.triangles[t];
    if (std::max({tri.x, tri.y, tri.z}) >= scene.mesh.positions.size() ||
        (!scene.objects.empty() && object_of(scene, t) >= scene.objects.size()))
      throw Error(fmt::format("{}: triangle {} names a vertex or object the scene does not have", source, t));
  }
}

}  // namespace
}  // namespace unwrap_detail

AtlasStats atlas_stats(const Scene& scene, int uv_set, int W, int H) {
  using namespace unwrap_detail;
  atlas_raster::check_stacked_atlas(scene, W, H, uv_set);  // H may be the rows of many pages stacked
  const Mesh& mesh = scene.mesh;
  const auto& uv = scene.uv_sets[std::size_t(uv_set)];
  if (uv.size() != mesh.positions.size())
    throw Error(fmt::format("{}: UV set {} has {} entries for {} vertices", mesh.source, uv_set, uv.size(), mesh.positions.size()));
  AtlasStats s;
  s.width = W, s.height = H;
  const std::vector<std::uint32_t> chart = uv_charts(scene, uv, W, H, s.charts);
  const std::vector<std::uint32_t> texel = texel_charts(scene, uv, W, H, chart, s.shared_texels);
  s.covered = std::size_t(W) * H - std::size_t(std::count(texel.begin(), texel.end(), kNone));
  s.use = double(s.covered) / (double(W) * H);
  s.min_gap = s.shared_texels > 0 ? 0 : min_gap(texel, W, H);
  // Distortion over the triangles with area in space and in the atlas.
  std::vector<double> ratio;
  double area3 = 0, area_uv = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const glm::uvec3 tri = mesh.triangles[t];
    const glm::dvec3 p[3] = {mesh.positions[tri.x], mesh.positions[tri.y], mesh.positions[tri.z]};
    const double a3 = 0.5 * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    if (!(a3 > 0)) continue;
    if (chart[t] == kNone) {
      ++s.degenerate;
      continue;
    }
    const glm::dvec2 q[3] = {glm::dvec2(uv[tri.x]) * glm::dvec2(W, H), glm::dvec2(uv[tri.y]) * glm::dvec2(W, H),
                             glm::dvec2(uv[tri.z]) * glm::dvec2(W, H)};
    double r = 0;
    const double stretch = triangle_stretch(p, q, r);
    if (std::isfinite(stretch)) s.max_stretch = std::max(s.max_stretch, stretch);
    ratio.push_back(std::abs(r));
    area3 += a3, area_uv += std::abs(r) * a3;
  }
  if (area_uv > 0) {
    const double mean = area_uv / area3;
    s.texel_size = std::sqrt(1.0 / mean);
    for (const double r : ratio)
      if (r > 0) s.max_area_ratio = std::max({s.max_area_ratio, r / mean, mean / r});
  }
  return s;
}

Scene unwrap_scene(const Scene& scene, const UnwrapOptions& o, AtlasStats* stats) {
  using namespace unwrap_detail;
  const auto start = std::chrono::steady_clock::now();
  const std::string& source = scene.mesh.source;
  check_input(scene, o);
  const Faces faces = build_faces(scene);
  std::vector<Chart> charts = make_charts(faces, o);
  if (o.pages != 1) {  // pages: no chart longer than a page, at the texel size or the densest the pages could hold
    const int border = (o.padding + 1) / 2, inner = std::min(o.width, o.height) - 2 * border;
    double area = 0;
    for (const Chart& c : charts) area += c.area3;
    const double d = o.texel_size > 0 ? 1.0 / o.texel_size
                                      : std::sqrt(double(o.width - 2 * border) * double(o.height - 2 * border) *
                                                  o.pages / std::max(area, 1e-300));
    // Two texels inside the page's inner side: a footprint's margins and rounding (make_footprints).
    if (inner > 2) cut_to_page(charts, faces, d, double(inner - 2), chart_stretch(o));
  }
  const Layout layout = o.texel_size > 0 ? (o.pages == 0 ? page_atlas(charts, o, source) : size_atlas(charts, o, source))
                                         : fit_atlas(charts, o, source);
  // The float UVs keep max_stretch (a conformal request, 1, keeps rounding's 1e-4).
  Scene out = assemble(scene, corner_uvs(faces, charts, layout, std::max(o.max_stretch, 1 + 1e-4)));
  check_result(out, layout.pages);
  if (stats) {
    const int set = int(out.uv_sets.size()) - 1;
    *stats = atlas_stats(stack_lightmap_pages(out, set, layout.pages), set, layout.width, layout.height * layout.pages);
    stats->pages = layout.pages;
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return out;
}

}  // namespace prt
