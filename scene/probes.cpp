// Probe volumes (prt/probes.h; docs/PROBES.md): the grid, relighting,
// visibility-aware interpolation and the probe file.
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

// ---- the file (docs/FORMAT.md "Probe volume") ----------------------------------------

namespace {

constexpr char kProbeMagic[8] = {'P', 'R', 'T', 'P', '\r', '\n', '\x1a', '\n'};
constexpr char kEnd[4] = {'P', 'R', 'T', 'E'};
constexpr std::uint32_t kProbeVersion = 1;

class Out {
 public:
  void raw(const void* data, std::size_t n) {
    const std::size_t at = bytes.size();
    bytes.resize(at + n);
    if (n > 0) std::memcpy(bytes.data() + at, data, n);
  }
  template <typename T>
  void put(const T& v) {
    raw(&v, sizeof(T));
  }
  template <typename T>
  void array(const std::vector<T>& v) {
    put(std::uint64_t(v.size()));
    raw(v.data(), v.size() * sizeof(T));
  }
  std::vector<unsigned char> bytes;
};

class In {
 public:
  In(const std::vector<unsigned char>& b, const std::string& path) : b_(b), path_(path) {}
  template <typename T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, b_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  template <typename T>
  void array(std::vector<T>& v, const char* what) {
    const std::uint64_t n = get<std::uint64_t>();
    if (n > (b_.size() - at_) / sizeof(T)) throw Error(fmt::format("{}: {}: {} entries run past the end of the file", path_, what, n));
    v.resize(std::size_t(n));
    if (n > 0) std::memcpy(v.data(), b_.data() + at_, std::size_t(n) * sizeof(T));
    at_ += std::size_t(n) * sizeof(T);
  }
  std::size_t at() const { return at_; }

 private:
  void need(std::size_t n) const {
    if (b_.size() - at_ < n) throw Error(path_ + ": truncated probe file");
  }
  const std::vector<unsigned char>& b_;
  const std::string& path_;
  std::size_t at_ = 0;
};

}  // namespace

void write_probe_transfer(const std::string& path, const ProbeTransfer& t) {
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw Error(path + ": cannot write this probe volume: " + p);
  Out o;
  o.raw(kProbeMagic, 8);
  o.put(kProbeVersion);
  for (int a = 0; a < 3; ++a) o.put(std::int32_t(t.grid.dims[std::size_t(a)]));
  for (int a = 0; a < 3; ++a) o.put(t.grid.min[a]);
  for (int a = 0; a < 3; ++a) o.put(t.grid.max[a]);
  for (std::int32_t v : {t.bands, t.cube_res, t.depth_res, int(t.mode), t.bounces, t.bounce_bands, t.channels, t.rays_per_texel})
    o.put(v);
  o.put(t.seed);
  o.put(t.scene_hash);
  o.put(t.depth_cap);
  std::vector<std::uint8_t> state(t.state.size());
  for (std::size_t i = 0; i < state.size(); ++i) state[i] = std::uint8_t(t.state[i]);
  o.array(state);
  o.array(t.positions);
  o.array(t.vis_nodes);
  o.array(t.vis_offsets);
  o.array(t.vis_complement);
  o.array(t.partial_nodes);
  o.array(t.partial_mask);
  o.array(t.partial_offsets);
  o.array(t.depth);
  o.array(t.bounce);
  const std::uint64_t h = hash64(o.bytes.data(), o.bytes.size());
  o.put(h);
  o.raw(kEnd, 4);
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f.write(reinterpret_cast<const char*>(o.bytes.data()), std::streamsize(o.bytes.size()));
    f.close();
    if (!f) throw Error(path + ": write failed");
  });
}

bool is_probe_file(const std::string& path) {
  // Only a regular file is opened: a FIFO would block here, before the
  // reader that names the problem (check_input_file) is reached.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream f(path, std::ios::binary);
  char head[8] = {};
  f.read(head, 8);
  return f && std::memcmp(head, kProbeMagic, 8) == 0;
}

ProbeTransfer read_probe_transfer(const std::string& path) {
  check_input_file(path, "a probe volume");
  std::ifstream f(path, std::ios::binary);
  std::vector<unsigned char> b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (!f.eof() && f.fail()) throw Error(path + ": read error");
  if (b.size() < 8 || std::memcmp(b.data(), kProbeMagic, 8) != 0)
    throw Error(path + ": not a probe volume (prt precompute SCENE --probes NXxNYxNZ writes one)");
  if (b.size() < 8 + 4 + 12 || std::memcmp(b.data() + b.size() - 4, kEnd, 4) != 0)
    throw Error(path + ": truncated probe file (no end marker)");
  std::uint64_t stored_hash;
  std::memcpy(&stored_hash, b.data() + b.size() - 12, 8);
  if (hash64(b.data(), b.size() - 12) != stored_hash) throw Error(path + ": checksum mismatch: the file is damaged");
  b.resize(b.size() - 12);
  In in(b, path);
  for (int i = 0; i < 8; ++i) in.get<char>();
  const auto version = in.get<std::uint32_t>();
  if (version != kProbeVersion)
    throw Error(fmt::format("{}: probe file version {} (this prt reads {})", path, version, kProbeVersion));
  ProbeTransfer t;
  for (int a = 0; a < 3; ++a) t.grid.dims[std::size_t(a)] = in.get<std::int32_t>();
  for (int a = 0; a < 3; ++a) t.grid.min[a] = in.get<double>();
  for (int a = 0; a < 3; ++a) t.grid.max[a] = in.get<double>();
  t.bands = in.get<std::int32_t>();
  t.cube_res = in.get<std::int32_t>();
  t.depth_res = in.get<std::int32_t>();
  const std::int32_t mode = in.get<std::int32_t>();
  if (mode != int(TransferMode::Shadowed) && mode != int(TransferMode::Interreflected))
    throw Error(fmt::format("{}: unknown mode {}", path, mode));
  t.mode = TransferMode(mode);
  t.bounces = in.get<std::int32_t>();
  t.bounce_bands = in.get<std::int32_t>();
  t.channels = in.get<std::int32_t>();
  t.rays_per_texel = in.get<std::int32_t>();
  t.seed = in.get<std::uint64_t>();
  t.scene_hash = in.get<std::uint64_t>();
  t.depth_cap = in.get<float>();
  std::vector<std::uint8_t> state;
  in.array(state, "probe states");
  t.state.resize(state.size());
  for (std::size_t i = 0; i < state.size(); ++i) {
    if (state[i] > 2) throw Error(fmt::format("{}: probe {} has an unknown state {}", path, i, state[i]));
    t.state[i] = ProbeState(state[i]);
  }
  in.array(t.positions, "probe positions");
  in.array(t.vis_nodes, "visibility nodes");
  in.array(t.vis_offsets, "visibility node offsets");
  in.array(t.vis_complement, "visibility complement flags");
  in.array(t.partial_nodes, "partial texels");
  in.array(t.partial_mask, "partial texel masks");
  in.array(t.partial_offsets, "partial texel offsets");
  in.array(t.depth, "depth moments");
  in.array(t.bounce, "bounce matrices");
  if (in.at() != b.size()) throw Error(path + ": bytes after the last array");
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw Error(path + ": inconsistent probe volume: " + p);
  return t;
}

