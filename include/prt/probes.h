// prt/probes.h - relightable probe volumes (docs/PROBES.md): points on a
// regular grid over a scene whose incident light follows the environment.
// Traced by prt::compute_probe_transfer (prt/precompute.h), by Embree on the
// CPU or, with ProbeOptions::tracer (a prt/point_tracer.h PointTracer: the
// GL compute tracer of prt/gpu_tracer.h), on the GPU: the same rays, drawn
// and summed by the same code, a wavefront of a block of probes at a time.
//
// A probe at x stores what it takes to give, for any environment L, the
// n-band SH projection of its incident radiance
//   Li(x, w) = V(x, w) L(w)                        (shadowed)
//            + (1 - V(x, w)) Lo(hit(x, w), -w)     (interreflected: the
//              diffuse exit radiance of the surface the ray x -> w meets)
// without band-limiting the environment's side of the direct light:
//   * a visibility cube: 6 r^2 bits, texel i set when the ray from x through
//     its centre region escapes (the majority of the texel's rays); the
//     direct part of coefficient k is then sum_i V_i G_k(i) with
//     G_k(i) = sum over the map's pixels p that fall in texel i (after the
//     rotation) of Y_k(w_p) L_p omega_p, exact per map pixel, so a sun of
//     1e5 counts where it is and nowhere else. Relighting sums G over the
//     visible texels through a quadtree of each face (a full node adds its
//     pyramid sum), so its cost follows the visibility's edges, not 6 r^2;
//   * interreflected: the bounce part as a matrix from the environment's
//     first `bounce_bands` bands to the probe's n^2 coefficients, per
//     channel (one when the albedo is grey). The light that reaches the
//     surfaces goes through the band limit here (docs/PROBES.md measures
//     what that costs);
//   * depth moments (mean and mean square of the capped hit distance) on
//     an octahedral map, for the visibility-aware weights below (DDGI,
//     Majercik et al. 2019).
// Probes whose every ray escapes store nothing (their light is the whole
// map's projection); probes inside geometry (more than half their rays
// strike back faces) store nothing and get no weight.
//
// Query (p, n): the 8 probes of p's cell, weight trilinear x validity x a
// Chebyshev visibility test of the segment probe -> p against the probe's
// depth moments (cubed, crushed below 0.2 as DDGI does), with p moved
// along n by a tenth of the smallest spacing; the weighted mean of their SH
// divided by max(sum of weights, kProbeMinWeight), so a point no probe can
// see (inside a closed box) gets (almost) nothing instead of the mean of
// probes that cannot see it. E(p, n)/pi = sum_k A_l/pi L_k Y_k(n) (A_l of
// prt/filter.h).
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/sun.h>  // kProbeBrightRatio, kProbeLocalRatio
#include <prt/transfer.h>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

struct ProbeGrid {
  std::array<int, 3> dims{2, 2, 2};  // NX, NY, NZ, each >= 2
  glm::dvec3 min{0.0}, max{1.0};     // the scene's bounding box: probe (0,0,0) at min, (NX-1,NY-1,NZ-1) at max

  std::size_t count() const { return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]); }
  // Probe (i, j, k) is entry i + NX (j + NY k).
  std::size_t index(int i, int j, int k) const {
    return std::size_t(i) + std::size_t(dims[0]) * (std::size_t(j) + std::size_t(dims[1]) * std::size_t(k));
  }
  // min + (max - min) (i/(NX-1), j/(NY-1), k/(NZ-1)).
  glm::dvec3 position(int i, int j, int k) const;
  glm::dvec3 spacing() const;  // (max - min) / (dims - 1)
};

inline constexpr int kMaxProbeDim = 1024;
// Diffuse bounces an interreflected volume traces (prt precompute --probes --bounces).
inline constexpr int kMaxProbeBounces = 8;
inline constexpr std::size_t kMaxProbes = std::size_t(1) << 24;
// The most environment bands a probe's SH transfer matrix takes
// (probe_sh_matrices; prt export --matrix-bands).
inline constexpr int kMaxProbeMatrixBands = 16;
// Below this total weight a query's light fades to 0 (docs/PROBES.md, "Leaks").
inline constexpr double kProbeMinWeight = 0.05;

