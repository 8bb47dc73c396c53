// Subdividing coarse meshes for their transfer (docs/PRECOMPUTE.md,
// "Subdividing coarse meshes"): the converse of adaptive sample points, as
// D3DX's ComputeDirectLightingSHAdaptive. A per-vertex transfer is linear
// over each triangle when it is drawn, so a shadow edge crossing a big
// triangle of a coarse mesh is lost; here the edges whose two ends'
// transfer differs by more than TOL (the band-weighted metric of the
// adaptive sample points' TOL) are split at their midpoints, round by round:
//  - edges are keyed by their ends' positions, so the two sides of a seam
//    (vertices a file duplicates) split together, and an edge is split once
//    in every triangle that has it: no T-junction, nothing opens;
//  - a triangle with 1, 2 or 3 split edges becomes 2, 3 or 4 (winding kept;
//    with 2, the quad left is cut along its shorter diagonal);
//  - the new vertex: the midpoint, the normalised mean of the ends' normals,
//    their mean colour, per corner the mean UV;
//  - largest difference first, until the cap on the vertex count.
// How each round's transfer is had: shadowed, the new vertices alone are
// traced (detail::compute_at at points, against the input's ray scene,
// built once: midpoints of flat triangles leave the surface rays hit as it
// was); interreflected (whose bounces gather from every vertex) and
// unshadowed (no rays), the whole mesh. When the traced rows show no edge
// over TOL the refined mesh's transfer is computed whole (compute_transfer:
// what is returned, the same bits) and its edges checked again, so the
// result holds what the report says of it.
#include <prt/error.h>
#include <prt/precompute.h>

#include "ray_scene.h"
#include "transfer_impl.h"

#include <fmt/core.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <tuple>
#include <vector>

namespace prt {

namespace {

constexpr std::uint32_t kNoVertex = std::numeric_limits<std::uint32_t>::max();

// Every rank gets rank 0's `data` (count floats): an all-gather in which
// rank 0's part is everything.
void broadcast(std::vector<float>& data, const Communicator& comm) {
  if (comm.size() == 1) return;
  std::vector<std::size_t> blocks(std::size_t(comm.size()) + 1, data.size() * sizeof(float));
  blocks[0] = 0;
  comm.all_gather(data.data(), blocks);
}

// What make_mesh makes of `normals` given as a file's (it renormalises them
// in double): a mesh of one degenerate triangle per normal.
std::vector<glm::vec3> as_loaded(const std::vector<glm::vec3>& normals) {
  std::vector<glm::uvec3> tris(normals.size());
  for (std::size_t i = 0; i < tris.size(); ++i) tris[i] = glm::uvec3(std::uint32_t(i));
  return make_mesh(std::vector<glm::vec3>(normals.size(), glm::vec3(0.0f)), std::move(tris), normals).normals;
}

// The refined mesh, with normals that make_mesh keeps as they are: the mesh
// written (prt precompute --subdivided-mesh) and loaded again must have the
// same normals (shading_hash: analytic vertices are shaded from them), but
// renormalising a float unit vector in double may move it by an ulp, and
// again each time. Where it would, the nearest vector within 2 ulps per
// component that stays put replaces it.
Mesh build_mesh(std::vector<glm::vec3> positions, std::vector<glm::uvec3> triangles, std::vector<glm::vec3> normals,
                std::vector<glm::vec3> colors, const std::string& source) {
  Mesh m = make_mesh(positions, triangles, normals, colors, {}, source);
  const std::vector<glm::vec3> again = as_loaded(m.normals);
  std::vector<std::size_t> moved;
  for (std::size_t v = 0; v < again.size(); ++v)
    if (again[v] != m.normals[v]) moved.push_back(v);
  if (moved.empty()) return m;
  constexpr int kReach = 2, kSide = 2 * kReach + 1, kPerVertex = kSide * kSide * kSide;
  std::vector<glm::vec3> candidates;
  candidates.reserve(moved.size() * kPerVertex);
  const auto step = [](float x, int k) {
    for (; k > 0; --k) x = std::nextafter(x, std::numeric_limits<float>::infinity());
    for (; k < 0; ++k) x = std::nextafter(x, -std::numeric_limits<float>::infinity());
    return x;
  };
  for (std::size_t v : moved) {
    const glm::vec3 n = m.normals[v];
    for (int i = 0; i < kPerVertex; ++i)
      candidates.emplace_back(step(n.x, i % kSide - kReach), step(n.y, i / kSide % kSide - kReach),
                              step(n.z, i / (kSide * kSide) - kReach));
  }
  const std::vector<glm::vec3> kept = as_loaded(candidates);
  normals = m.normals;
  for (std::size_t j = 0; j < moved.size(); ++j) {
    const glm::dvec3 want = normals[moved[j]];
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = j * kPerVertex; i < (j + 1) * kPerVertex; ++i) {
      const double d = glm::length(glm::dvec3(candidates[i]) - want);
      if (kept[i] == candidates[i] && d < best) best = d, normals[moved[j]] = candidates[i];
    }
  }
  return make_mesh(std::move(positions), std::move(triangles), std::move(normals), std::move(colors), {}, source);
}

// An edge of a triangle: its key (the ends' position ids, low first), its
// ends (vertex indices, low first), the triangle and corner (edge k joins
// corners k and k + 1).
struct EdgeUse {
  std::uint32_t key0, key1, a, b, tri;
  std::uint8_t corner;
};

class Subdivider {
 public:
  Subdivider(const Mesh& input, const TransferOptions& o, const SubdivideOptions& s, const Progress& progress)
      : input_(input), o_(o), s_(s), progress_(progress), comm_(o.comm ? *o.comm : single_process()),
        w_(detail::band_weights(o.bands)) {
    choice_ = o;
    choice_.glossy = false;  // the choice reads the diffuse rows only
    choice_.memory_report = nullptr;
    const bool grey = !o.vertex_colors && o.albedo.x == o.albedo.y && o.albedo.y == o.albedo.z;
    channels_ = grey ? 1 : 3;
    stride_ = std::size_t(channels_) * std::size_t(o.bands) * std::size_t(o.bands);
    cap_ = s.max_vertices ? s.max_vertices : 4 * input.vertex_count();
  }

