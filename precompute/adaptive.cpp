// Adaptive sample points (docs/PRECOMPUTE.md, "Adaptive sample points").
//
// The irradiance-caching idea (Ward, Rubinstein & Clear 1988; Krivanek et
// al. 2005 for SH gradients) on a mesh's vertices: transfer is computed at
// a subset and interpolated where that is safe. Here:
//  - levels: nested Poisson-disk subsets of the vertices, spacing h0 =
//    diagonal / 16 halving per level until it nears the edge length; the
//    last level is every vertex left. Level 0 is traced whole.
//  - prediction along the surface: each later level's vertices are predicted
//    from the traced vertices of the geodesic Voronoi cell they lie in and
//    the cells next to it, walking mesh edges only and never across a crease
//    (normals more than 30 degrees apart): a depth discontinuity has no edge,
//    a normal discontinuity is not walked. What is interpolated is the
//    residual A(n) - T/rho (the unshadowed transfer of the vertex's own
//    normal minus its transfer, per unit albedo), inverse-square-distance
//    weighted, added back to the vertex's own A(n): the part of transfer that
//    follows the normal exactly is not interpolated at all (D3DX's and
//    Krivanek's gradients serve the same end).
//  - verification: the predictions of each level fall into patches (cells
//    of 16 level spacings); a fraction of every patch (at least 3) is traced
//    as probes, and a patch whose probes' RMS error exceeds TOL is traced
//    whole. The error: band-weighted ((l + 1)^-2, the power of typical
//    lighting per band) RMS of the row difference, relative to the RMS of
//    the level-0 rows. Noisy geometry fails its patches and is traced.
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/precompute.h>

#include "ray_scene.h"
#include "transfer_impl.h"

#include <fmt/core.h>
#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <queue>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

// 0.01 at 1024 samples and fewer, smaller with more: the full run's error
// against the reference at 6 bands is mostly the bands' own (bunny00 under
// sunset.exr: 0.0163, 0.0153, 0.0152 at 256, 1024, 4096 samples), so a TOL
// grown with the noise of fewer samples would pass 1.1x it (1.25x at 256
// samples and 0.03); more samples lower the noise, and TOL with it.
double default_adaptive_tolerance(int samples) { return 0.01 * std::sqrt(1024.0 / std::max(samples, 1024)); }
double max_adaptive_tolerance(int samples) { return 1.5 * default_adaptive_tolerance(samples); }

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
// Edges between normals further apart than 30 degrees are not walked: a
// crease's two sides are not interpolated into each other.
constexpr float kCreaseCos = 0.866f;
constexpr int kMaxSources = 12;       // sources per prediction: the nearest of the cell and its neighbours
constexpr double kPatchSpacings = 16;  // a patch: a cell of this many level spacings
constexpr double kFinestSpacing = 1.5;  // the last Poisson level's spacing, in mean edge lengths
// A prediction whose sources' spread exceeds this many TOL is traced instead.
// Measured (docs/PRECOMPUTE.md): without the rule, homer and mannequin-devil
// reach 1.13-1.14x the full run's error at TOL 0.015 (a few vertices between
// sources that disagree, which no probe of their patch saw); at 1, 1.00x,
// but a smooth 100k-vertex scan traces 82% instead of 51%; at 2 both hold
// (1.004-1.04x, 60%); at 3, homer is back at 1.13x.
constexpr double kSpreadFactor = 2.0;

std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// The mesh's edges, both ways, as CSR (into points' offset and next).
void adjacency(const Mesh& m, detail::AdaptivePoints& g) {
  const std::size_t V = m.vertex_count();
  g.offset.assign(V + 1, 0);
  for (const glm::uvec3& t : m.triangles)
    for (int e = 0; e < 3; ++e) g.offset[t[e] + 1] += 2;
  for (std::size_t v = 0; v < V; ++v) g.offset[v + 1] += g.offset[v];
  g.next.resize(g.offset[V]);
  std::vector<std::uint32_t> at(g.offset.begin(), g.offset.end() - 1);
  for (const glm::uvec3& t : m.triangles)
    for (int e = 0; e < 3; ++e) {
      g.next[at[t[e]]++] = t[(e + 1) % 3];
      g.next[at[t[e]]++] = t[(e + 2) % 3];
    }
  // Sorted and unique per vertex, compacted.
  std::vector<std::uint32_t> count(V, 0);
  tbb::parallel_for(std::size_t(0), V, [&](std::size_t v) {
    auto b = g.next.begin() + g.offset[v], e = g.next.begin() + g.offset[v + 1];
    std::sort(b, e);
    count[v] = std::uint32_t(std::unique(b, e) - b);
  });
  std::size_t out = 0;
  for (std::size_t v = 0; v < V; ++v) {
    const std::uint32_t b = g.offset[v];
    g.offset[v] = std::uint32_t(out);
    for (std::uint32_t i = 0; i < count[v]; ++i) g.next[out++] = g.next[b + i];
  }
  g.offset[V] = std::uint32_t(out);
  g.next.resize(out);
}

// Open-addressing map from a grid cell to the first vertex of its list.
class CellMap {
 public:
  explicit CellMap(std::size_t expected) {
    std::size_t cap = 64;
    while (cap < 2 * expected) cap *= 2;
    keys_.assign(cap, kEmpty);
    values_.assign(cap, kNone);
  }
  std::uint32_t* find_or_add(std::uint64_t key) {
    if (2 * (used_ + 1) > keys_.size()) grow();
    std::size_t i = slot(key);
    if (keys_[i] == kEmpty) {
      keys_[i] = key;
      ++used_;
    }
    return &values_[i];
  }
  std::uint32_t find(std::uint64_t key) const {
    const std::size_t i = slot(key);
    return keys_[i] == kEmpty ? kNone : values_[i];
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t(0);
  std::size_t slot(std::uint64_t key) const {
    const std::size_t mask = keys_.size() - 1;
    std::size_t i = std::size_t(mix(key)) & mask;
    while (keys_[i] != kEmpty && keys_[i] != key) i = (i + 1) & mask;
    return i;
  }
  void grow() {
    std::vector<std::uint64_t> k;
    std::vector<std::uint32_t> v;
    k.swap(keys_);
    v.swap(values_);
    keys_.assign(2 * k.size(), kEmpty);
    values_.assign(2 * k.size(), kNone);
    for (std::size_t i = 0; i < k.size(); ++i)
      if (k[i] != kEmpty) {
        const std::size_t j = slot(k[i]);
        keys_[j] = k[i];
        values_[j] = v[i];
      }
  }
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> values_;
  std::size_t used_ = 0;
};

std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::int64_t kBias = std::int64_t(1) << 20;
  return (std::uint64_t(x + kBias) << 42) | (std::uint64_t(y + kBias) << 21) | std::uint64_t(z + kBias);
}