// The one rule of a grid's dimensions: each of NX, NY, NZ from 2 to
// kMaxProbeDim, and NX x NY x NZ at most kMaxProbes. Empty when `dims` keep
// it, else what breaks it and the rule ("NX is 0; each of NX, NY, NZ must be
// 2 to 1024, and NX x NY x NZ at most 16777216"). parse_probe_dims,
// probe_grid and compute_probe_transfer refuse by it, before allocating.
std::string probe_dims_problem(const std::array<int, 3>& dims);
// "NXxNYxNZ" -> dims, each 2..kMaxProbeDim, at most kMaxProbes in all.
// Throws prt::Error with the rule.
std::array<int, 3> parse_probe_dims(std::string_view text);
// The grid over `mesh`'s bounding box (a flat box keeps its thickness 0:
// the probes of that axis coincide; precompute moves probes off surfaces).
// Throws prt::Error for dims that break probe_dims_problem's rule.
ProbeGrid probe_grid(const Mesh& mesh, const std::array<int, 3>& dims);

enum class ProbeState : std::uint8_t {
  Sky = 0,      // every ray escapes: stores nothing, its light is the map's
  Stored = 1,   // visibility, depth moments (and bounce matrices)
  Invalid = 2,  // inside geometry: stores nothing, weight 0
};

struct ProbeTransfer {
  ProbeGrid grid;
  int bands = 3;          // of each probe's output: its incident light's SH
  int cube_res = 64;      // visibility cube face size at its finest (power of two, 4..64)
  int depth_res = 8;      // octahedral depth map size (2..32)
  TransferMode mode = TransferMode::Shadowed;
  int bounces = 0;        // interreflected: diffuse bounces traced (>= 1)
  int bounce_bands = 0;   // interreflected: bands of the environment the bounce matrices take
  int channels = 1;       // of the bounce matrices: 3 when the albedo is not grey
  int rays_per_texel = 4; // rays per texel of the traced base cube (cube_res / 4): k^2, a k x k jittered grid
  std::uint64_t seed = 1;
  std::uint64_t scene_hash = 0;  // Scene::hash() of the scene it was computed for (0: a bare mesh's Mesh::hash)
  float depth_cap = 0;           // hit distances are capped here (1.5 x the largest spacing)

  std::vector<ProbeState> state;       // per probe
  std::vector<glm::vec3> positions;    // per probe: the grid point, moved off a surface it lies on
  // Per stored probe, in probe order:
  // The visibility cube as the quadtree nodes that are uniformly visible
  // (or, with vis_complement, uniformly blocked: the fewer), node ids of
  // probe_node_id; probe s's are [vis_offsets[s], vis_offsets[s + 1]).
  std::vector<std::uint16_t> vis_nodes;
  std::vector<std::uint64_t> vis_offsets;   // stored + 1, from 0
  std::vector<std::uint8_t> vis_complement; // per stored probe
  // Finest texels an edge crosses (left clear in the nodes above), each
  // with the 4 x 4 sub-texels whose ray escaped (bit 4 sy + sx, sx along
  // the face's u): probe s's are [partial_offsets[s], partial_offsets[s + 1]).
  std::vector<std::uint16_t> partial_nodes;
  std::vector<std::uint16_t> partial_mask;
  std::vector<std::uint64_t> partial_offsets;  // stored + 1, from 0
  std::vector<std::uint16_t> depth;       // 2 depth_res^2 each: mean, mean square / cap^2, unorm16
  std::vector<float> bounce;              // interreflected: channels x n^2 x bounce_bands^2 each, row-major

  std::size_t probes() const { return grid.count(); }
  std::size_t stored() const;  // probes in state Stored
  std::size_t bounce_floats_per_probe() const;
  // Bytes of the per-probe data (state, positions, and the stored arrays).
  std::size_t bytes() const;
  // Per probe: its index among the stored probes, or ~0u.
  std::vector<std::uint32_t> stored_slots() const;
};