// ---- the visibility quadtree ------------------------------------------------------------

namespace {

std::size_t level_offset(int r, int level) {
  std::size_t o = 0;
  for (int l = 0; l < level; ++l) o += std::size_t(r >> l) * std::size_t(r >> l);
  return o;
}

}  // namespace

std::uint16_t probe_node_id(int r, int face, int level, int x, int y) {
  const std::size_t per_face = (4 * std::size_t(r) * std::size_t(r) - 1) / 3;
  return std::uint16_t(std::size_t(face) * per_face + level_offset(r, level) + std::size_t(y) * std::size_t(r >> level) +
                       std::size_t(x));
}

std::vector<std::uint16_t> probe_visibility_nodes(std::span<const std::uint32_t> bits, int r, bool& complement) {
  PRT_CHECK(r >= 1 && r <= 64 && std::has_single_bit(unsigned(r)));
  PRT_CHECK(bits.size() * 32 >= std::size_t(6) * r * r);
  const int levels = std::countr_zero(unsigned(r)) + 1;
  // Per face, counts of set bits per node, bottom-up.
  std::vector<std::uint16_t> on, off;
  std::vector<std::uint32_t> count;
  for (int face = 0; face < 6; ++face) {
    count.assign(level_offset(r, levels), 0);
    for (int v = 0; v < r; ++v)
      for (int u = 0; u < r; ++u) {
        const std::size_t i = (std::size_t(face) * r + std::size_t(v)) * r + std::size_t(u);
        count[std::size_t(v) * r + std::size_t(u)] = (bits[i >> 5] >> (i & 31)) & 1u;
      }
    for (int l = 1; l < levels; ++l) {
      const int size = r >> l;
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          std::uint32_t c = 0;
          for (int q = 0; q < 4; ++q)
            c += count[level_offset(r, l - 1) + std::size_t(2 * y + (q >> 1)) * std::size_t(2 * size) + std::size_t(2 * x + (q & 1))];
          count[level_offset(r, l) + std::size_t(y) * size + std::size_t(x)] = c;
        }
    }
    struct Node { int level, x, y; };
    std::vector<Node> stack{{levels - 1, 0, 0}};
    while (!stack.empty()) {
      const Node n = stack.back();
      stack.pop_back();
      const std::uint32_t c = count[level_offset(r, n.level) + std::size_t(n.y) * std::size_t(r >> n.level) + std::size_t(n.x)];
      const std::uint32_t full = std::uint32_t(1) << (2 * n.level);
      if (c == full) on.push_back(probe_node_id(r, face, n.level, n.x, n.y));
      else if (c == 0) off.push_back(probe_node_id(r, face, n.level, n.x, n.y));
      else
        for (int q = 3; q >= 0; --q) stack.push_back({n.level - 1, 2 * n.x + (q & 1), 2 * n.y + (q >> 1)});
    }
  }
  complement = off.size() < on.size();
  return complement ? off : on;
}

// ---- octahedral map ------------------------------------------------------------------

glm::dvec2 octahedral_encode(const glm::dvec3& d) {
  const double s = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
  double x = d.x / s, y = d.y / s;
  if (d.z < 0) {
    const double ox = (1.0 - std::abs(y)) * (x >= 0 ? 1.0 : -1.0), oy = (1.0 - std::abs(x)) * (y >= 0 ? 1.0 : -1.0);
    x = ox;
    y = oy;
  }
  return {x * 0.5 + 0.5, y * 0.5 + 0.5};
}

glm::dvec3 octahedral_decode(const glm::dvec2& uv) {
  double x = uv.x * 2 - 1, y = uv.y * 2 - 1;
  const double z = 1.0 - std::abs(x) - std::abs(y);
  if (z < 0) {
    const double ox = (1.0 - std::abs(y)) * (x >= 0 ? 1.0 : -1.0), oy = (1.0 - std::abs(x)) * (y >= 0 ? 1.0 : -1.0);
    x = ox;
    y = oy;
  }
  return glm::normalize(glm::dvec3(x, y, z));
}

// ---- visibility-aware weights -------------------------------------------------------

double probe_visibility(const ProbeTransfer& t, std::size_t slot, const glm::dvec3& dir, double distance) {
  const int N = t.depth_res;
  const std::uint16_t* m = t.depth.data() + slot * 2 * std::size_t(N) * N;
  const glm::dvec2 uv = octahedral_encode(dir);
  const double fx = uv.x * N - 0.5, fy = uv.y * N - 0.5;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  // Octahedral border: a texel past an edge is its mirror across the edge's midpoint.
  const auto texel = [&](int x, int y) {
    if (x < 0) { x = -x - 1; y = N - 1 - y; }
    else if (x >= N) { x = 2 * N - 1 - x; y = N - 1 - y; }
    if (y < 0) { y = -y - 1; x = N - 1 - x; }
    else if (y >= N) { y = 2 * N - 1 - y; x = N - 1 - x; }
    return std::size_t(std::clamp(y, 0, N - 1)) * N + std::size_t(std::clamp(x, 0, N - 1));
  };
  double mean = 0, mean2 = 0;
  for (int dy = 0; dy <= 1; ++dy)
    for (int dx = 0; dx <= 1; ++dx) {
      const double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
      const std::size_t i = texel(x0 + dx, y0 + dy);
      mean += w * m[2 * i] / 65535.0;
      mean2 += w * m[2 * i + 1] / 65535.0;
    }
  const double cap = t.depth_cap;
  mean *= cap;
  mean2 *= cap * cap;
  if (distance <= mean) return 1.0;
  const double var = std::max(mean2 - mean * mean, 1e-8 * cap * cap);
  const double d = distance - mean;
  double v = var / (var + d * d);
  v = v * v * v;
  if (v < 0.2) v *= v * v / 0.04;  // DDGI's crush: a little light does not leak
  return v;
}