// Nested Poisson-disk levels of the `active` vertices: level[v] = the first
// level k < count - 1 whose spacing h0 / 2^k admits v (no vertex of level
// <= k nearer than the spacing), walking the vertices in Morton order; the
// last level (count - 1) takes every vertex left.
// Morton codes of the positions in the bounding box, 21 bits per axis.
std::vector<std::uint64_t> morton_codes(const detail::AdaptivePoints& m, glm::vec3 lo, glm::vec3 hi) {
  const glm::vec3 ext = hi - lo + glm::vec3(1e-20f);
  std::vector<std::uint64_t> codes(m.count);
  tbb::parallel_for(std::size_t(0), codes.size(), [&](std::size_t v) {
    const glm::vec3 q = glm::clamp((m.positions[v] - lo) / ext, glm::vec3(0.0f), glm::vec3(1.0f));
    const std::uint32_t x = std::uint32_t(q.x * 2097151.0f), y = std::uint32_t(q.y * 2097151.0f),
                        z = std::uint32_t(q.z * 2097151.0f);
    std::uint64_t code = 0;
    for (int b = 20; b >= 0; --b) code = (code << 3) | ((x >> b & 1u) << 2) | ((y >> b & 1u) << 1) | (z >> b & 1u);
    codes[v] = code;
  });
  return codes;
}

std::vector<std::uint8_t> poisson_levels(const detail::AdaptivePoints& m, const std::vector<std::uint8_t>& active,
                                         const std::vector<std::uint64_t>& morton, double h0, int count) {
  const std::size_t V = m.count;
  std::vector<std::uint8_t> level(V, std::uint8_t(count - 1));
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
  order.reserve(V);
  for (std::uint32_t v = 0; v < V; ++v)
    if (active[v]) order.push_back({morton[v], v});
  tbb::parallel_sort(order.begin(), order.end());
  std::vector<std::uint32_t> chain(V, kNone), accepted;
  for (int k = 0; k + 1 < count; ++k) {
    const double h = h0 / std::pow(2.0, k), h2 = h * h;
    CellMap grid(accepted.size() * 2 + 1024);
    const auto cell = [&](const glm::vec3& p, int d) { return std::int64_t(std::floor(double(p[d]) / h)); };
    const auto insert = [&](std::uint32_t v) {
      const glm::vec3 p = m.positions[v];
      std::uint32_t* head = grid.find_or_add(cell_key(cell(p, 0), cell(p, 1), cell(p, 2)));
      chain[v] = *head;
      *head = v;
    };
    for (std::uint32_t a : accepted) insert(a);
    for (const auto& [code, v] : order) {
      if (level[v] < k) continue;
      const glm::vec3 p = m.positions[v];
      const std::int64_t cx = cell(p, 0), cy = cell(p, 1), cz = cell(p, 2);
      bool near = false;
      const auto probe = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
        for (std::uint32_t a = grid.find(cell_key(x, y, z)); a != kNone && !near; a = chain[a]) {
          const glm::dvec3 d = glm::dvec3(m.positions[a]) - glm::dvec3(p);
          near = glm::dot(d, d) < h2;
        }
      };
      probe(cx, cy, cz);  // its own cell first: most vertices stop here
      for (int dx = -1; dx <= 1 && !near; ++dx)
        for (int dy = -1; dy <= 1 && !near; ++dy)
          for (int dz = -1; dz <= 1 && !near; ++dz)
            if (dx || dy || dz) probe(cx + dx, cy + dy, cz + dz);
      if (near) continue;
      level[v] = std::uint8_t(k);
      accepted.push_back(v);
      insert(v);
    }
  }
  return level;
}

// Geodesic Voronoi cells of the traced vertices, walking edges that are not
// creases: each vertex's site (nearest traced vertex; kNone where none is
// reachable) and each site's neighbouring sites (cells sharing an edge), CSR
// over vertex ids. Kept across levels: the traced set only grows, so each
// update is a Dijkstra from the new sites alone, relaxing the vertices they
// are nearer to (distances only fall).
bool walkable(const detail::AdaptivePoints& m, std::uint32_t a, std::uint32_t b) {
  return glm::dot(m.normals[a], m.normals[b]) >= kCreaseCos;
}

class Cells {
 public:
  explicit Cells(std::size_t V) : site(V, kNone), dist_(V, std::numeric_limits<float>::infinity()) {}

  std::vector<std::uint32_t> site;
  std::vector<std::uint32_t> offset, next;

  // Adds `sites` (vertices now traced) and rebuilds the neighbour lists.
  void add(const detail::AdaptivePoints& g, std::vector<std::uint32_t> sites) {
    const detail::AdaptivePoints& m = g;
    using Item = std::pair<float, std::uint32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
    std::sort(sites.begin(), sites.end());
    for (std::uint32_t v : sites) {
      site[v] = v;
      dist_[v] = 0;
      q.push({0.0f, v});
    }
    while (!q.empty()) {
      const auto [d, u] = q.top();
      q.pop();
      if (d > dist_[u]) continue;
      for (std::uint32_t i = g.offset[u]; i < g.offset[u + 1]; ++i) {
        const std::uint32_t w = g.next[i];
        if (!walkable(m, u, w)) continue;
        const float nd = d + glm::length(m.positions[w] - m.positions[u]);
        if (nd < dist_[w]) {
          dist_[w] = nd;
          site[w] = site[u];
          q.push({nd, w});
        }
      }
    }
    // Neighbouring cells: a key (site << 32 | other site) per walkable edge
    // across a cell boundary, deduplicated per vertex first, then sorted.
    const std::size_t V = site.size();
    std::vector<std::vector<std::uint64_t>> parts(std::size_t(std::max(1, tbb::this_task_arena::max_concurrency())) * 4);
    const std::size_t chunk = (V + parts.size() - 1) / parts.size();
    tbb::parallel_for(std::size_t(0), parts.size(), [&](std::size_t part) {
      std::vector<std::uint64_t>& out = parts[part];
      std::uint32_t seen[16];
      for (std::size_t u = part * chunk; u < std::min(V, (part + 1) * chunk); ++u) {
        const std::uint32_t su = site[u];
        if (su == kNone) continue;
        int n = 0;
        for (std::uint32_t i = g.offset[u]; i < g.offset[u + 1]; ++i) {
          const std::uint32_t w = g.next[i], sw = site[w];
          if (sw == kNone || sw == su || !walkable(m, std::uint32_t(u), w)) continue;
          if (std::find(seen, seen + n, sw) != seen + n) continue;
          if (n < 16) seen[n++] = sw;
          out.push_back((std::uint64_t(su) << 32) | sw);
        }
      }
    });
    std::vector<std::uint64_t> keys;
    std::size_t total = 0;
    for (const auto& p : parts) total += p.size();
    keys.reserve(total);
    for (auto& p : parts) keys.insert(keys.end(), p.begin(), p.end());
    tbb::parallel_sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    offset.assign(V + 1, 0);
    for (std::uint64_t k : keys) ++offset[(k >> 32) + 1];
    for (std::size_t v = 0; v < V; ++v) offset[v + 1] += offset[v];
    next.resize(keys.size());
    for (std::size_t i = 0; i < keys.size(); ++i) next[i] = std::uint32_t(keys[i]);  // sorted by site: CSR order
  }