  Subdivided run(SubdivideReport& r) {
    // The input with normals make_mesh keeps (an ulp from its own at most): split or not, the mesh returned
    // must load back as it is.
    mesh_ = build_mesh(input_.positions, input_.triangles, input_.normals, input_.colors, input_.source);
    corner_uvs_ = input_.corner_uvs;
    if (!corner_uvs_.empty()) set_corner_uvs(mesh_, corner_uvs_);
    rows_for(0);
    // The scale: the RMS over the input's vertices with a normal of their rows' weighted norm.
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t v = 0; v < mesh_.vertex_count(); ++v) {
      if (!has_normal(v)) continue;
      sum += detail::weighted_square(rows_.data() + v * stride_, nullptr, w_, channels_);
      ++n;
    }
    ref_ = n ? std::sqrt(sum / double(n)) : 0.0;

    for (;;) {
      std::vector<Candidate> over = edges_over();
      if (over.empty()) {
        if (exact_) break;
        exact_pass();  // the traced rows say done: check the whole mesh's transfer
        continue;
      }
      if (r.rounds == s_.max_rounds) break;
      const std::size_t added = split(over, r);
      if (added == 0) break;  // the cap allows no split (r.capped)
      ++r.rounds;
      rows_for(mesh_.vertex_count() - added);
      if (r.capped) break;
    }
    if (!exact_) exact_pass();
    r.vertices = mesh_.vertex_count();
    Subdivided out;
    out.mesh = std::move(mesh_);
    out.transfer = std::move(transfer_);
    return out;
  }

 private:
  struct Candidate {
    double error;
    std::size_t first, last;  // its uses in uses_ [first, last)
  };

  bool has_normal(std::size_t v) const { return mesh_.normals[v] != glm::vec3(0.0f); }