// The quadtree of a visibility cube of face size r (a power of two up to
// 64): per face, level 0 the r x r texels, level L the (r >> L)^2 blocks,
// up to one node for the face; node (face, level, x, y) has id
// face * nodes_per_face + offset(level) + y (r >> level) + x, with
// offset(L) = sum_{l < L} (r >> l)^2 and nodes_per_face = (4 r^2 - 1) / 3
// (6 faces of r = 64: 32,766 ids, a u16).
std::uint16_t probe_node_id(int r, int face, int level, int x, int y);
// The nodes of a cube's bits (texel i = (face r + v) r + u, bit i % 32 of
// word i / 32) that are uniformly set, or with *complement the uniformly
// clear ones (whichever list is shorter): what ProbeTransfer stores.
std::vector<std::uint16_t> probe_visibility_nodes(std::span<const std::uint32_t> bits, int r, bool& complement);

// What is wrong with `t` (sizes, ranges, finite values, and each stored
// probe's quadtree: node and partial texel ids inside the cube, nodes
// disjoint, partial texels once each, masks of 1 to 15 sub-texels, in the
// cube's clear region; docs/FORMAT.md "Probe volume"), naming the probe, or
// "". Whatever passes is safe for every consumer (ProbeRelighter,
// probe_sh_matrices, probe_weights, the GPU pass). Linear in the arrays.
std::string probe_transfer_problem(const ProbeTransfer& t);

// Files (docs/FORMAT.md "Probe volume"; a section family of the transfer
// format, prt/transfer_file.h reads any kind): write through a temporary file
// and rename; read validates everything (checksum, sizes,
// probe_transfer_problem) and throws prt::Error naming the file.
void write_probe_transfer(const std::string& path, const ProbeTransfer& t);
ProbeTransfer read_probe_transfer(const std::string& path);

// Relighting (docs/PROBES.md "Relighting"). The constructor splits the
// map (downsampled once by solid-angle-weighted sums, to about 16 pixels
// across a visibility texel) into its bright pixels (radiance over
// kProbeBrightRatio times the map's mean and kProbeLocalRatio times the
// mean 4 texels around them, at most 1/64 of them, the brightest:
// prt/sun.h's bright_cells)
// and the rest, resampled into a smooth cube of face 2r.
// set_rotation() rebuilds the per-frame sums: each finest texel of the
// rotated visibility cube gets the smooth cube sampled (bilinear) at its
// four quarter-texel centres, exactly weighted, plus every bright pixel
// splatted exactly into its texel; then the pyramid of each face and the
// rotated bounce SH. relight() gives the probes' SH (n^2 RGB each), Sky
// probes the whole map's, Invalid ones zero.
class ProbeRelighter {
 public:
  // Throws prt::Error on a probe volume that is inconsistent or a map with
  // non-finite pixels.
  ProbeRelighter(const ProbeTransfer& t, const EnvMap& map);
  // Light from direction d arrives from R d (L_rot(d) = L(R^T d)), as prt relight --rotate.
  void set_rotation(const glm::dmat3& R);
  // SH of every probe's incident light: out[probe * n^2 + k]. Parallel.
  void relight(std::vector<glm::vec3>& out) const;
  // The same for the listed probes only: out[i * n^2 + k] for probes[i].
  void relight(std::span<const std::uint32_t> probes, std::vector<glm::vec3>& out) const;
  // The whole map's SH (what a Sky probe gets) under the current rotation.
  std::span<const glm::vec3> sky() const;
  const ProbeTransfer& transfer() const { return t_; }
  // How many of the map's pixels are relit exactly as bright ones.
  std::size_t bright_pixels() const { return bright_.size(); }

 private:
  void relight_range(std::size_t begin, std::size_t end, const std::uint32_t* probes, glm::vec3* out) const;
  const ProbeTransfer& t_;
  int nc_ = 0, levels_ = 0;
  std::size_t stride_ = 0;  // floats per node: nc x 3 padded to a multiple of 8
  std::size_t nodes_per_face_ = 0;
  std::vector<std::size_t> level_offset_;
  // The map, downsampled: directions, solid angle x radiance; the bright ones' indices.
  std::vector<glm::vec3> dirs_;
  std::vector<glm::vec3> power_;
  std::vector<std::uint32_t> bright_;
  // The rest as radiance on a cube of face 2r (map frame), and the world
  // directions and Y_k omega of the 2r cube's texel centres (the finest
  // texels' quarters).
  std::vector<glm::vec3> smooth_;
  std::vector<glm::vec3> quarter_dir_;
  std::vector<float> quarter_y_;
  std::vector<glm::dvec3> bounce_sh_, bounce_rot_;
  std::vector<float> sums_;     // nodes x stride, from sums_at_ (64-byte aligned)
  std::size_t sums_at_ = 0;
  std::vector<float> smooth0_;  // finest texels x stride: their smooth part alone
  std::vector<glm::vec3> total_;
  std::vector<float> total_padded_;  // the same, stride floats
  std::vector<std::uint32_t> slot_;
  // Per frame, the finest texels that hold bright pixels: their slot (-1:
  // none) and per slot the sums of their 16 sub-texels (stride each).
  std::vector<std::int32_t> cell_slot_;
  std::vector<float> cell_sums_;
};

