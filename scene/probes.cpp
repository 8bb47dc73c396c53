// Probe volumes (prt/probes.h; docs/PROBES.md): the grid and the probe data
// with its one validator. The file: scene/transfer_io_probes.cpp; the
// visibility and interpolation weights: scene/probe_visibility.cpp; the SH
// matrices: scene/probe_matrices.cpp; relighting: scene/probe_relighter.cpp.
#include <prt/probes.h>

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/hash.h>
#include <prt/io.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <limits>


namespace prt {

// ---- the grid -------------------------------------------------------------------

glm::dvec3 ProbeGrid::position(int i, int j, int k) const {
  const glm::dvec3 f(double(i) / (dims[0] - 1), double(j) / (dims[1] - 1), double(k) / (dims[2] - 1));
  return min + (max - min) * f;
}

glm::dvec3 ProbeGrid::spacing() const {
  return (max - min) / glm::dvec3(dims[0] - 1, dims[1] - 1, dims[2] - 1);
}

std::string probe_dims_problem(const std::array<int, 3>& dims) {
  const auto rule = [] {
    return fmt::format("each of NX, NY, NZ must be 2 to {}, and NX x NY x NZ at most {}", kMaxProbeDim, kMaxProbes);
  };
  const char* names[3] = {"NX", "NY", "NZ"};
  for (int a = 0; a < 3; ++a)
    if (dims[std::size_t(a)] < 2 || dims[std::size_t(a)] > kMaxProbeDim)
      return fmt::format("{} is {}; {}", names[a], dims[std::size_t(a)], rule());
  const std::size_t n = std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
  if (n > kMaxProbes) return fmt::format("{} x {} x {} is {} probes; {}", dims[0], dims[1], dims[2], n, rule());
  return {};
}

std::array<int, 3> parse_probe_dims(std::string_view text) {
  const auto bad = [&] {
    return Error(fmt::format("--probes: expected NXxNYxNZ, each 2 to {} (e.g. 16x8x16), at most {} probes, got '{}'",
                             kMaxProbeDim, kMaxProbes, text));
  };
  std::array<int, 3> d{};
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int a = 0; a < 3; ++a) {
    const auto r = std::from_chars(p, end, d[std::size_t(a)]);
    if (r.ec != std::errc() || d[std::size_t(a)] < 2 || d[std::size_t(a)] > kMaxProbeDim) throw bad();
    p = r.ptr;
    if (a < 2) {
      if (p == end || (*p != 'x' && *p != 'X')) throw bad();
      ++p;
    }
  }
  if (p != end) throw bad();
  if (!probe_dims_problem(d).empty()) throw bad();
  return d;
}

ProbeGrid probe_grid(const Mesh& mesh, const std::array<int, 3>& dims) {
  if (const std::string p = probe_dims_problem(dims); !p.empty()) throw Error("probe grid: " + p);
  if (mesh.positions.empty()) throw Error("probes: the scene has no vertices");
  ProbeGrid g;
  g.dims = dims;
  g.min = g.max = glm::dvec3(mesh.positions.front());
  for (const glm::vec3& p : mesh.positions) {
    g.min = glm::min(g.min, glm::dvec3(p));
    g.max = glm::max(g.max, glm::dvec3(p));
  }
  return g;
}

// ---- the transfer ------------------------------------------------------------------

std::size_t ProbeTransfer::stored() const {
  return std::size_t(std::count(state.begin(), state.end(), ProbeState::Stored));
}

std::size_t ProbeTransfer::bounce_floats_per_probe() const {
  if (mode != TransferMode::Interreflected) return 0;
  return std::size_t(channels) * std::size_t(sh::num_coeffs(bands)) * std::size_t(sh::num_coeffs(bounce_bands));
}

std::size_t ProbeTransfer::bytes() const {
  return state.size() + positions.size() * sizeof(glm::vec3) + vis_nodes.size() * 2 + vis_offsets.size() * 8 + vis_complement.size() + partial_nodes.size() * 4 +
         partial_offsets.size() * 8 + depth.size() * 2 +
         bounce.size() * 4;
}