 private:
  std::vector<float> dist_;
};

// Some of the points (ids into them) as a Source.
detail::VertexPoints subset(const detail::AdaptivePoints& p, const std::vector<std::uint32_t>& ids) {
  detail::VertexPoints points(p.positions, p.normals, p.albedo.empty() ? nullptr : p.albedo.data(), ids);
  points.hit_points = p.hit_points;
  return points;
}

// Interpolation weights of the vertices not traced: for each, up to
// kMaxSources traced vertices and normalised weights, in src/w from first[v].
struct Weights {
  std::vector<std::uint32_t> first;  // per vertex: index into src and w, or kNone (traced)
  std::vector<std::uint8_t> count;
  std::vector<std::uint32_t> src;
  std::vector<float> w;
};

using Sources = std::vector<std::pair<std::uint32_t, float>>;  // (vertex, distance or weight)

// The Poisson levels of the choice: each vertex's level, the first level's
// spacing h0 (halved at each level) and the number of levels.
struct Levels {
  std::vector<std::uint8_t> level;
  double h0 = 0;
  int count = 0;
};

// One level's predictions of its n candidates: stride floats each, and the
// weights that made them (wn[i] of them; 0: no prediction, traced).
struct Predictions {
  Predictions(std::size_t n, std::size_t stride)
      : pred(n * stride), wsrc(n * kMaxSources), ww(n * kMaxSources), wn(n, 0) {}
  std::vector<float> pred;
  std::vector<std::uint32_t> wsrc;
  std::vector<float> ww;
  std::vector<std::uint8_t> wn;
};

// One level's patches: (patch key, candidate index) sorted by patch and,
// within a patch, in a seeded order; each patch's [begin, end) in keyed; and
// the candidates traced first (those without a prediction, each patch's probes).
struct Patches {
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed;
  std::vector<std::pair<std::size_t, std::size_t>> ranges;
  std::vector<std::uint32_t> batch;
};

class Adaptive {
 public:
  Adaptive(const Mesh& mesh, const detail::AdaptivePoints& points, const TransferOptions& o, const AdaptiveOptions& a,
           const Progress& progress, AdaptiveReport& report)
      : mesh_(mesh), pts_(points), pos_(points.positions), nrm_(points.normals), o_(o), a_(a), progress_(progress),
        report_(report), V_(points.count), scene_(mesh) {}

  Transfer run();

 private:
  using Clock = std::chrono::steady_clock;
  static double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

  // run's phases: the options' sizes and the tolerance; the arrays and the
  // Poisson levels; level 0 traced (the reference norm); each later level
  // predicted, probed per patch and traced where a patch fails; the
  // verification; the shadowed result.
  void prepare();
  Levels select_levels();
  void timed_trace(std::vector<std::uint32_t> vs);  // trace, timed, with the progress callback
  void trace_level0(const std::vector<std::uint8_t>& level);
  void choose_level(int k, const Levels& levels, Cells& cells);
  void predict_candidates(const std::vector<std::uint32_t>& cand, const Cells& cells, Predictions& pr) const;
  Patches make_patches(int k, double h0, const std::vector<std::uint32_t>& cand, const std::vector<std::uint8_t>& wn);
  // The not yet traced members of the patches whose probes' RMS error passes TOL.
  std::vector<std::uint32_t> failing_patches(const std::vector<std::uint32_t>& cand, const Predictions& pr,
                                             const Patches& pt);
  void keep_predictions(const std::vector<std::uint32_t>& cand, const Predictions& pr);
  void verify();
  Transfer finish_shadowed();

  // Traces `vs` with the selection options into rows_ (ao_, bent_, glossy_
  // on rank 0), their residuals into resid_; marks them traced.
  void trace(std::vector<std::uint32_t> vs);
  void residual_of(std::uint32_t v);
  // The prediction of vertex v from `sources` (vertex, distance): stride_
  // floats into out; the normalised weights into ws. Returns the sources'
  // spread (their residuals' weighted RMS about the prediction, as error()).
  double predict(std::uint32_t v, Sources& sources, float* out, Sources& ws) const;
  double error(const float* predicted, const float* traced) const;
  // Every vertex's `channels` x nc_ values: the traced vertices' from `rows`
  // (V rows), the others interpolated with weights_, per unit albedo and,
  // about_normal, as a residual about the vertex's own A(n).
  void fill(std::vector<float>& rows, int channels, bool about_normal) const;
  // A(n) of every source of an interpolated vertex, once (fill reads it per bounce): source_an_ rows, source_slot_[v].
  void cache_source_normals();
  // The same for glossy matrices (gstride floats per vertex): residuals about
  // the hemisphere product matrix.
  void fill_glossy(std::vector<float>& g, std::size_t gstride, bool symmetric, int channels) const;
  void fill_ao_bent(std::vector<float>& ao, std::vector<glm::vec3>& bent) const;
  Transfer finish_interreflected(const std::vector<std::uint32_t>& traced_list);
  // Marks the interpolated vertices (an interpolated vertex all of whose
  // sources are analytic is analytic too) and compacts the V rows of t.
  void finish(Transfer& t, std::vector<std::uint8_t> analytic) const;