ProbeWeights trilinear_weights(const ProbeGrid& g, const glm::dvec3& p) {
  int i0[3];
  double f[3];
  const glm::dvec3 s = g.spacing();
  for (int a = 0; a < 3; ++a) {
    const int n = g.dims[std::size_t(a)];
    double x = s[a] > 0 ? (p[a] - g.min[a]) / s[a] : 0.0;
    if (!(x >= 0)) x = 0;  // NaN (a query point that is not finite) too: int(NaN) is undefined
    x = std::clamp(x, 0.0, double(n - 1));
    i0[a] = std::min(int(std::floor(x)), n - 2);
    f[a] = x - i0[a];
  }
  ProbeWeights w;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    w.probe[std::size_t(c)] = std::uint32_t(g.index(i0[0] + dx, i0[1] + dy, i0[2] + dz));
    w.weight[std::size_t(c)] = float((dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]));
  }
  w.count = 8;
  return w;
}

ProbeWeights probe_weights(const ProbeTransfer& t, std::span<const std::uint32_t> slots, const glm::dvec3& p,
                           const glm::dvec3& n, const ProbeVisibility& visible) {
  const glm::dvec3 s = t.grid.spacing();
  double smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (s[a] > 0) smallest = std::min(smallest, s[a]);
  if (!std::isfinite(smallest)) smallest = 0;
  const double nl = glm::length(n);
  // The depth moments see a surface point's own surface: look from a
  // tenth of a spacing off it. Traced visibility starts its segments off the
  // surface itself and needs no bias (a bias would carry a point inside a
  // box out through its wall).
  const glm::dvec3 q = nl > 0 && !visible ? p + n / nl * (0.1 * smallest) : p;
  ProbeWeights w = trilinear_weights(t.grid, p);
  PRT_CHECK(slots.size() == t.state.size());
  double sum = 0;
  for (int c = 0; c < 8; ++c) {
    const std::uint32_t probe = w.probe[std::size_t(c)];
    double weight = w.weight[std::size_t(c)];
    if (weight > 0) {
      if (t.state[probe] == ProbeState::Invalid) {
        weight = 0;
      } else if (visible) {
        weight *= visible(glm::dvec3(t.positions[probe]), q);
      } else if (t.state[probe] == ProbeState::Stored) {
        const glm::dvec3 d = q - glm::dvec3(t.positions[probe]);
        const double dist = glm::length(d);
        if (dist > 0) weight *= probe_visibility(t, slots[probe], d / dist, dist);
      }
    }
    w.weight[std::size_t(c)] = float(weight);
    sum += weight;
  }
  const double norm = 1.0 / std::max(sum, kProbeMinWeight);
  for (float& x : w.weight) x = float(x * norm);
  return w;
}

glm::dvec3 lambert_from_sh(std::span<const glm::vec3> sh, int bands, const glm::dvec3& n) {
  const int nc = sh::num_coeffs(bands);
  PRT_CHECK(sh.size() >= std::size_t(nc));
  std::vector<double> y(static_cast<std::size_t>(nc));
  const glm::dvec3 u = glm::normalize(n);
  sh::eval(bands, u.x, u.y, u.z, y.data());
  glm::dvec3 out(0.0);
  for (int l = 0; l < bands; ++l) {
    const double a = sh::clamped_cosine_factor(l) / M_PI;
    for (int m = -l; m <= l; ++m) {
      const int k = sh::index(l, m);
      out += a * y[std::size_t(k)] * glm::dvec3(sh[std::size_t(k)]);
    }
  }
  return out;
}

// ---- SH matrices ---------------------------------------------------------------------------