std::vector<std::uint32_t> ProbeTransfer::stored_slots() const {
  std::vector<std::uint32_t> slot(state.size(), ~0u);
  std::uint32_t n = 0;
  for (std::size_t p = 0; p < state.size(); ++p)
    if (state[p] == ProbeState::Stored) slot[p] = n++;
  return slot;
}

namespace {

// Probe positions and the depth cap lie within this distance of the origin
// on every axis. prt writes them within 4 x kMaxCoordinate: the grid's box
// is a mesh's bounding box (within kMaxCoordinate), a probe moves off the
// surfaces near it by less than a spacing (at most 2 x kMaxCoordinate), and
// the cap is twice the largest spacing. 8 x leaves room; squared in float
// (the GPU probe pass: distances, the cap^2) they stay finite.
constexpr double kMaxProbeCoordinate = 8 * kMaxCoordinate;

// The visibility quadtree of every stored probe (docs/FORMAT.md "Probe
// volume"), after the counts and offsets are known to agree: every node id
// inside the cube and no node listed twice or inside another listed one
// (the nodes are disjoint: nothing counts twice); every partial texel a
// finest texel, listed once, its mask neither 0 nor all 16 sub-texels (an
// edge texel: a clear or fully visible texel is stored in the nodes), and
// in the cube's clear region: inside no listed node when the nodes are the
// visible ones, inside a listed node when they are the blocked ones
// (vis_complement), else its light would count twice. Linear in the nodes
// and partial texels (a walk up the tree, at most 7 levels, per entry),
// independent of their order; in parallel over blocks of probes (about
// 13 ns an entry on one core: 160 ms for a 73 MB volume of 64 x 32 x 64),
// the first problem in probe order reported.
class QuadtreeCheck {
 public:
  explicit QuadtreeCheck(const ProbeTransfer& t) : t_(t), r_(t.cube_res) {
    const int levels = std::countr_zero(unsigned(r_)) + 1;
    std::vector<std::size_t> offset(std::size_t(levels) + 1, 0);
    for (int l = 0; l < levels; ++l)
      offset[std::size_t(l) + 1] = offset[std::size_t(l)] + std::size_t(r_ >> l) * std::size_t(r_ >> l);
    per_face_ = offset.back();
    ids_ = 6 * per_face_;
    finest_ = std::size_t(r_) * std::size_t(r_);
    parent_.assign(ids_, kRoot);
    for (std::size_t face = 0; face < 6; ++face)
      for (int l = 0; l + 1 < levels; ++l) {
        const std::size_t size = std::size_t(r_ >> l), up = size / 2;
        for (std::size_t y = 0; y < size; ++y)
          for (std::size_t x = 0; x < size; ++x)
            parent_[face * per_face_ + offset[std::size_t(l)] + y * size + x] =
                std::uint16_t(face * per_face_ + offset[std::size_t(l) + 1] + (y / 2) * up + x / 2);
      }
  }

  // The first problem of stored slots [begin, end), or "".
  std::string slots(std::size_t begin, std::size_t end) const {
    std::vector<std::uint8_t> listed(ids_, 0), seen(ids_, 0);  // this probe's nodes, its partial texels
    for (std::size_t s = begin; s < end; ++s)
      if (std::string p = slot(s, listed, seen); !p.empty()) return fmt::format("probe {}: {}", probe_of(s), p);
    return "";
  }

 private:
  static constexpr std::uint16_t kRoot = 0xffff;  // a face's root has no parent