  const Mesh& mesh_;  // what rays hit
  const detail::AdaptivePoints& pts_;
  const glm::vec3 *pos_, *nrm_;  // the points'
  const TransferOptions& o_;
  const AdaptiveOptions& a_;
  const Progress& progress_;
  AdaptiveReport& report_;
  const std::size_t V_;
  const detail::RayScene scene_;
  TransferOptions so_;  // the selection pass's options
  bool root_ = true;
  int nc_ = 0, channels_ = 1;
  std::size_t stride_ = 0, gstride_ = 0;
  std::vector<glm::vec3> albedo_;    // per vertex (vertex colours clamped, or the options' albedo)
  std::vector<double> band_weight_;  // per coefficient: (l + 1)^-2
  std::vector<std::uint8_t> active_, traced_, analytic_;
  std::vector<float> rows_, resid_;  // V x stride: rows (traced or predicted), residuals of the traced
  std::vector<float> ao_, glossy_;   // rank 0
  std::vector<glm::vec3> bent_;      // rank 0
  Weights weights_;
  std::vector<std::uint32_t> source_slot_;  // per vertex: its row in source_an_, or kNone
  std::vector<float> source_an_;            // nc_ per source
  std::vector<std::uint64_t> morton_;  // per vertex
  std::vector<std::uint32_t> fresh_;   // traced since the Voronoi cells were last updated
  double ref_norm_ = 1;
  double eps_ = 0;  // added to squared distances: coincident vertices divide by no zero
  std::size_t done_ = 0;  // vertex traces so far (progress)
};

void Adaptive::residual_of(std::uint32_t v) {
  thread_local std::vector<double> an;
  an.assign(std::size_t(nc_), 0.0);
  analytic_transfer(o_.bands, 1, nrm_[v], glm::vec3(1.0f), an.data());
  const glm::vec3 rho = albedo_[v];
  int best = 0;
  for (int c = 1; c < channels_; ++c)
    if (rho[c] > rho[best]) best = c;
  for (int c = 0; c < channels_; ++c) {
    const int from = rho[c] > 0.0f ? c : best;  // a black channel: the geometry of the brightest
    const float* row = rows_.data() + std::size_t(v) * stride_ + std::size_t(from) * nc_;
    float* r = resid_.data() + std::size_t(v) * stride_ + std::size_t(c) * nc_;
    const double inv = rho[from] > 0.0f ? 1.0 / rho[from] : 0.0;
    for (int k = 0; k < nc_; ++k) r[k] = inv > 0 ? float(an[std::size_t(k)] - inv * row[k]) : 0.0f;
  }
}

double Adaptive::predict(std::uint32_t v, Sources& sources, float* out, Sources& ws) const {
  const auto nearer = [](const auto& x, const auto& y) {
    return x.second < y.second || (x.second == y.second && x.first < y.first);
  };
  if (sources.size() > std::size_t(kMaxSources)) {
    std::nth_element(sources.begin(), sources.begin() + kMaxSources, sources.end(), nearer);
    sources.resize(kMaxSources);
  }
  std::sort(sources.begin(), sources.end(), nearer);
  double wsum = 0;
  ws.clear();
  for (const auto& [u, d] : sources) {
    const double w = 1.0 / (double(d) * d + eps_);
    ws.push_back({u, float(w)});
    wsum += w;
  }
  for (auto& e : ws) e.second = float(e.second / wsum);
  thread_local std::vector<double> an, acc;
  an.assign(std::size_t(nc_), 0.0);
  acc.assign(stride_, 0.0);
  analytic_transfer(o_.bands, 1, nrm_[v], glm::vec3(1.0f), an.data());
  for (const auto& [u, w] : ws)
    for (std::size_t k = 0; k < stride_; ++k) acc[k] += double(w) * resid_[std::size_t(u) * stride_ + k];
  for (int c = 0; c < channels_; ++c)
    for (int k = 0; k < nc_; ++k)
      out[std::size_t(c) * nc_ + k] = float(albedo_[v][c] * (an[std::size_t(k)] - acc[std::size_t(c) * nc_ + k]));
  // How much the sources disagree: the weighted RMS of their residuals about
  // the prediction's, in the metric of error().
  double spread2 = 0;
  for (const auto& [u, w] : ws)
    for (int c = 0; c < channels_; ++c)
      for (int k = 0; k < nc_; ++k) {
        const std::size_t q = std::size_t(c) * nc_ + k;
        const double d = albedo_[v][c] * (double(resid_[std::size_t(u) * stride_ + q]) - acc[q]);
        spread2 += double(w) * band_weight_[std::size_t(k)] * d * d;
      }
  return std::sqrt(spread2 / channels_) / ref_norm_;
}

double Adaptive::error(const float* p, const float* t) const {
  return std::sqrt(detail::weighted_square(p, t, band_weight_, channels_)) / ref_norm_;
}

void Adaptive::trace(std::vector<std::uint32_t> vs) {
  if (vs.empty()) return;
  // Morton order: each thread's run of points lies close together, so the BVH's nodes stay in cache (a
  // sparse subset in index order traces 1.4x slower per point on a 1M-vertex scan).
  tbb::parallel_sort(vs.begin(), vs.end(), [&](std::uint32_t a, std::uint32_t b) {
    return morton_[a] != morton_[b] ? morton_[a] < morton_[b] : a < b;
  });
  const detail::VertexPoints points = subset(pts_, vs);
  const std::vector<glm::vec3>& nrm = points.normals;
  detail::Source src = points.source(&scene_);
  std::vector<std::uint8_t> analytic;
  src.analytic_out = &analytic;
  const std::size_t before = done_;
  const Progress sub = progress_ ? Progress([&](std::size_t d, std::size_t, const char*) {
    return progress_(std::min(V_, before + d), V_, "rays (adaptive)");
  })
                                 : Progress();
  const Transfer t = detail::compute_at(mesh_, src, so_, sub, true);
  tbb::parallel_for(std::size_t(0), vs.size(), [&](std::size_t i) {
    const std::uint32_t v = vs[i];
    std::copy_n(t.coeffs.begin() + std::ptrdiff_t(i * stride_), stride_, rows_.begin() + std::ptrdiff_t(std::size_t(v) * stride_));
    traced_[v] = 1;
    analytic_[v] = analytic[i];
    residual_of(v);
    if (!root_) return;
    ao_[v] = t.ao[i];
    bent_[v] = t.bent_normals[i];
    if (!gstride_) return;
    float* g = glossy_.data() + std::size_t(v) * gstride_;
    if (analytic[i]) {  // not written by the pass: the hemisphere's own matrix
      const std::vector<double> H = glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm[i])), o_.bands);
      std::size_t q = 0;
      for (int p = 0; p < nc_; ++p)
        for (int r = p; r < nc_; ++r) g[q++] = float(H[std::size_t(p) * nc_ + r]);
    } else {
      std::copy_n(t.glossy_matrices.begin() + std::ptrdiff_t(i * gstride_), gstride_, g);
    }
  });
  report_.traces += vs.size();
  done_ += vs.size();
  fresh_.insert(fresh_.end(), vs.begin(), vs.end());
}

