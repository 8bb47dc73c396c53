// Object-space dynamic ambient occlusion (prt/dynamic_ao.h): Bunnell's
// element shadows over a bounding-volume hierarchy of vertex discs.
#include <prt/dynamic_ao.h>

#include <prt/error.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>

namespace prt {

namespace {

// Elements a leaf holds at most. A leaf is never one disc: reached (its
// parent opened), its elements are summed one by one, so the hierarchy's
// finest level is exact. Taking leaves whole as well, when far enough, was
// measured: it doubles the hierarchy's error against every pair (the bent
// tube's mean 0.0033 -> 0.0064) to save 7-9% of the time.
constexpr std::size_t kLeafElements = 4;

struct Element {
  glm::dvec3 p, n;  // position; unit normal
  double area = 0;
  std::uint32_t vertex = 0;
};

struct Node {
  glm::dvec3 p{0.0}, n{0.0};  // area-weighted mean position; normalised mean normal (zero: not one disc)
  double area = 0;             // sum of the elements' areas
  double radius = 0;           // about p, holding every element's disc
  std::uint32_t skip = 0;      // the node after this one's subtree (depth-first order)
  std::uint32_t begin = 0, end = 0;  // elements (leaves only; begin == end for an inner node)
  bool disc = false;           // may be taken as one disc
  bool leaf() const { return end > begin; }
};

// Bunnell's element-to-element shadow (prt/dynamic_ao.h): `to` = emitter -
// receiver, d2 its squared length (> 0). 1 - 1/sqrt(1 + x) is written
// x / (s (1 + s)), s = sqrt(1 + x), which keeps its digits for the small x
// of distant discs.
inline double shadow(const glm::dvec3& to, double d2, const glm::dvec3& n_r, const glm::dvec3& n_e, double area) {
  const double inv_d = 1.0 / std::sqrt(d2);
  const double cos_r = glm::dot(n_r, to) * inv_d;
  if (!(cos_r > 0)) return 0;
  const double cos_e = glm::dot(n_e, to) * inv_d;
  if (!(cos_e > 0)) return 0;
  const double x = area / (std::numbers::pi * d2), s = std::sqrt(1.0 + x);
  return x / (s * (1.0 + s)) * std::min(cos_e, 1.0) * std::min(4.0 * cos_r, 1.0);
}

class Hierarchy {
 public:
  explicit Hierarchy(std::vector<Element> elements) : elements_(std::move(elements)) {
    if (elements_.empty()) return;
    nodes_.reserve(elements_.size());  // 2 leaves - 1 nodes, a leaf holding 2 elements or more
    build(0, std::uint32_t(elements_.size()));
  }

  const std::vector<Element>& elements() const { return elements_; }
  const std::vector<Node>& nodes() const { return nodes_; }

  // Each node's area-weighted mean accessibility from `element_access`
  // (indexed as elements()), children before parents (they follow them).
  void node_access(const std::vector<double>& element_access, std::vector<double>& out) const {
    out.assign(nodes_.size(), 1.0);
    for (std::size_t i = nodes_.size(); i-- > 0;) {
      const Node& nd = nodes_[i];
      double sum = 0;
      if (nd.leaf()) {
        for (std::uint32_t e = nd.begin; e < nd.end; ++e) sum += elements_[e].area * element_access[e];
      } else {
        const std::uint32_t a = std::uint32_t(i) + 1, b = nodes_[a].skip;
        sum = nodes_[a].area * out[a] + nodes_[b].area * out[b];
      }
      out[i] = nd.area > 0 ? sum / nd.area : 1.0;
    }
  }

 private:
  // Nodes in depth-first order: an inner node's children are the next node
  // and the node its first child's subtree skips to.
  std::uint32_t build(std::uint32_t begin, std::uint32_t end) {
    const std::uint32_t index = std::uint32_t(nodes_.size());
    nodes_.emplace_back();
    Node nd;
    double area = 0;
    glm::dvec3 sp(0.0), sn(0.0), lo(INFINITY), hi(-INFINITY);
    for (std::uint32_t e = begin; e < end; ++e) {
      const Element& el = elements_[e];
      area += el.area;
      sp += el.area * el.p;
      sn += el.area * el.n;
      lo = glm::min(lo, el.p);
      hi = glm::max(hi, el.p);
    }
    nd.area = area;
    nd.p = area > 0 ? sp / area : 0.5 * (lo + hi);
    const double len = glm::length(sn);
    nd.disc = area > 0 && len >= kMinNormalCoherence * area;
    if (nd.disc) nd.n = sn / len;
    if (end - begin <= kLeafElements) {
      nd.begin = begin;
      nd.end = end;
      for (std::uint32_t e = begin; e < end; ++e)
        nd.radius = std::max(nd.radius, glm::length(elements_[e].p - nd.p) +
                                             std::sqrt(elements_[e].area / std::numbers::pi));
    } else {
      // The median along the longest axis; ties by vertex, so that the
      // split does not depend on the library's nth_element.
      const glm::dvec3 ext = hi - lo;
      const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
      const std::uint32_t mid = begin + (end - begin) / 2;
      std::nth_element(elements_.begin() + begin, elements_.begin() + mid, elements_.begin() + end,
                       [axis](const Element& a, const Element& b) {
                         return a.p[axis] < b.p[axis] || (a.p[axis] == b.p[axis] && a.vertex < b.vertex);
                       });
      const std::uint32_t a = build(begin, mid), b = build(mid, end);
      for (const std::uint32_t c : {a, b})
        nd.radius = std::max(nd.radius, glm::length(nodes_[c].p - nd.p) + nodes_[c].radius);
    }
    nd.skip = std::uint32_t(nodes_.size());
    nodes_[index] = nd;
    return index;
  }