  std::string slot(std::size_t s, std::vector<std::uint8_t>& listed, std::vector<std::uint8_t>& seen) const {
    const ProbeTransfer& t = t_;
    const std::uint64_t nb = t.vis_offsets[s], ne = t.vis_offsets[s + 1];
    for (std::uint64_t i = nb; i < ne; ++i) {
      const std::uint16_t id = t.vis_nodes[i];
      if (id >= ids_) return fmt::format("visibility node {} is past the cube's nodes (a cube of {} has {})", id, r_, ids_);
      if (listed[id]) return fmt::format("visibility node {} is listed twice", id);
      listed[id] = 1;
    }
    for (std::uint64_t i = nb; i < ne; ++i)
      for (std::uint16_t p = parent_[t.vis_nodes[i]]; p != kRoot; p = parent_[p])
        if (listed[p]) return fmt::format("visibility node {} lies inside node {}, also listed (the nodes overlap)", t.vis_nodes[i], p);
    const bool complement = t.vis_complement[s] != 0;
    const std::uint64_t pb = t.partial_offsets[s], pe = t.partial_offsets[s + 1];
    for (std::uint64_t i = pb; i < pe; ++i) {
      const std::uint16_t id = t.partial_nodes[i];
      if (id >= ids_) return fmt::format("partial texel {} is past the cube's nodes (a cube of {} has {})", id, r_, ids_);
      if (id % per_face_ >= finest_)
        return fmt::format("partial texel {} is not a finest texel (node {} of face {}; a cube of {} has {} finest "
                           "texels a face)",
                           id, id % per_face_, id / per_face_, r_, finest_);
      const std::uint16_t mask = t.partial_mask[i];
      if (mask == 0 || mask == 0xffff)
        return fmt::format("partial texel {} has sub-texel mask {:#06x} (an edge texel: 1 to 15 of its 16 sub-texels "
                           "visible)",
                           id, mask);
      if (seen[id]) return fmt::format("partial texel {} is listed twice", id);
      seen[id] = 1;
      std::uint16_t under = kRoot;
      for (std::uint16_t p = id; p != kRoot && under == kRoot; p = parent_[p])
        if (listed[p]) under = p;
      if (!complement && under != kRoot)
        return fmt::format("partial texel {} lies inside visibility node {} (a visible node: the texel would count "
                           "twice)",
                           id, under);
      if (complement && under == kRoot)
        return fmt::format("partial texel {} lies inside none of its blocked nodes (complement: the texel would "
                           "count as visible and again as partial)",
                           id);
    }
    for (std::uint64_t i = nb; i < ne; ++i) listed[t.vis_nodes[i]] = 0;
    for (std::uint64_t i = pb; i < pe; ++i) seen[t.partial_nodes[i]] = 0;
    return "";
  }

  // The probe of stored slot s (for messages).
  std::size_t probe_of(std::size_t s) const {
    std::size_t p = 0;
    for (std::size_t n = 0;; ++p)
      if (t_.state[p] == ProbeState::Stored && n++ == s) return p;
  }

  const ProbeTransfer& t_;
  int r_;
  std::size_t per_face_ = 0, ids_ = 0, finest_ = 0;
  std::vector<std::uint16_t> parent_;  // per node id
};

std::string quadtree_problem(const ProbeTransfer& t) {
  const QuadtreeCheck check(t);
  const std::size_t stored = t.vis_offsets.size() - 1, block = 4096, blocks = (stored + block - 1) / block;
  std::vector<std::string> problem(blocks);
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
    problem[b] = check.slots(b * block, std::min(stored, (b + 1) * block));
  });
  for (const std::string& p : problem)
    if (!p.empty()) return p;
  return "";
}

}  // namespace