void Adaptive::cache_source_normals() {
  source_slot_.assign(V_, kNone);
  std::uint32_t n = 0;
  for (std::uint32_t u : weights_.src)
    if (source_slot_[u] == kNone) source_slot_[u] = n++;
  source_an_.assign(std::size_t(n) * nc_, 0.0f);
  tbb::parallel_for(std::size_t(0), V_, [&](std::size_t u) {
    if (source_slot_[u] == kNone) return;
    std::vector<double> an(static_cast<std::size_t>(nc_));
    analytic_transfer(o_.bands, 1, nrm_[u], glm::vec3(1.0f), an.data());
    std::copy(an.begin(), an.end(), source_an_.begin() + std::ptrdiff_t(std::size_t(source_slot_[u]) * nc_));
  });
}

void Adaptive::fill(std::vector<float>& rows, int channels, bool about_normal) const {
  const std::size_t stride = std::size_t(channels) * nc_;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, V_, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<double> an(static_cast<std::size_t>(nc_)), acc(stride);
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      const std::uint32_t f = weights_.first[v];
      if (f == kNone) continue;
      std::fill(acc.begin(), acc.end(), 0.0);
      for (std::uint32_t j = f; j < f + weights_.count[v]; ++j) {
        const std::uint32_t u = weights_.src[j];
        const float* un = source_an_.data() + std::size_t(source_slot_[u]) * nc_;
        const glm::vec3 rho = albedo_[u];
        int best = 0;
        for (int c = 1; c < channels; ++c)
          if (rho[c] > rho[best]) best = c;
        for (int c = 0; c < channels; ++c) {
          const int from = rho[c] > 0.0f ? c : best;
          if (!(rho[from] > 0.0f)) continue;
          const double inv = 1.0 / rho[from], w = weights_.w[j];
          const float* row = rows.data() + u * stride + std::size_t(from) * nc_;
          for (int k = 0; k < nc_; ++k)
            acc[std::size_t(c) * nc_ + k] += w * ((about_normal ? double(un[k]) : 0.0) - inv * row[k]);
        }
      }
      if (about_normal) analytic_transfer(o_.bands, 1, nrm_[v], glm::vec3(1.0f), an.data());
      for (int c = 0; c < channels; ++c)
        for (int k = 0; k < nc_; ++k)
          rows[v * stride + std::size_t(c) * nc_ + k] =
              float(albedo_[v][c] * ((about_normal ? an[std::size_t(k)] : 0.0) - acc[std::size_t(c) * nc_ + k]));
    }
  });
}

void Adaptive::fill_glossy(std::vector<float>& g, std::size_t gstride, bool symmetric, int channels) const {
  // Residuals H(n_u) - M_u of the traced sources, then H(n_v) - sum w R_u.
  std::vector<float> resid(V_ * gstride, 0.0f);
  const auto unpack = [&](const std::vector<double>& H, float* out) {  // H in the stored layout, per channel
    std::size_t q = 0;
    for (int c = 0; c < channels; ++c)
      for (int p = 0; p < nc_; ++p)
        for (int r = symmetric ? p : 0; r < nc_; ++r) out[q++] = float(H[std::size_t(p) * nc_ + r]);
  };
  tbb::parallel_for(std::size_t(0), V_, [&](std::size_t u) {
    if (!traced_[u] || !active_[u]) return;
    std::vector<float> h(gstride);
    unpack(glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm_[u])), o_.bands), h.data());
    for (std::size_t q = 0; q < gstride; ++q) resid[u * gstride + q] = h[q] - g[u * gstride + q];
  });
  tbb::parallel_for(std::size_t(0), V_, [&](std::size_t v) {
    const std::uint32_t f = weights_.first[v];
    if (f == kNone) return;
    std::vector<float> h(gstride);
    unpack(glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm_[v])), o_.bands), h.data());
    std::vector<double> acc(gstride, 0.0);
    for (std::uint32_t j = f; j < f + weights_.count[v]; ++j)
      for (std::size_t q = 0; q < gstride; ++q) acc[q] += double(weights_.w[j]) * resid[weights_.src[j] * gstride + q];
    for (std::size_t q = 0; q < gstride; ++q) g[v * gstride + q] = float(h[q] - acc[q]);
  });
}

void Adaptive::fill_ao_bent(std::vector<float>& ao, std::vector<glm::vec3>& bent) const {
  tbb::parallel_for(std::size_t(0), V_, [&](std::size_t v) {
    const std::uint32_t f = weights_.first[v];
    if (f == kNone) return;
    double a = 0;
    glm::dvec3 b(nrm_[v]);
    for (std::uint32_t j = f; j < f + weights_.count[v]; ++j) {
      const std::uint32_t u = weights_.src[j];
      a += double(weights_.w[j]) * ao[u];
      b += double(weights_.w[j]) * (glm::dvec3(bent[u]) - glm::dvec3(nrm_[u]));
    }
    ao[v] = float(std::clamp(a, 0.0, 1.0));
    const double len = glm::length(b);
    bent[v] = len > 0 ? glm::vec3(b / len) : nrm_[v];
  });
}

void Adaptive::prepare() {
  nc_ = o_.bands * o_.bands;
  const bool grey = pts_.albedo.empty() && o_.albedo.x == o_.albedo.y && o_.albedo.y == o_.albedo.z;
  channels_ = grey ? 1 : 3;
  stride_ = std::size_t(channels_) * nc_;
  so_ = o_;
  so_.memory_report = nullptr;
  if (o_.mode == TransferMode::Interreflected) {  // chosen on the shadowed transfer; the bounces are traced once the choice is made
    so_.mode = TransferMode::Shadowed;
    so_.glossy = false;
  }
  gstride_ = so_.glossy ? std::size_t(nc_) * (nc_ + 1) / 2 : 0;
  albedo_.resize(V_);
  for (std::size_t v = 0; v < V_; ++v)
    for (int c = 0; c < 3; ++c)
      albedo_[v][c] = pts_.albedo.empty() ? o_.albedo[c] : pts_.albedo[v][c];
  band_weight_ = detail::band_weights(o_.bands);
  report_.tolerance = a_.tolerance > 0 ? a_.tolerance : default_adaptive_tolerance(o_.samples);
  report_.vertices = V_;
}