  std::vector<Element> elements_;
  std::vector<Node> nodes_;
};

}  // namespace

std::vector<float> dynamic_ao(const Mesh& mesh, const DynamicAoOptions& o) {
  if (o.passes < 1) throw Error(fmt::format("dynamic AO: passes is {}; must be at least 1", o.passes));
  if (!(o.far >= 1))
    throw Error(fmt::format("dynamic AO: far is {}; must be at least 1 (a nearer cluster would hold the receiver)",
                            o.far));
  if (o.threads < 0) throw Error(fmt::format("dynamic AO: threads is {}; must be at least 0", o.threads));
  const std::size_t V = mesh.vertex_count();
  if (mesh.normals.size() != V)
    throw Error(fmt::format("dynamic AO: {} normals for {} vertices", mesh.normals.size(), V));

  // Element areas: a third of each triangle's, in double.
  std::vector<double> area(V, 0.0);
  for (const glm::uvec3& t : mesh.triangles) {
    const glm::dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
    const double third = glm::length(glm::cross(b - a, c - a)) / 6.0;
    for (int k = 0; k < 3; ++k) area[t[k]] += third;
  }
  // Emitters: a normal and an area. Receivers: a normal.
  std::vector<Element> emitters;
  for (std::size_t v = 0; v < V; ++v)
    if (mesh.normals[v] != glm::vec3(0.0f) && area[v] > 0)
      emitters.push_back({glm::dvec3(mesh.positions[v]), glm::normalize(glm::dvec3(mesh.normals[v])), area[v],
                          std::uint32_t(v)});
  const Hierarchy h(std::move(emitters));
  const std::vector<Element>& el = h.elements();
  const std::vector<Node>& nodes = h.nodes();
  // far^2, compared with d^2 / radius^2; infinite far never takes a node whole.
  const double far2 = o.far * o.far;

  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);

  std::vector<double> access(V, 1.0), next(V, 1.0);
  std::vector<double> element_access(el.size(), 1.0), node_access(nodes.size(), 1.0);
  for (int pass = 0; pass < o.passes; ++pass) {
    const bool weighted = pass > 0;
    if (weighted) {
      for (std::size_t i = 0; i < el.size(); ++i) element_access[i] = access[el[i].vertex];
      h.node_access(element_access, node_access);
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, V), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t v = range.begin(); v < range.end(); ++v) {
        if (mesh.normals[v] == glm::vec3(0.0f)) {
          next[v] = 1.0;
          continue;
        }
        const glm::dvec3 p(mesh.positions[v]), n = glm::normalize(glm::dvec3(mesh.normals[v]));
        double sum = 0;
        for (std::uint32_t i = 0; i < nodes.size();) {
          const Node& nd = nodes[i];
          const glm::dvec3 to = nd.p - p;
          // Wholly behind the receiver's tangent plane: every element's n_r . v <= 0.
          if (glm::dot(n, to) <= -nd.radius) {
            i = nd.skip;
            continue;
          }
          if (nd.leaf()) {  // reached only through an opened parent (or as the root): element by element
            for (std::uint32_t e = nd.begin; e < nd.end; ++e) {
              if (el[e].vertex == v) continue;
              const glm::dvec3 te = el[e].p - p;
              const double d2 = glm::dot(te, te);
              if (!(d2 > 0)) continue;  // coincident: no direction between them
              const double s = shadow(te, d2, n, el[e].n, el[e].area);
              sum += weighted ? s * element_access[e] : s;
            }
            i = nd.skip;
            continue;
          }
          const double d2 = glm::dot(to, to);
          if (nd.disc && d2 > far2 * nd.radius * nd.radius) {  // far enough: one disc
            const double s = shadow(to, d2, n, nd.n, nd.area);
            sum += weighted ? s * node_access[i] : s;
            i = nd.skip;
          } else {
            ++i;  // its first child
          }
        }
        next[v] = std::clamp(1.0 - sum, 0.0, 1.0);
      }
    });
    access.swap(next);
  }
  return std::vector<float>(access.begin(), access.end());
}

}  // namespace prt