std::vector<float> probe_sh_matrices(const ProbeTransfer& t, int in_bands, int& channels) {
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw Error("probe volume: " + p);
  if (in_bands < 1 || in_bands > kMaxProbeMatrixBands)
    throw Error(fmt::format("probe SH matrices: {} input bands (1 to {})", in_bands, kMaxProbeMatrixBands));
  const int r = t.cube_res, no = sh::num_coeffs(t.bands), ni = sh::num_coeffs(in_bands);
  const int big = std::max(t.bands, in_bands);
  const std::size_t per = std::size_t(no) * std::size_t(ni);
  const std::size_t per_face = (4 * std::size_t(r) * std::size_t(r) - 1) / 3, nodes = 6 * per_face;
  // Per node: the integral of Y_k Y_j over its texels (4 x 4 directions a
  // finest texel, one per sub-texel, each a 16th of its solid angle).
  std::vector<double> node(nodes * per, 0.0);
  const auto sub_direction = [&](int face, int u, int v, int q) {
    return glm::normalize(cube_direction(face, 2.0 * (u + ((q & 3) + 0.5) / 4) / r - 1.0, 2.0 * (v + ((q >> 2) + 0.5) / 4) / r - 1.0));
  };
  std::vector<double> y(static_cast<std::size_t>(sh::num_coeffs(big)));
  for (int face = 0; face < 6; ++face)
    for (int v = 0; v < r; ++v)
      for (int u = 0; u < r; ++u) {
        const double w = cube_texel_solid_angle(u, v, r) / 16.0;
        double* nd = node.data() + std::size_t(probe_node_id(r, face, 0, u, v)) * per;
        for (int q = 0; q < 16; ++q) {
          const glm::dvec3 d = sub_direction(face, u, v, q);
          sh::eval(big, d.x, d.y, d.z, y.data());
          for (int k = 0; k < no; ++k)
            for (int j = 0; j < ni; ++j) nd[std::size_t(k) * ni + std::size_t(j)] += w * y[std::size_t(k)] * y[std::size_t(j)];
        }
      }
  for (int face = 0; face < 6; ++face)
    for (int l = 1; (r >> l) >= 1; ++l)
      for (int yy = 0; yy < (r >> l); ++yy)
        for (int xx = 0; xx < (r >> l); ++xx) {
          double* dst = node.data() + std::size_t(probe_node_id(r, face, l, xx, yy)) * per;
          for (int q = 0; q < 4; ++q) {
            const double* src = node.data() + std::size_t(probe_node_id(r, face, l - 1, 2 * xx + (q & 1), 2 * yy + (q >> 1))) * per;
            for (std::size_t i = 0; i < per; ++i) dst[i] += src[i];
          }
        }
  std::vector<double> whole(per, 0.0);
  for (int face = 0; face < 6; ++face) {
    const int top = std::countr_zero(unsigned(r));
    const double* root = node.data() + std::size_t(probe_node_id(r, face, top, 0, 0)) * per;
    for (std::size_t i = 0; i < per; ++i) whole[i] += root[i];
  }
  channels = t.mode == TransferMode::Interreflected ? t.channels : 1;
  const std::size_t P = t.probes(), stride = std::size_t(channels) * per;
  std::vector<float> out(P * stride, 0.0f);
  const std::vector<std::uint32_t> slots = t.stored_slots();
  const int nb = t.mode == TransferMode::Interreflected ? sh::num_coeffs(t.bounce_bands) : 0;
  std::vector<double> m(per);
  for (std::size_t p = 0; p < P; ++p) {
    if (t.state[p] == ProbeState::Invalid) continue;
    if (t.state[p] == ProbeState::Sky) {
      m = whole;
    } else {
      const std::size_t s = slots[p];
      std::fill(m.begin(), m.end(), 0.0);
      for (std::uint64_t i = t.vis_offsets[s]; i < t.vis_offsets[s + 1]; ++i) {
        const double* src = node.data() + std::size_t(t.vis_nodes[i]) * per;
        for (std::size_t q = 0; q < per; ++q) m[q] += src[q];
      }
      if (t.vis_complement[s])
        for (std::size_t q = 0; q < per; ++q) m[q] = whole[q] - m[q];
      for (std::uint64_t i = t.partial_offsets[s]; i < t.partial_offsets[s + 1]; ++i) {
        const std::size_t id = t.partial_nodes[i], face = id / per_face, at = id - face * per_face;
        const int u = int(at % std::size_t(r)), v = int(at / std::size_t(r));
        const double w = cube_texel_solid_angle(u, v, r) / 16.0;
        for (int q = 0; q < 16; ++q)
          if ((t.partial_mask[i] >> q) & 1u) {
            const glm::dvec3 d = sub_direction(int(face), u, v, q);
            sh::eval(big, d.x, d.y, d.z, y.data());
            for (int k = 0; k < no; ++k)
              for (int j = 0; j < ni; ++j) m[std::size_t(k) * ni + std::size_t(j)] += w * y[std::size_t(k)] * y[std::size_t(j)];
          }
      }
    }
    for (int c = 0; c < channels; ++c) {
      float* dst = out.data() + p * stride + std::size_t(c) * per;
      for (std::size_t q = 0; q < per; ++q) dst[q] = float(m[q]);
      if (nb > 0 && t.state[p] == ProbeState::Stored) {
        const float* B = t.bounce.data() + std::size_t(slots[p]) * t.bounce_floats_per_probe() +
                         (t.channels == 1 ? 0 : std::size_t(c) * std::size_t(no) * std::size_t(nb));
        for (int k = 0; k < no; ++k)
          for (int j = 0; j < std::min(ni, nb); ++j) dst[std::size_t(k) * ni + std::size_t(j)] += B[std::size_t(k) * nb + std::size_t(j)];
      }
    }
  }
  return out;
}

void write_probe_matrices(const std::string& path, const ProbeTransfer& t, const std::vector<float>& matrices,
                          int in_bands, int channels) {
  const std::size_t no = std::size_t(sh::num_coeffs(t.bands)), ni = std::size_t(sh::num_coeffs(in_bands));
  PRT_CHECK(matrices.size() == t.probes() * std::size_t(channels) * no * ni);
  Out o;
  o.raw("PRTPMAT1", 8);
  o.put(std::uint32_t(t.probes()));
  for (int a = 0; a < 3; ++a) o.put(std::uint32_t(t.grid.dims[std::size_t(a)]));
  for (int a = 0; a < 3; ++a) o.put(t.grid.min[a]);
  for (int a = 0; a < 3; ++a) o.put(t.grid.max[a]);
  o.put(std::uint32_t(no));
  o.put(std::uint32_t(ni));
  o.put(std::uint32_t(channels));
  o.put(std::uint32_t(0));
  for (std::size_t p = 0; p < t.probes(); ++p) {
    o.put(t.positions[p]);
    o.put(std::uint32_t(t.state[p]));
  }
  o.raw(matrices.data(), matrices.size() * sizeof(float));
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f.write(reinterpret_cast<const char*>(o.bytes.data()), std::streamsize(o.bytes.size()));
    f.close();
    if (!f) throw Error(path + ": write failed");
  });
}

// ---- relighting ------------------------------------------------------------------------