Levels Adaptive::select_levels() {
  const auto t_select = Clock::now();
  active_.assign(V_, 0);
  traced_.assign(V_, 0);
  analytic_.assign(V_, 0);
  rows_.assign(V_ * stride_, 0.0f);
  resid_.assign(V_ * stride_, 0.0f);
  if (root_) {
    ao_.assign(V_, 0.0f);
    bent_.assign(nrm_, nrm_ + V_);
    glossy_.assign(V_ * gstride_, 0.0f);
  }
  weights_.first.assign(V_, kNone);
  weights_.count.assign(V_, 0);
  for (std::size_t v = 0; v < V_; ++v) {
    const glm::vec3 n = nrm_[v];
    active_[v] = glm::dot(n, n) > 0.0f;
    if (!active_[v]) traced_[v] = 1;  // no normal: no transfer (zero, as compute_transfer), nothing to trace
  }
  // Level spacings from the bounding-box diagonal down to about the neighbours' spacing.
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (std::size_t v = 0; v < V_; ++v) {
    lo = glm::min(lo, pos_[v]);
    hi = glm::max(hi, pos_[v]);
  }
  if (V_ == 0) lo = hi = glm::vec3(0.0f);
  Levels levels;
  const double edge = pts_.spacing;
  const double diag = glm::length(glm::dvec3(hi) - glm::dvec3(lo));
  levels.h0 = diag / 16;
  eps_ = 1e-12 * diag * diag;
  int count = 1;
  while (levels.h0 / std::pow(2.0, count - 1) > kFinestSpacing * edge && count < 12) ++count;
  ++count;  // the last level: every vertex left
  report_.levels = count;
  levels.count = count;
  morton_ = morton_codes(pts_, lo, hi);
  levels.level = poisson_levels(pts_, active_, morton_, levels.h0, count);
  report_.seconds_selecting += since(t_select);
  return levels;
}

void Adaptive::timed_trace(std::vector<std::uint32_t> vs) {
  const auto t0 = Clock::now();
  trace(std::move(vs));
  report_.seconds_tracing += since(t0);
  if (progress_ && !progress_(std::min(done_, V_), V_, "rays (adaptive)")) throw Error("cancelled");
}

void Adaptive::trace_level0(const std::vector<std::uint8_t>& level) {
  std::vector<std::uint32_t> l0;
  for (std::uint32_t v = 0; v < V_; ++v)
    if (active_[v] && level[v] == 0) l0.push_back(v);
  timed_trace(l0);
  double n2 = 0;
  for (std::uint32_t v : l0) n2 += detail::weighted_square(rows_.data() + std::size_t(v) * stride_, nullptr, band_weight_, channels_);
  ref_norm_ = l0.empty() || n2 <= 0 ? 1.0 : std::sqrt(n2 / double(l0.size()));
}

void Adaptive::predict_candidates(const std::vector<std::uint32_t>& cand, const Cells& cells, Predictions& pr) const {
  const double tol = report_.tolerance;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cand.size(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
    Sources src, ws;
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const std::uint32_t v = cand[i], site = cells.site[v];
      if (site == kNone) continue;  // no traced vertex reachable along the surface: traced
      src.clear();
      const glm::vec3 p = pos_[v];
      src.push_back({site, glm::length(pos_[site] - p)});
      for (std::uint32_t j = cells.offset[site]; j < cells.offset[site + 1]; ++j)
        src.push_back({cells.next[j], glm::length(pos_[cells.next[j]] - p)});
      const double spread = predict(v, src, pr.pred.data() + i * stride_, ws);
      // Sources that disagree by more than TOL: the vertex lies where transfer changes faster than the
      // level's spacing resolves (a shadow edge, a fold); no probe of its patch need see that. Traced.
      if (spread > kSpreadFactor * tol) continue;
      pr.wn[i] = std::uint8_t(ws.size());
      for (std::size_t j = 0; j < ws.size(); ++j) {
        pr.wsrc[i * kMaxSources + j] = ws[j].first;
        pr.ww[i * kMaxSources + j] = ws[j].second;
      }
    }
  });
}

Patches Adaptive::make_patches(int k, double h0, const std::vector<std::uint32_t>& cand,
                               const std::vector<std::uint8_t>& wn) {
  Patches pt;
  const double side = kPatchSpacings * h0 / std::pow(2.0, k);
  for (std::uint32_t i = 0; i < cand.size(); ++i) {
    if (wn[i] == 0) {
      pt.batch.push_back(cand[i]);
      continue;
    }
    const glm::vec3 p = pos_[cand[i]];
    pt.keyed.push_back({cell_key(std::int64_t(std::floor(p.x / side)), std::int64_t(std::floor(p.y / side)),
                                 std::int64_t(std::floor(p.z / side))),
                        i});
  }
  const std::uint64_t salt = mix(a_.seed * 0x51ed27u + std::uint64_t(k));
  tbb::parallel_sort(pt.keyed.begin(), pt.keyed.end(), [&](const auto& x, const auto& y) {
    if (x.first != y.first) return x.first < y.first;
    return mix(cand[x.second] ^ salt) < mix(cand[y.second] ^ salt);
  });
  const auto& keyed = pt.keyed;
  for (std::size_t i = 0; i < keyed.size();) {
    std::size_t j = i;
    while (j < keyed.size() && keyed[j].first == keyed[i].first) ++j;
    pt.ranges.push_back({i, j});
    const std::size_t probes = std::min(j - i, std::max<std::size_t>(std::size_t(a_.min_probes),
                                                                     std::size_t(std::ceil(a_.probe_fraction * double(j - i)))));
    for (std::size_t q = i; q < i + probes; ++q) pt.batch.push_back(cand[keyed[q].second]);
    report_.probes += probes;
    i = j;
  }
  report_.patches += pt.ranges.size();
  return pt;
}

std::vector<std::uint32_t> Adaptive::failing_patches(const std::vector<std::uint32_t>& cand, const Predictions& pr,
                                                      const Patches& pt) {
  std::vector<std::uint32_t> failing;
  for (const auto& [b, e] : pt.ranges) {
    double e2 = 0;
    std::size_t n = 0;
    for (std::size_t q = b; q < e; ++q) {
      const std::uint32_t i = pt.keyed[q].second, v = cand[i];
      if (!traced_[v]) break;  // the probes come first
      const double err = error(pr.pred.data() + std::size_t(i) * stride_, rows_.data() + std::size_t(v) * stride_);
      e2 += err * err;
      ++n;
    }
    if (n > 0 && std::sqrt(e2 / double(n)) > report_.tolerance) {
      ++report_.failed_patches;
      for (std::size_t q = b; q < e; ++q)
        if (!traced_[cand[pt.keyed[q].second]]) failing.push_back(cand[pt.keyed[q].second]);
    }
  }
  return failing;
}