// Each probe's transfer as an SH matrix, for engines that light probes
// from SH lighting (Far Cry 3's relightable probes): out_k = sum_j
// M[c][k][j] L_j(c) with L the map's first `in_bands` bands (prt's
// convention), M = sum over the visible texels of Y_k Y_j omega (the edge
// texels by their visible sub-texels' share) plus the bounce matrix
// (interreflected; its bands cut or padded to in_bands). Per probe
// channels x n^2 x in_bands^2 floats (channels: t.channels when
// interreflected, else 1), every probe (sky ones: the SH product's
// identity block; invalid ones: zero). The band limit of L is what the
// visibility cube avoids: docs/PROBES.md measures what it costs.
std::vector<float> probe_sh_matrices(const ProbeTransfer& t, int in_bands, int& channels);
// The binary file of probe_sh_matrices (docs/FORMAT.md "Probe matrices"),
// written through a temporary file.
void write_probe_matrices(const std::string& path, const ProbeTransfer& t, const std::vector<float>& matrices,
                          int in_bands, int channels);

// The engines' JSON of prt export --probes (docs/PROBES.md "Export"): every
// probe of `t` (3 bands: throws prt::Error otherwise) relit under `map`
// turned by rotation_from_euler(rotate) (yaw, pitch, roll degrees), as
// three.js LightProbe and Unity SphericalHarmonicsL2 coefficients with its
// position in both engines' axes and its state, and the grid; the names
// are recorded as given. The text ends in a newline.
struct ProbeExportNames {
  std::string scene, probes_file, map, generator;
};
std::string probe_engine_json(const ProbeTransfer& t, const EnvMap& map, const std::array<double, 3>& rotate,
                              const ProbeExportNames& names);

// Weights of the probes that light a query at p with normal n (see above):
// up to 8 (probe, weight) pairs, weights already divided by
// max(sum, kProbeMinWeight).
struct ProbeWeights {
  std::array<std::uint32_t, 8> probe{};
  std::array<float, 8> weight{};
  int count = 0;
};
// `slots`: t.stored_slots() (computed once for many queries). `visible`,
// when set, replaces the depth moments' Chebyshev test: the visibility
// (0..1) between a probe's position and the query point, traced (prt
// precompute's ProbeOcclusion: what prt relight --at uses).
using ProbeVisibility = std::function<double(const glm::dvec3& probe, const glm::dvec3& point)>;
ProbeWeights probe_weights(const ProbeTransfer& t, std::span<const std::uint32_t> slots, const glm::dvec3& p,
                           const glm::dvec3& n, const ProbeVisibility& visible = {});
// Plain trilinear weights (no visibility): the baseline of docs/PROBES.md.
ProbeWeights trilinear_weights(const ProbeGrid& g, const glm::dvec3& p);

// E(p, n)/pi of the SH radiance `sh` (bands^2 RGB): the radiance a white
// Lambertian surface facing n reflects.
glm::dvec3 lambert_from_sh(std::span<const glm::vec3> sh, int bands, const glm::dvec3& n);

// The Chebyshev visibility of a point at `distance` in direction `dir` from
// probe slot `slot` (stored probes only): 1 when nearer than the mean
// depth there, else sigma^2 / (sigma^2 + (d - mean)^2), cubed and crushed
// below 0.2. Bilinear over the octahedral map (continuous everywhere).
double probe_visibility(const ProbeTransfer& t, std::size_t slot, const glm::dvec3& dir, double distance);

// Octahedral mapping of a unit direction to [0, 1]^2 and back (docs/CONVENTIONS.md).
glm::dvec2 octahedral_encode(const glm::dvec3& d);
glm::dvec3 octahedral_decode(const glm::dvec2& uv);

}  // namespace prt