namespace {

// The texel of direction d in a cube of face size r: face * r^2 + v * r + u;
// *at: where in it, x + 256 y in 1/256ths of the texel.
std::size_t cube_texel(const glm::dvec3& d, int r, std::uint16_t* at = nullptr) {
  double s = 0, t = 0;
  const int face = cube_face_coords(d, s, t);
  const double fu = std::clamp((s + 1) * 0.5 * r, 0.0, double(r) - 1e-9), fv = std::clamp((t + 1) * 0.5 * r, 0.0, double(r) - 1e-9);
  const int u = int(fu), v = int(fv);
  if (at) *at = std::uint16_t(std::min(255, int((fu - u) * 256)) + 256 * std::min(255, int((fv - v) * 256)));
  return (std::size_t(face) * r + std::size_t(v)) * r + std::size_t(u);
}

// A bright pixel's share of each sub-texel of its texel (bit 4 sy + sx of
// a partial texel's mask), from where it lies (`at`, as cube_texel gives
// it): bilinear between the sub-texels' centres, clamped at the texel's
// border. Summed over a mask's visible sub-texels, the visible area of a
// sub-texel-sized box at the pixel (a sun that an edge half hides gets
// half its light, not all or nothing). Up to 4 (cell, weight) pairs.
void sub_texel_weights(std::uint16_t at, int cell[4], float weight[4]) {
  const float x = std::clamp(float(at & 255u) / 64.0f - 0.5f, 0.0f, 3.0f), y = std::clamp(float(at >> 8) / 64.0f - 0.5f, 0.0f, 3.0f);
  const int x0 = std::min(int(x), 2), y0 = std::min(int(y), 2);
  const float a = x - float(x0), b = y - float(y0);
  cell[0] = 4 * y0 + x0;
  cell[1] = cell[0] + 1;
  cell[2] = cell[0] + 4;
  cell[3] = cell[0] + 5;
  weight[0] = (1 - a) * (1 - b);
  weight[1] = a * (1 - b);
  weight[2] = (1 - a) * b;
  weight[3] = a * b;
}

// Bilinear lookup in a cube of face n (within the face, clamped at its edges).
glm::vec3 cube_bilinear(const std::vector<glm::vec3>& cube, int n, const glm::dvec3& d) {
  double s = 0, t = 0;
  const int face = cube_face_coords(d, s, t);
  const double fu = std::clamp((s + 1) * 0.5 * n - 0.5, 0.0, double(n - 1)), fv = std::clamp((t + 1) * 0.5 * n - 0.5, 0.0, double(n - 1));
  const int u0 = std::min(int(fu), n - 2 < 0 ? 0 : n - 2), v0 = std::min(int(fv), n - 2 < 0 ? 0 : n - 2);
  const int u1 = std::min(u0 + 1, n - 1), v1 = std::min(v0 + 1, n - 1);
  const float a = float(fu - u0), b = float(fv - v0);
  const glm::vec3* f = cube.data() + std::size_t(face) * std::size_t(n) * std::size_t(n);
  const auto at = [&](int u, int v) { return f[std::size_t(v) * std::size_t(n) + std::size_t(u)]; };
  return (1 - b) * ((1 - a) * at(u0, v0) + a * at(u1, v0)) + b * ((1 - a) * at(u0, v1) + a * at(u1, v1));
}

float luminance(const glm::vec3& c) { return 0.2126f * std::abs(c.x) + 0.7152f * std::abs(c.y) + 0.0722f * std::abs(c.z); }

// One probe's SH (before the bounce): its nodes' sums (or the whole minus
// them) plus its partial texels. Inlined into relight_range's clones (AVX2
// where the CPU has it).
struct ProbeSums {
  const ProbeTransfer* t;
  const float* sums;
  const float* total;  // stride floats
  const std::int32_t* cell_slot;
  const float* cell_sums;
  std::size_t stride, nodes_per_face, r;
};

constexpr int kPopcount4[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};

inline int popcount16(std::uint16_t m) {
  return kPopcount4[m & 15] + kPopcount4[(m >> 4) & 15] + kPopcount4[(m >> 8) & 15] + kPopcount4[m >> 12];
}

// Adds `from` x f (or 1) into `to`, `stride` floats; W: 8-float vectors (GCC
// and Clang vector extensions: one AVX op, or two SSE ops in the baseline
// clone).
typedef float Float8 __attribute__((vector_size(32)));
typedef float Float8Unaligned __attribute__((vector_size(32), aligned(4), may_alias));

template <std::size_t W>
struct Lanes {
  Float8 v[W];
  void load(const float* p) {
    for (std::size_t i = 0; i < W; ++i) v[i] = reinterpret_cast<const Float8Unaligned*>(p)[i];
  }
  void add(const float* p) {
    for (std::size_t i = 0; i < W; ++i) v[i] += reinterpret_cast<const Float8Unaligned*>(p)[i];
  }
  void add(const float* p, float f) {
    for (std::size_t i = 0; i < W; ++i) v[i] += reinterpret_cast<const Float8Unaligned*>(p)[i] * f;
  }
  void sub(const float* p) {
    for (std::size_t i = 0; i < W; ++i) v[i] -= reinterpret_cast<const Float8Unaligned*>(p)[i];
  }
};

// The same for any stride (a multiple of 8), in loops.
struct AnyLanes {
  std::size_t n;
  float v[8 * 8 * 3 + 8] = {};  // nc <= 64 (8 bands), padded
  void load(const float* p) { std::copy_n(p, n, v); }
  void add(const float* p) {
    for (std::size_t j = 0; j < n; ++j) v[j] += p[j];
  }
  void add(const float* p, float f) {
    for (std::size_t j = 0; j < n; ++j) v[j] += p[j] * f;
  }
  void sub(const float* p) {
    for (std::size_t j = 0; j < n; ++j) v[j] -= p[j];
  }
};

// One probe's SH (before the bounce): its nodes' sums (or the whole minus
// them) plus its partial texels: a texel without bright pixels by its
// visible fraction, one with them by its visible sub-texels' sums (at most
// 8 adds: the texel minus the hidden ones when fewer). Inlined into
// relight_range's clones (AVX2 where the CPU has it).
template <class L>
__attribute__((always_inline)) inline void probe_sums(const ProbeSums& c, std::size_t s, L& acc, L& part, float* out) {
  const ProbeTransfer& t = *c.t;
  const std::size_t stride = c.stride;
  {
    // Two chains of adds (the adds' latency, not the loads, bounds one).
    L other = acc;
    std::uint64_t i = t.vis_offsets[s];
    for (; i + 1 < t.vis_offsets[s + 1]; i += 2) {
      acc.add(c.sums + std::size_t(t.vis_nodes[i]) * stride);
      other.add(c.sums + std::size_t(t.vis_nodes[i + 1]) * stride);
    }
    if (i < t.vis_offsets[s + 1]) acc.add(c.sums + std::size_t(t.vis_nodes[i]) * stride);
    acc.add(reinterpret_cast<const float*>(&other.v[0]));
  }
  for (std::uint64_t i = t.partial_offsets[s]; i < t.partial_offsets[s + 1]; ++i) {
    const std::size_t id = t.partial_nodes[i];
    const std::size_t face = std::size_t(id >= c.nodes_per_face) + std::size_t(id >= 2 * c.nodes_per_face) +
                             std::size_t(id >= 3 * c.nodes_per_face) + std::size_t(id >= 4 * c.nodes_per_face) +
                             std::size_t(id >= 5 * c.nodes_per_face);  // id / nodes_per_face, without a division
    const std::size_t texel = face * c.r * c.r + (id - face * c.nodes_per_face);
    const std::uint16_t mask = t.partial_mask[i];
    const int visible = popcount16(mask);
    const std::int32_t slot = c.cell_slot[texel];
    if (slot < 0) {
      part.add(c.sums + id * stride, float(visible) / 16.0f);
      continue;
    }
    const float* cells = c.cell_sums + std::size_t(slot) * 16 * stride;
    if (visible <= 8) {
      for (unsigned m = mask; m != 0; m &= m - 1) part.add(cells + std::size_t(__builtin_ctz(m)) * stride);
    } else {
      part.add(c.sums + id * stride);
      for (unsigned m = std::uint16_t(~mask); m != 0; m &= m - 1) part.sub(cells + std::size_t(__builtin_ctz(m)) * stride);
    }
  }
  const float* part_v = reinterpret_cast<const float*>(&part.v[0]);
  if (t.vis_complement[s]) {
    L res = acc;
    res.load(c.total);
    res.add(part_v);
    res.sub(reinterpret_cast<const float*>(&acc.v[0]));
    std::memcpy(out, res.v, stride * sizeof(float));
  } else {
    acc.add(part_v);
    std::memcpy(out, acc.v, stride * sizeof(float));
  }
}

}  // namespace