void Adaptive::keep_predictions(const std::vector<std::uint32_t>& cand, const Predictions& pr) {
  for (std::uint32_t i = 0; i < cand.size(); ++i) {
    const std::uint32_t v = cand[i];
    if (traced_[v]) continue;
    std::copy_n(pr.pred.begin() + std::ptrdiff_t(std::size_t(i) * stride_), stride_, rows_.begin() + std::ptrdiff_t(std::size_t(v) * stride_));
    weights_.first[v] = std::uint32_t(weights_.src.size());
    weights_.count[v] = pr.wn[i];
    weights_.src.insert(weights_.src.end(), pr.wsrc.begin() + std::ptrdiff_t(i * kMaxSources),
                        pr.wsrc.begin() + std::ptrdiff_t(i * kMaxSources + pr.wn[i]));
    weights_.w.insert(weights_.w.end(), pr.ww.begin() + std::ptrdiff_t(i * kMaxSources),
                      pr.ww.begin() + std::ptrdiff_t(i * kMaxSources + pr.wn[i]));
  }
}

void Adaptive::choose_level(int k, const Levels& levels, Cells& cells) {
  const auto t_pred = Clock::now();
  std::vector<std::uint32_t> cand;
  for (std::uint32_t v = 0; v < V_; ++v)
    if (active_[v] && levels.level[v] == k) cand.push_back(v);
  if (cand.empty()) return;
  cells.add(pts_, std::move(fresh_));
  fresh_.clear();
  Predictions pr(cand.size(), stride_);
  predict_candidates(cand, cells, pr);
  const Patches pt = make_patches(k, levels.h0, cand, pr.wn);
  report_.seconds_predicting += since(t_pred);
  timed_trace(pt.batch);
  timed_trace(failing_patches(cand, pr, pt));
  keep_predictions(cand, pr);
}

void Adaptive::verify() {
  const double tol = report_.tolerance;
  std::vector<std::uint32_t> check;
  const double cut = a_.verify_fraction * 18446744073709551615.0;
  for (std::uint32_t v = 0; v < V_; ++v)
    if (weights_.first[v] != kNone && (a_.verify_fraction >= 1 || double(mix(v ^ mix(a_.seed + 0x7e51f1u))) < cut))
      check.push_back(v);
  std::vector<float> before(check.size() * stride_);
  for (std::size_t i = 0; i < check.size(); ++i)
    std::copy_n(rows_.begin() + std::ptrdiff_t(std::size_t(check[i]) * stride_), stride_, before.begin() + std::ptrdiff_t(i * stride_));
  timed_trace(check);
  std::vector<double> errs(check.size());
  double e2 = 0;
  for (std::size_t i = 0; i < check.size(); ++i) {
    errs[i] = error(before.data() + i * stride_, rows_.data() + std::size_t(check[i]) * stride_);
    e2 += errs[i] * errs[i];
    weights_.first[check[i]] = kNone;
    weights_.count[check[i]] = 0;
  }
  report_.verified = check.size();
  if (!check.empty()) {
    report_.verified_rms = std::sqrt(e2 / double(check.size()));
    report_.verified_over = std::size_t(std::count_if(errs.begin(), errs.end(), [&](double e) { return e > tol; }));
    std::sort(errs.begin(), errs.end());
    report_.verified_max = errs.back();
    report_.verified_p95 = errs[std::min(errs.size() - 1, std::size_t(std::ceil(0.95 * double(errs.size()))) - 1)];
  }
}

Transfer Adaptive::finish_shadowed() {
  Transfer t;
  t.bands = o_.bands;
  t.channels = channels_;
  t.mode = o_.mode;
  t.samples = o_.mode == TransferMode::Unshadowed ? 0 : o_.samples;
  t.albedo = o_.albedo;
  t.vertex_colors = o_.vertex_colors;
  t.seed = o_.seed;
  t.vertices = V_;
  if (!root_) return Transfer{};
  t.coeffs = std::move(rows_);
  t.ao = std::move(ao_);
  t.bent_normals = std::move(bent_);
  fill_ao_bent(t.ao, t.bent_normals);
  t.glossy = so_.glossy;
  if (t.glossy) {
    fill_glossy(glossy_, gstride_, true, 1);
    t.glossy_matrices = std::move(glossy_);
  }
  finish(t, analytic_);
  return t;
}

Transfer Adaptive::run() {
  const Communicator& comm = o_.comm ? *o_.comm : single_process();
  root_ = comm.rank() == 0;
  prepare();
  const Levels levels = select_levels();
  trace_level0(levels.level);
  Cells cells(V_);
  for (int k = 1; k < levels.count; ++k) choose_level(k, levels, cells);

  // Verification: a seeded fraction of the interpolated vertices traced; their
  // predictions compared, then replaced by the traced rows.
  if (a_.verify_fraction > 0) verify();

  std::vector<std::uint32_t> traced_list;
  for (std::uint32_t v = 0; v < V_; ++v)
    if (active_[v] && weights_.first[v] == kNone) traced_list.push_back(v);
  report_.traced = traced_list.size();
  report_.interpolated = 0;
  for (std::size_t v = 0; v < V_; ++v) report_.interpolated += weights_.first[v] != kNone;

  if (o_.mode == TransferMode::Interreflected) return finish_interreflected(traced_list);
  return finish_shadowed();  // the selection pass's rows are the result
}

void Adaptive::finish(Transfer& t, std::vector<std::uint8_t> analytic) const {
  t.interpolated.assign(V_, 0);
  for (std::size_t v = 0; v < V_; ++v) {
    const std::uint32_t f = weights_.first[v];
    if (f == kNone) continue;
    t.interpolated[v] = 1;
    // Every source unoccluded: the residual is zero, the row its own A(n): analytic.
    bool all = true;
    for (std::uint32_t j = f; j < f + weights_.count[v]; ++j) all = all && analytic[weights_.src[j]];
    analytic[v] = all;
  }
  if (report_.interpolated == 0) t.interpolated.clear();
  compact_transfer(t, analytic);
}