  // The rows of the current mesh, rows for vertices [from, V) new (the rest
  // kept from the round before).
  void rows_for(std::size_t from) {
    const std::size_t V = mesh_.vertex_count();
    if (!o_.glossy && (from == 0 || o_.mode != TransferMode::Shadowed)) return exact_pass();
    exact_ = false;
    transfer_ = Transfer{};
    if (o_.mode == TransferMode::Shadowed) {
      // The new vertices alone, against the input's geometry (the same surface).
      if (!scene_) scene_ = std::make_unique<detail::RayScene>(input_);
      const std::size_t P = V - from;
      std::vector<std::uint32_t> ids(P);
      std::iota(ids.begin(), ids.end(), std::uint32_t(from));
      const detail::VertexPoints points(mesh_, ids, o_.vertex_colors);
      const detail::Source src = points.source(scene_.get());
      const Transfer t = detail::compute_at(input_, src, choice_, progress_, true);
      PRT_CHECK_OP(t.stride(), ==, stride_);
      rows_.resize(from * stride_);
      rows_.insert(rows_.end(), t.coeffs.begin(), t.coeffs.end());
      return;
    }
    // Interreflected glossy: the whole mesh's diffuse transfer, on every rank.
    detail::Source src;
    src.positions = mesh_.positions.data();
    src.normals = mesh_.normals.data();
    src.count = V;
    const Transfer t = detail::compute_at(mesh_, src, choice_, progress_, true);
    PRT_CHECK_OP(t.stride(), ==, stride_);
    rows_ = t.coeffs;
  }

  // compute_transfer of the current mesh: the result, if nothing is split after it.
  void exact_pass() {
    transfer_ = compute_transfer(mesh_, o_, progress_);
    if (comm_.rank() == 0) {
      PRT_CHECK_OP(transfer_.stride(), ==, stride_);
      rows_ = dense_transfer(transfer_, mesh_);
    } else {
      rows_.assign(mesh_.vertex_count() * stride_, 0.0f);
    }
    broadcast(rows_, comm_);
    exact_ = true;
  }