ProbeRelighter::ProbeRelighter(const ProbeTransfer& t, const EnvMap& map) : t_(t) {
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw Error("probe volume: " + p);
  require_finite(map);
  nc_ = sh::num_coeffs(t.bands);
  stride_ = (std::size_t(nc_) * 3 + 7) / 8 * 8;
  const int r = t.cube_res;
  levels_ = std::countr_zero(unsigned(r)) + 1;  // sizes r, r/2, ..., 1
  level_offset_.resize(std::size_t(levels_) + 1, 0);
  for (int l = 0; l < levels_; ++l)
    level_offset_[std::size_t(l) + 1] = level_offset_[std::size_t(l)] + std::size_t(r >> l) * std::size_t(r >> l);
  nodes_per_face_ = level_offset_.back();
  // Nodes on 64-byte boundaries (a 3-band node is two cache lines, not three).
  sums_.assign(6 * nodes_per_face_ * stride_ + 16, 0.0f);
  sums_at_ = std::size_t((64 - reinterpret_cast<std::uintptr_t>(sums_.data()) % 64) % 64 / sizeof(float));
  total_.assign(std::size_t(nc_), glm::vec3(0.0f));

  // The map, downsampled by an integer factor f (solid-angle weighted sums
  // of f x f blocks) to about 16 pixels across a visibility texel; each
  // block's direction, power and radiance, and a lookup from a direction to
  // its block (the smooth cube below is resampled from it).
  std::vector<glm::vec3> radiance;  // per block, in grid order
  std::function<std::size_t(const glm::dvec3&)> block_of;
  const auto add_block = [&](const glm::dvec3& dir, double omega, const glm::dvec3& power) {
    radiance.push_back(omega > 0 ? glm::vec3(power / omega) : glm::vec3(0.0f));
    dirs_.push_back(glm::vec3(glm::length(dir) > 0 ? glm::normalize(dir) : glm::dvec3(0, 0, 1)));
    power_.push_back(glm::vec3(power));
  };
  if (map.is_cube()) {
    const int N = map.width;
    int f = 1;
    while (N % (2 * f) == 0 && N / (2 * f) >= 2 * r) f *= 2;
    const int nb = N / f;
    for (int face = 0; face < 6; ++face)
      for (int by = 0; by < N; by += f)
        for (int bx = 0; bx < N; bx += f) {
          glm::dvec3 dir(0.0), power(0.0);
          double omega = 0;
          for (int y = by; y < by + f; ++y)
            for (int x = bx; x < bx + f; ++x) {
              const double w = cube_texel_solid_angle(x, y, N);
              const float* c = map.rgb.data() + ((std::size_t(face) * N + std::size_t(y)) * N + std::size_t(x)) * 3;
              dir += cube_texel_direction(face, x, y, N) * w;
              power += glm::dvec3(c[0], c[1], c[2]) * w;
              omega += w;
            }
          add_block(dir, omega, power);
        }
    block_of = [nb](const glm::dvec3& d) { return cube_texel(d, nb); };
  } else {
    const int W = map.width, H = map.height;
    int f = 1;
    while (W % (2 * f) == 0 && H % (2 * f) == 0 && W / (2 * f) >= 16 * r) f *= 2;
    const int wb = W / f, hb = H / f;
    for (int by = 0; by < H; by += f)
      for (int bx = 0; bx < W; bx += f) {
        glm::dvec3 dir(0.0), power(0.0);
        double omega = 0;
        for (int y = by; y < by + f; ++y)
          for (int x = bx; x < bx + f; ++x) {
            const double w = latlong_pixel_solid_angle(y, W, H);
            const float* c = map.rgb.data() + (std::size_t(y) * W + std::size_t(x)) * 3;
            dir += latlong_direction(x + 0.5, y + 0.5, W, H) * w;
            power += glm::dvec3(c[0], c[1], c[2]) * w;
            omega += w;
          }
        add_block(dir, omega, power);
      }
    block_of = [wb, hb](const glm::dvec3& d) {
      double px = 0, py = 0;
      latlong_pixel(d, wb, hb, px, py);
      const int x = std::clamp(int(std::floor(px)), 0, wb - 1), y = std::clamp(int(std::floor(py)), 0, hb - 1);
      return std::size_t(y) * std::size_t(wb) + std::size_t(x);
    };
  }

  // The bright pixels: radiance over kProbeBrightRatio times the map's mean
  // and kProbeLocalRatio times the mean around them (8 lookups 4 texels
  // away: a sun up to a few degrees wide, not the inside of a bright window), the brightest
  // 1/64 of the pixels at most. They are splatted exactly each frame; the
  // rest is resampled.
  {
    double power = 0;
    for (const glm::vec3& p : power_) power += double(luminance(p));
    const float threshold = float(kProbeBrightRatio * power / (4.0 * std::numbers::pi));
    const double step = 8.0 / r;  // about 4 texels at a face's centre, in radians
    const auto local_mean = [&](const glm::dvec3& d) {
      const glm::dvec3 a = std::abs(d.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
      const glm::dvec3 t1 = glm::normalize(glm::cross(d, a)), t2 = glm::cross(d, t1);
      double sum = 0;
      for (int q = 0; q < 8; ++q) {
        const double phi = q * std::numbers::pi / 4;
        sum += double(luminance(radiance[block_of(glm::normalize(d + step * (std::cos(phi) * t1 + std::sin(phi) * t2)))]));
      }
      return sum / 8;
    };
    for (std::size_t i = 0; i < power_.size(); ++i) {
      const float l = luminance(radiance[i]);
      if (l > threshold && double(l) > kProbeLocalRatio * local_mean(glm::dvec3(dirs_[i]))) bright_.push_back(std::uint32_t(i));
    }
    const std::size_t cap = power_.size() / 64;
    if (bright_.size() > cap) {
      std::nth_element(bright_.begin(), bright_.begin() + std::ptrdiff_t(cap), bright_.end(),
                       [&](std::uint32_t a, std::uint32_t b) { return luminance(radiance[a]) > luminance(radiance[b]); });
      bright_.resize(cap);
      std::sort(bright_.begin(), bright_.end());
    }
  }
  // The smooth cube (face 2r, map frame): per texel, the mean of 4 x 4
  // nearest lookups of the blocks, bright ones as 0.
  {
    std::vector<glm::vec3> dim = radiance;
    for (std::uint32_t i : bright_) dim[i] = glm::vec3(0.0f);
    const int n = 2 * r;
    smooth_.assign(6 * std::size_t(n) * std::size_t(n), glm::vec3(0.0f));
    tbb::parallel_for(0, 6 * n, [&](int row) {
      const int face = row / n, y = row % n;
      for (int x = 0; x < n; ++x) {
        glm::vec3 sum(0.0f);
        for (int sy = 0; sy < 4; ++sy)
          for (int sx = 0; sx < 4; ++sx)
            sum += dim[block_of(cube_direction(face, 2.0 * (x + (sx + 0.5) / 4) / n - 1.0, 2.0 * (y + (sy + 0.5) / 4) / n - 1.0))];
        smooth_[(std::size_t(face) * n + std::size_t(y)) * n + std::size_t(x)] = sum / 16.0f;
      }
    });
    // The finest texels' quarters (the 2r cube's texels, world frame).
    quarter_dir_.resize(smooth_.size());
    quarter_y_.resize(smooth_.size() * std::size_t(nc_));
    std::vector<double> y(static_cast<std::size_t>(nc_));
    for (int face = 0; face < 6; ++face)
      for (int v = 0; v < n; ++v)
        for (int u = 0; u < n; ++u) {
          const std::size_t q = (std::size_t(face) * n + std::size_t(v)) * n + std::size_t(u);
          const glm::dvec3 d = cube_texel_direction(face, u, v, n);
          quarter_dir_[q] = glm::vec3(d);
          const double w = cube_texel_solid_angle(u, v, n);
          sh::eval(t.bands, d.x, d.y, d.z, y.data());
          for (int k = 0; k < nc_; ++k) quarter_y_[q * std::size_t(nc_) + std::size_t(k)] = float(y[std::size_t(k)] * w);
        }
  }
  if (t.mode == TransferMode::Interreflected) {
    // The bounce side: the map's first bounce_bands bands, point quadrature
    // over the blocks (the light the surfaces get goes through this band
    // limit, docs/PROBES.md).
    const int nb = sh::num_coeffs(t.bounce_bands);
    bounce_sh_.assign(std::size_t(nb), glm::dvec3(0.0));
    std::vector<double> y(static_cast<std::size_t>(nb));
    for (std::size_t i = 0; i < dirs_.size(); ++i) {
      sh::eval(t.bounce_bands, double(dirs_[i].x), double(dirs_[i].y), double(dirs_[i].z), y.data());
      for (int k = 0; k < nb; ++k) bounce_sh_[std::size_t(k)] += y[std::size_t(k)] * glm::dvec3(power_[i]);
    }
    bounce_rot_ = bounce_sh_;
  }

  slot_ = t.stored_slots();
  set_rotation(glm::dmat3(1.0));
}

void ProbeRelighter::set_rotation(const glm::dmat3& R) {
  const int r = t_.cube_res, n = 2 * r;
  const std::size_t stride = stride_, texels = 6 * std::size_t(r) * std::size_t(r);
  const glm::dmat3 Rt = glm::transpose(R);
  // The smooth part: each finest texel's four quarters, sampled in the map
  // frame (R^T d) and weighted by their exact Y_k omega (parallel).
  smooth0_.assign(texels * stride, 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, texels, 512), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t texel = range.begin(); texel < range.end(); ++texel) {
      const std::size_t face = texel / (std::size_t(r) * r), v = (texel / std::size_t(r)) % std::size_t(r), u = texel % std::size_t(r);
      float* out = smooth0_.data() + texel * stride;
      for (int q = 0; q < 4; ++q) {
        const std::size_t i = (face * std::size_t(n) + 2 * v + std::size_t(q >> 1)) * std::size_t(n) + 2 * u + std::size_t(q & 1);
        const glm::vec3 L = cube_bilinear(smooth_, n, Rt * glm::dvec3(quarter_dir_[i]));
        const float* y = quarter_y_.data() + i * std::size_t(nc_);
        for (int k = 0; k < nc_; ++k)
          for (int c = 0; c < 3; ++c) out[std::size_t(k) * 3 + std::size_t(c)] += y[k] * L[c];
      }
    }
  });
  // The bright pixels, exactly: their texel, sub-texel and Y_k(R w) L omega,
  // bucketed by texel (a counting sort, in pixel order within a texel).
  const std::size_t B = bright_.size();
  std::vector<std::uint32_t> texel_of(B);
  std::vector<std::uint16_t> at_of(B);
  std::vector<float> sh_of(B * stride, 0.0f);
  {
    std::vector<double> y(static_cast<std::size_t>(nc_));
    for (std::size_t b = 0; b < B; ++b) {
      const std::uint32_t i = bright_[b];
      const glm::dvec3 d = R * glm::dvec3(dirs_[i]);
      texel_of[b] = std::uint32_t(cube_texel(d, r, &at_of[b]));
      sh::eval(t_.bands, d.x, d.y, d.z, y.data());
      for (int k = 0; k < nc_; ++k)
        for (int c = 0; c < 3; ++c) sh_of[b * stride + std::size_t(k) * 3 + std::size_t(c)] = float(y[std::size_t(k)] * double(power_[i][c]));
    }
  }
  std::vector<std::uint32_t> offset(texels + 1, 0);
  for (std::uint32_t texel : texel_of) ++offset[texel + 1];
  for (std::size_t i = 0; i < texels; ++i) offset[i + 1] += offset[i];
  std::vector<std::uint32_t> order(B);
  {
    std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
    for (std::size_t b = 0; b < B; ++b) order[fill[texel_of[b]]++] = std::uint32_t(b);
  }
  // Texels with bright pixels: the sums of their 16 sub-texels (a 16th of
  // the smooth part each, plus the bright pixels' shares), which partial
  // texels there add up by their masks.
  cell_slot_.assign(texels, -1);
  std::size_t slots = 0;
  for (std::size_t texel = 0; texel < texels; ++texel)
    if (offset[texel + 1] > offset[texel]) cell_slot_[texel] = std::int32_t(slots++);
  cell_sums_.assign(slots * 16 * stride, 0.0f);
  for (std::size_t texel = 0; texel < texels; ++texel) {
    if (cell_slot_[texel] < 0) continue;
    float* cells = cell_sums_.data() + std::size_t(cell_slot_[texel]) * 16 * stride;
    const float* sm = smooth0_.data() + texel * stride;
    for (int q = 0; q < 16; ++q)
      for (std::size_t j = 0; j < stride; ++j) cells[std::size_t(q) * stride + j] = sm[j] / 16.0f;
    for (std::uint32_t i = offset[texel]; i < offset[texel + 1]; ++i) {
      const std::uint32_t b = order[i];
      int cell[4];
      float weight[4];
      sub_texel_weights(at_of[b], cell, weight);
      for (int q = 0; q < 4; ++q)
        for (std::size_t j = 0; j < stride; ++j) cells[std::size_t(cell[q]) * stride + j] += weight[q] * sh_of[std::size_t(b) * stride + j];
    }
  }
  // The pyramid, per face (parallel): level 0 the smooth part plus the
  // bright pixels (in double), each level the sum of its 4 children.
  std::vector<std::vector<double>> face_total(6, std::vector<double>(stride, 0.0));
  tbb::parallel_for(0, 6, [&](int face) {
    std::vector<double> cur(std::size_t(r) * r * stride), next;
    const std::size_t first = std::size_t(face) * r * r;
    for (std::size_t i = 0; i < std::size_t(r) * r; ++i) {
      double* a = cur.data() + i * stride;
      const float* sm = smooth0_.data() + (first + i) * stride;
      for (std::size_t j = 0; j < stride; ++j) a[j] = double(sm[j]);
      for (std::uint32_t b = offset[first + i]; b < offset[first + i + 1]; ++b)
        for (std::size_t j = 0; j < stride; ++j) a[j] += double(sh_of[std::size_t(order[b]) * stride + j]);
    }
    for (int l = 0; l < levels_; ++l) {
      const int size = r >> l;
      float* out = sums_.data() + sums_at_ + (std::size_t(face) * nodes_per_face_ + level_offset_[std::size_t(l)]) * stride;
      for (std::size_t i = 0; i < cur.size(); ++i) out[i] = float(cur[i]);
      if (l + 1 == levels_) {
        face_total[std::size_t(face)] = cur;
        break;
      }
      const int half = size / 2;
      next.assign(std::size_t(half) * half * stride, 0.0);
      for (int v = 0; v < size; ++v)
        for (int u = 0; u < size; ++u) {
          const double* src = cur.data() + (std::size_t(v) * size + std::size_t(u)) * stride;
          double* dst = next.data() + (std::size_t(v / 2) * half + std::size_t(u / 2)) * stride;
          for (std::size_t j = 0; j < stride; ++j) dst[j] += src[j];
        }
      cur.swap(next);
    }
  });
  total_padded_.assign(stride, 0.0f);
  for (std::size_t j = 0; j < stride; ++j) {
    double sum = 0;
    for (int face = 0; face < 6; ++face) sum += face_total[std::size_t(face)][j];
    total_padded_[j] = float(sum);
  }
  for (int k = 0; k < nc_; ++k)
    for (int c = 0; c < 3; ++c) total_[std::size_t(k)][c] = total_padded_[std::size_t(k) * 3 + std::size_t(c)];
  if (!bounce_sh_.empty()) {
    bounce_rot_.resize(bounce_sh_.size());
    sh::Rotation(t_.bounce_bands, R).apply(bounce_sh_, bounce_rot_);
  }
}