Transfer Adaptive::finish_interreflected(const std::vector<std::uint32_t>& traced_list) {
  // The chosen vertices traced again with the bounces (and glossy), each
  // bounce gathering from every vertex: the traced ones' rows, the others
  // interpolated with the weights of the choice.
  const std::size_t P = traced_list.size();
  const detail::VertexPoints points = subset(pts_, traced_list);
  const std::vector<glm::vec3>& nrm = points.normals;
  cache_source_normals();
  const auto scatter = [&](const auto& point_rows, auto& vertex_rows, std::size_t stride, auto zero) {
    vertex_rows.assign(V_ * stride, zero);
    for (std::size_t i = 0; i < P; ++i)
      std::copy_n(point_rows.begin() + std::ptrdiff_t(i * stride), stride,
                  vertex_rows.begin() + std::ptrdiff_t(std::size_t(traced_list[i]) * stride));
  };
  const std::function<void(const std::vector<float>&, std::vector<float>&, bool)> expand =
      [&](const std::vector<float>& point_rows, std::vector<float>& vertex_rows, bool transfer) {
        scatter(point_rows, vertex_rows, stride_, 0.0f);
        fill(vertex_rows, channels_, transfer);  // bounce light alone has no A(n) to interpolate about
      };
  detail::Source src = points.source(&scene_);
  src.expand = &expand;
  std::vector<std::uint8_t> analytic_points;
  src.analytic_out = &analytic_points;
  const std::size_t before = done_;
  const Progress sub = progress_ ? Progress([&](std::size_t d, std::size_t total, const char* phase) {
    return progress_(std::string_view(phase) == "rays" ? std::min(V_, before + d) : d,
                     std::string_view(phase) == "rays" ? V_ : total, phase);
  })
                                 : Progress();
  const auto t0 = Clock::now();
  Transfer pt = detail::compute_at(mesh_, src, o_, sub, false);
  report_.seconds_tracing += since(t0);
  report_.traces += P;
  done_ += P;
  if (!root_) return Transfer{};
  Transfer t;
  t.header() = pt.header();
  t.vertices = V_;
  t.bounce_energy = pt.bounce_energy;
  t.direct_energy = pt.direct_energy;
  expand(pt.coeffs, t.coeffs, true);
  if (!pt.direct.empty()) expand(pt.direct, t.direct, true);
  scatter(pt.ao, t.ao, 1, 0.0f);
  scatter(pt.bent_normals, t.bent_normals, 1, glm::vec3(0.0f));
  fill_ao_bent(t.ao, t.bent_normals);
  t.glossy = pt.glossy;
  if (t.glossy) {
    const std::size_t gstride = pt.glossy_stride();
    scatter(pt.glossy_matrices, t.glossy_matrices, gstride, 0.0f);
    // Analytic points' matrices were not written: the hemisphere's own, per channel.
    for (std::size_t i = 0; i < P; ++i)
      if (analytic_points[i]) {
        const std::vector<double> H = glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(nrm[i])), o_.bands);
        float* g = t.glossy_matrices.data() + std::size_t(traced_list[i]) * gstride;
        for (int c = 0; c < pt.glossy_channels(); ++c)
          for (std::size_t q = 0; q < std::size_t(nc_) * nc_; ++q) g[std::size_t(c) * nc_ * nc_ + q] = float(H[q]);
      }
    fill_glossy(t.glossy_matrices, gstride, false, pt.glossy_channels());
  }
  std::vector<std::uint8_t> analytic(V_, 0);
  for (std::size_t i = 0; i < P; ++i) analytic[traced_list[i]] = analytic_points[i];
  finish(t, std::move(analytic));
  return t;
}

}  // namespace

namespace detail {

void check_adaptive_options(const AdaptiveOptions& adaptive, std::size_t points) {
  const auto bad = [](const std::string& what) { return Error("adaptive sample points: " + what); };
  if (!(adaptive.tolerance >= 0 && adaptive.tolerance < 1))
    throw bad(fmt::format("tolerance {} is outside [0, 1) (0: the default for the samples)", adaptive.tolerance));
  if (!(adaptive.probe_fraction > 0 && adaptive.probe_fraction <= 1))
    throw bad(fmt::format("probe fraction {} is outside (0, 1]", adaptive.probe_fraction));
  if (adaptive.min_probes < 1) throw bad(fmt::format("min_probes {} is below 1", adaptive.min_probes));
  if (!(adaptive.verify_fraction >= 0 && adaptive.verify_fraction <= 1))
    throw bad(fmt::format("verify fraction {} is outside [0, 1]", adaptive.verify_fraction));
  if (points >= std::size_t(kNone)) throw bad("2^32 - 1 sample points or more");
}

Transfer adaptive_at(const Mesh& mesh, const AdaptivePoints& points, const TransferOptions& options,
                     const AdaptiveOptions& adaptive, const Progress& progress, AdaptiveReport& report) {
  check_adaptive_options(adaptive, points.count);
  report = AdaptiveReport{};
  std::unique_ptr<tbb::global_control> limit;
  if (options.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, options.threads);
  Adaptive a(mesh, points, options, adaptive, progress, report);
  return a.run();
}

}  // namespace detail

Transfer compute_adaptive_transfer(const Mesh& mesh, const TransferOptions& options, const AdaptiveOptions& adaptive,
                                   const Progress& progress, AdaptiveReport* report) {
  detail::check_transfer_options(options, mesh);
  detail::refuse_adaptive_light_bounce(options);
  AdaptiveReport local;
  AdaptiveReport& r = report ? *report : local;
  if (options.mode == TransferMode::Unshadowed) {  // no rays: nothing to save
    detail::check_adaptive_options(adaptive, mesh.vertex_count());
    r = AdaptiveReport{};
    Transfer t = compute_transfer(mesh, options, progress);
    r.tolerance = adaptive.tolerance > 0 ? adaptive.tolerance : default_adaptive_tolerance(options.samples);
    r.vertices = r.traced = mesh.vertex_count();
    return t;
  }
  detail::AdaptivePoints points;
  points.positions = mesh.positions.data();
  points.normals = mesh.normals.data();
  points.count = mesh.vertex_count();
  if (options.vertex_colors)
    for (const glm::vec3& c : mesh.colors) points.albedo.push_back(glm::clamp(c, 0.0f, 1.0f));
  adjacency(mesh, points);
  double edge_sum = 0;
  for (const glm::uvec3& t : mesh.triangles)
    for (int e = 0; e < 3; ++e)
      edge_sum += glm::length(glm::dvec3(mesh.positions[t[(e + 1) % 3]]) - glm::dvec3(mesh.positions[t[e]]));
  points.spacing = mesh.triangles.empty() ? 0.0 : edge_sum / (3.0 * double(mesh.triangles.size()));
  Transfer t = detail::adaptive_at(mesh, points, options, adaptive, progress, r);
  if (options.comm && options.comm->rank() != 0) return t;  // the file is rank 0's
  t.mesh_hash = mesh.hash();
  t.shading_hash = shading_hash(mesh, options.vertex_colors);
  return t;
}

}  // namespace prt