  // Every edge's uses, grouped by key (sorted); the groups whose largest
  // difference exceeds TOL, largest first.
  std::vector<Candidate> edges_over() {
    const std::size_t V = mesh_.vertex_count();
    // Position ids: one per distinct position (bit-identical), in order of first vertex.
    std::vector<std::uint32_t> order(V);
    std::iota(order.begin(), order.end(), 0u);
    const auto bits = [&](std::uint32_t v) {
      std::array<std::uint32_t, 3> b;
      std::memcpy(b.data(), &mesh_.positions[v], sizeof b);
      return b;
    };
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      const auto pa = bits(a), pb = bits(b);
      return pa != pb ? pa < pb : a < b;
    });
    std::vector<std::uint32_t> pid(V);
    for (std::size_t i = 0; i < V; ++i)
      pid[order[i]] = i > 0 && bits(order[i]) == bits(order[i - 1]) ? pid[order[i - 1]] : order[i];

    uses_.clear();
    uses_.reserve(3 * mesh_.triangles.size());
    for (std::size_t t = 0; t < mesh_.triangles.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        std::uint32_t a = mesh_.triangles[t][k], b = mesh_.triangles[t][(k + 1) % 3];
        if (pid[a] == pid[b]) continue;  // no length: nothing to split
        if (a > b) std::swap(a, b);
        const std::uint32_t k0 = std::min(pid[a], pid[b]), k1 = std::max(pid[a], pid[b]);
        uses_.push_back({k0, k1, a, b, std::uint32_t(t), std::uint8_t(k)});
      }
    std::sort(uses_.begin(), uses_.end(), [](const EdgeUse& x, const EdgeUse& y) {
      return std::tie(x.key0, x.key1, x.a, x.b, x.tri, x.corner) < std::tie(y.key0, y.key1, y.a, y.b, y.tri, y.corner);
    });
    std::vector<Candidate> over;
    if (!(ref_ > 0)) return over;
    for (std::size_t i = 0; i < uses_.size();) {
      std::size_t j = i;
      double worst = 0;
      while (j < uses_.size() && uses_[j].key0 == uses_[i].key0 && uses_[j].key1 == uses_[i].key1) {
        const EdgeUse& e = uses_[j];
        if ((j == i || e.a != uses_[j - 1].a || e.b != uses_[j - 1].b) && has_normal(e.a) && has_normal(e.b))
          worst = std::max(worst, edge_error(e.a, e.b));
        ++j;
      }
      if (worst > s_.tolerance) over.push_back({worst, i, j});
      i = j;
    }
    std::stable_sort(over.begin(), over.end(), [](const Candidate& x, const Candidate& y) { return x.error > y.error; });
    return over;
  }

  double edge_error(std::uint32_t a, std::uint32_t b) const {
    return std::sqrt(detail::weighted_square(rows_.data() + std::size_t(a) * stride_, rows_.data() + std::size_t(b) * stride_,
                                     w_, channels_)) /
           ref_;
  }

  // Splits the candidates in order while the cap allows; rebuilds mesh_.
  // Returns the vertices added.
  std::size_t split(const std::vector<Candidate>& over, SubdivideReport& rep) {
    const std::size_t V = mesh_.vertex_count(), T = mesh_.triangles.size();
    std::vector<glm::vec3> pos = mesh_.positions, nrm = mesh_.normals, col = mesh_.colors;
    std::vector<std::uint32_t> mid(3 * T, kNoVertex);  // per triangle corner edge: its midpoint vertex
    for (const Candidate& c : over) {
      std::size_t needed = 0;  // distinct vertex pairs in the group
      for (std::size_t j = c.first; j < c.last; ++j)
        needed += j == c.first || uses_[j].a != uses_[j - 1].a || uses_[j].b != uses_[j - 1].b;
      if (pos.size() + needed > cap_) {
        rep.capped = true;
        break;
      }
      std::uint32_t m = kNoVertex;
      for (std::size_t j = c.first; j < c.last; ++j) {
        const EdgeUse& e = uses_[j];
        if (j == c.first || e.a != uses_[j - 1].a || e.b != uses_[j - 1].b) {
          m = std::uint32_t(pos.size());
          pos.push_back((mesh_.positions[e.a] + mesh_.positions[e.b]) * 0.5f);
          const glm::dvec3 sum = glm::dvec3(mesh_.normals[e.a]) + glm::dvec3(mesh_.normals[e.b]);
          const double len = glm::length(sum);
          nrm.push_back(len > 0 && std::isfinite(len) ? glm::vec3(sum / len) : glm::vec3(0.0f));
          if (!col.empty()) col.push_back((mesh_.colors[e.a] + mesh_.colors[e.b]) * 0.5f);
          ++rep.split_edges;
        }
        mid[std::size_t(e.tri) * 3 + e.corner] = m;
      }
    }
    const std::size_t added = pos.size() - V;
    if (added == 0) return 0;
    if (T + 3 * added >= std::size_t(kNoVertex))
      throw Error(fmt::format("subdividing for transfer: more than {} triangles", kNoVertex - 1));

    const bool uvs = !corner_uvs_.empty();
    std::vector<glm::uvec3> tris;
    std::vector<glm::vec2> cuv;
    tris.reserve(T + 3 * added);
    struct Corner {
      std::uint32_t v;
      glm::vec2 uv;
    };
    const auto emit = [&](const Corner& x, const Corner& y, const Corner& z) {
      tris.emplace_back(x.v, y.v, z.v);
      if (uvs) cuv.insert(cuv.end(), {x.uv, y.uv, z.uv});
    };
    const auto dist2 = [&](std::uint32_t a, std::uint32_t b) {
      const glm::dvec3 d = glm::dvec3(pos[a]) - glm::dvec3(pos[b]);
      return glm::dot(d, d);
    };
    for (std::size_t t = 0; t < T; ++t) {
      Corner c[3], m[3];
      int n = 0;
      for (int k = 0; k < 3; ++k) {
        c[k].v = mesh_.triangles[t][k];
        c[k].uv = uvs ? corner_uvs_[3 * t + k] : glm::vec2(0.0f);
      }
      for (int k = 0; k < 3; ++k) {
        m[k].v = mid[3 * t + k];
        m[k].uv = (c[k].uv + c[(k + 1) % 3].uv) * 0.5f;
        n += m[k].v != kNoVertex;
      }
      // Rotated corners: r-th corner first.
      const auto C = [&](int r, int k) -> const Corner& { return c[(r + k) % 3]; };
      const auto M = [&](int r, int k) -> const Corner& { return m[(r + k) % 3]; };
      if (n == 0) {
        emit(c[0], c[1], c[2]);
      } else if (n == 1) {  // the split edge from corner r: (a, m, c), (m, b, c)
        int r = 0;
        while (m[r].v == kNoVertex) ++r;
        emit(C(r, 0), M(r, 0), C(r, 2));
        emit(M(r, 0), C(r, 1), C(r, 2));
      } else if (n == 2) {  // edges a-b and b-c split, c-a not: the corner at b, and the quad a m0 m1 c
        int u = 0;
        while (m[u].v != kNoVertex) ++u;
        const int r = (u + 1) % 3;
        const Corner &a = C(r, 0), &b = C(r, 1), &cc = C(r, 2), &m0 = M(r, 0), &m1 = M(r, 1);
        emit(m0, b, m1);
        if (dist2(a.v, m1.v) <= dist2(m0.v, cc.v)) {
          emit(a, m0, m1);
          emit(a, m1, cc);
        } else {
          emit(a, m0, cc);
          emit(m0, m1, cc);
        }
      } else {
        emit(c[0], m[0], m[2]);
        emit(m[0], c[1], m[1]);
        emit(m[2], m[1], c[2]);
        emit(m[0], m[1], m[2]);
      }
    }
    mesh_ = build_mesh(std::move(pos), std::move(tris), std::move(nrm), std::move(col), input_.source);
    if (uvs) set_corner_uvs(mesh_, cuv);
    corner_uvs_ = std::move(cuv);
    return added;
  }

  const Mesh& input_;
  const TransferOptions& o_;
  const SubdivideOptions& s_;
  const Progress& progress_;
  const Communicator& comm_;
  const std::vector<double> w_;
  TransferOptions choice_;
  int channels_ = 1;
  std::size_t stride_ = 0, cap_ = 0;
  double ref_ = 0;

  Mesh mesh_;
  std::vector<glm::vec2> corner_uvs_;
  std::vector<float> rows_;  // V x stride, every vertex's row
  bool exact_ = false;       // rows_ and transfer_ are compute_transfer(mesh_)'s
  Transfer transfer_;
  std::unique_ptr<detail::RayScene> scene_;
  std::vector<EdgeUse> uses_;
};

}  // namespace

Subdivided subdivide_for_transfer(const Mesh& mesh, const TransferOptions& options, const SubdivideOptions& s,
                                  const Progress& progress, SubdivideReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  detail::check_transfer_options(options, mesh);
  const auto bad = [](const std::string& what) { return Error("subdividing for transfer: " + what); };
  if (options.between_bounces)
    throw bad("a translucent material's transfer is not subdivided (its surface integral runs once, over the whole "
              "mesh); precompute it on a finer mesh");
  if (!(s.tolerance > 0 && s.tolerance < 1)) throw bad(fmt::format("tolerance {} is outside (0, 1)", s.tolerance));
  if (s.max_vertices != 0 && s.max_vertices < mesh.vertex_count())
    throw bad(fmt::format("at most {} vertices is below the mesh's {} (0: 4x the mesh's)", s.max_vertices,
                          mesh.vertex_count()));
  if (s.max_rounds < 1) throw bad(fmt::format("max_rounds {} is below 1", s.max_rounds));
  SubdivideReport local;
  SubdivideReport& r = report ? *report : local;
  r = SubdivideReport{};
  r.input_vertices = mesh.vertex_count();
  Subdivider sub(mesh, options, s, progress);
  Subdivided out = sub.run(r);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace prt