std::span<const glm::vec3> ProbeRelighter::sky() const { return total_; }

// Probes [begin, end) (of `probes` when given, else all), their SH to out.
// Compiled for AVX2 and for the baseline; the CPU picks at load time.
__attribute__((target_clones("avx2", "default")))
void ProbeRelighter::relight_range(std::size_t begin, std::size_t end, const std::uint32_t* probes, glm::vec3* out) const {
  const ProbeSums c{&t_, sums_.data() + sums_at_, total_padded_.data(), cell_slot_.data(), cell_sums_.data(), stride_, nodes_per_face_,
                    std::size_t(t_.cube_res)};
  const int nb = t_.bounce.empty() ? 0 : sh::num_coeffs(t_.bounce_bands);
  alignas(32) float sh[8 * 8 * 3 + 8];
  for (std::size_t i = begin; i < end; ++i) {
    const std::size_t probe = probes ? probes[i] : i;
    glm::vec3* o = out + i * std::size_t(nc_);
    const ProbeState st = t_.state[probe];
    if (st == ProbeState::Invalid) {
      std::fill(o, o + nc_, glm::vec3(0.0f));
      continue;
    }
    if (st == ProbeState::Sky) {
      std::copy(total_.begin(), total_.end(), o);
      continue;
    }
    const std::size_t s = slot_[probe];
    if (stride_ == 32) {  // 3 bands
      Lanes<4> acc{}, part{};
      probe_sums(c, s, acc, part, sh);
    } else {
      AnyLanes acc{stride_}, part{stride_};
      probe_sums(c, s, acc, part, sh);
    }
    for (int k = 0; k < nc_; ++k)
      for (int ch = 0; ch < 3; ++ch) o[k][ch] = sh[std::size_t(k) * 3 + std::size_t(ch)];
    if (nb > 0) {
      const float* B = t_.bounce.data() + s * t_.bounce_floats_per_probe();
      for (int ch = 0; ch < 3; ++ch) {
        const float* Bc = B + (t_.channels == 1 ? 0 : std::size_t(ch) * std::size_t(nc_) * std::size_t(nb));
        for (int k = 0; k < nc_; ++k) {
          double v = 0;
          const float* row = Bc + std::size_t(k) * std::size_t(nb);
          for (int j = 0; j < nb; ++j) v += double(row[j]) * bounce_rot_[std::size_t(j)][ch];
          o[k][ch] += float(v);
        }
      }
    }
  }
}

void ProbeRelighter::relight(std::vector<glm::vec3>& out) const {
  const std::size_t P = t_.probes();
  out.resize(P * std::size_t(nc_));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, P, 256), [&](const tbb::blocked_range<std::size_t>& range) {
    relight_range(range.begin(), range.end(), nullptr, out.data());
  });
}

void ProbeRelighter::relight(std::span<const std::uint32_t> probes, std::vector<glm::vec3>& out) const {
  out.resize(probes.size() * std::size_t(nc_));
  for (std::uint32_t p : probes)
    if (p >= t_.probes()) throw Error(fmt::format("probe {} of {}", p, t_.probes()));
  relight_range(0, probes.size(), probes.data(), out.data());
}

}  // namespace prt