std::string probe_transfer_problem(const ProbeTransfer& t) {
  const ProbeGrid& g = t.grid;
  for (int a = 0; a < 3; ++a)
    if (g.dims[std::size_t(a)] < 2 || g.dims[std::size_t(a)] > kMaxProbeDim)
      return fmt::format("grid dimension {} is {} (2 to {})", a, g.dims[std::size_t(a)], kMaxProbeDim);
  if (g.count() > kMaxProbes) return fmt::format("{} probes (at most {})", g.count(), kMaxProbes);
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(g.min[a]) || !std::isfinite(g.max[a]) || g.max[a] < g.min[a]) return "the grid's box is not finite";
    // The box is a mesh's bounding box, whose coordinates load_mesh and the ray scene hold within kMaxCoordinate.
    if (std::abs(g.min[a]) > kMaxCoordinate || std::abs(g.max[a]) > kMaxCoordinate)
      return fmt::format("the grid's box ({:g} to {:g} on axis {}) is beyond prt's coordinate limit of {:g}", g.min[a],
                         g.max[a], a, kMaxCoordinate);
  }
  if (t.bands < 1 || t.bands > 8) return fmt::format("{} output bands (1 to 8)", t.bands);
  if (t.cube_res < 4 || t.cube_res > 64 || !std::has_single_bit(unsigned(t.cube_res)))
    return fmt::format("visibility cube size {} (a power of two, 4 to 64)", t.cube_res);
  if (t.depth_res < 2 || t.depth_res > 32) return fmt::format("depth map size {} (2 to 32)", t.depth_res);
  if (t.rays_per_texel < 1) return "no rays per texel";
  if (t.mode != TransferMode::Shadowed && t.mode != TransferMode::Interreflected)
    return "mode must be shadowed or interreflected";
  if (t.mode == TransferMode::Interreflected) {
    if (t.bounces < 1 || t.bounces > kMaxProbeBounces || t.bounce_bands < 1 || t.bounce_bands > 16)
      return fmt::format("interreflected: {} bounces (1 to {}), {} bounce bands (1 to 16)", t.bounces, kMaxProbeBounces,
                         t.bounce_bands);
    if (t.channels != 1 && t.channels != 3) return fmt::format("{} channels (1 or 3)", t.channels);
  } else if (t.bounces != 0 || t.bounce_bands != 0 || t.channels != 1) {
    return fmt::format("shadowed, with {} bounces, {} bounce bands and {} channels (a shadowed volume has 0, 0 and 1)",
                       t.bounces, t.bounce_bands, t.channels);
  }
  if (!(t.depth_cap > 0) || !(t.depth_cap <= kMaxProbeCoordinate))
    return fmt::format("depth cap {:g} (positive, at most {:g})", t.depth_cap, kMaxProbeCoordinate);
  const std::size_t P = g.count();
  if (t.state.size() != P || t.positions.size() != P) return "state and positions must have one entry per probe";
  std::size_t stored = 0;
  for (ProbeState s : t.state) {
    if (s != ProbeState::Sky && s != ProbeState::Stored && s != ProbeState::Invalid) return "unknown probe state";
    stored += s == ProbeState::Stored;
  }
  for (std::size_t p = 0; p < P; ++p) {
    const glm::vec3& x = t.positions[p];
    if (!(std::abs(x.x) <= kMaxProbeCoordinate && std::abs(x.y) <= kMaxProbeCoordinate && std::abs(x.z) <= kMaxProbeCoordinate))
      return fmt::format("probe {}'s position ({:g}, {:g}, {:g}) is not finite or beyond {:g} (the grid's box is "
                         "within {:g})",
                         p, x.x, x.y, x.z, kMaxProbeCoordinate, kMaxCoordinate);
  }
  if (t.vis_offsets.size() != stored + 1 || t.vis_complement.size() != stored || t.vis_offsets.front() != 0 ||
      t.vis_offsets.back() != t.vis_nodes.size())
    return fmt::format("visibility node offsets do not match {} stored probes and {} nodes", stored, t.vis_nodes.size());
  for (std::size_t i = 0; i + 1 < t.vis_offsets.size(); ++i)
    if (t.vis_offsets[i + 1] < t.vis_offsets[i]) return "visibility node offsets decrease";
  for (std::uint8_t c : t.vis_complement)
    if (c > 1) return "visibility complement flag not 0 or 1";
  if (t.partial_offsets.size() != stored + 1 || t.partial_offsets.front() != 0 ||
      t.partial_offsets.back() != t.partial_nodes.size() || t.partial_mask.size() != t.partial_nodes.size())
    return fmt::format("partial texel offsets do not match {} stored probes and {} texels", stored, t.partial_nodes.size());
  for (std::size_t i = 0; i + 1 < t.partial_offsets.size(); ++i)
    if (t.partial_offsets[i + 1] < t.partial_offsets[i]) return "partial texel offsets decrease";
  if (const std::string q = quadtree_problem(t); !q.empty()) return q;
  if (t.depth.size() != stored * 2 * std::size_t(t.depth_res) * t.depth_res)
    return fmt::format("{} depth values for {} stored probes", t.depth.size(), stored);
  if (t.bounce.size() != stored * t.bounce_floats_per_probe())
    return fmt::format("{} bounce values for {} stored probes", t.bounce.size(), stored);
  for (float v : t.bounce)
    if (!std::isfinite(v)) return "a bounce matrix value is not finite";
  return "";
}

}  // namespace prt
