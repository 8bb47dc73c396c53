// The bounce of lights inside a scene (docs/LIGHTS.md "Bounce"): the gather
// of prt's interreflected pass kept as an operator from the light that
// leaves the scene's surfaces to the light it sends on, applied every frame
// to the lights' direct light.
//
// The interreflected pass traces, from every point (a lightmap's texel, a
// mesh's vertex), rays whose front hits make a row of the gather matrix G:
// sum_j G_ij L_j is the irradiance at point i from the radiance L_j leaving
// the points around the hits (bilinear in the lightmap, barycentric on a
// mesh), each bounce of the sky's transfer being (rho_i / pi) G applied to
// the one before (precompute/transfer.cpp). The operator keeps G with its
// columns merged into source patches, as hierarchical radiosity links a
// receiver to patches as coarse as their distance allows: the patches are
// the cells of nested grids (cell size s, 2s, 4s, ...; each cell's points of
// one dominant normal direction), and an entry of G whose emitting point
// lies at distance d from the receiver goes to the coarsest patch whose cell
// is at most ratio x d (TransferOptions::light_bounce_ratio). A patch's
// radiance is the mean of its points'. A row then holds one weight per patch
// its rays reached, and the bounces are applied at run time:
//   L_0 = the lights' direct radiance at the points,
//   L_k(i) = (rho_i / pi) sum_p W_ip mean_{j in p} L_{k-1}(j),  k = 1..B,
//   indirect = L_1 + ... + L_B.
#pragma once

#include <glm/vec3.hpp>

#include <array>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace prt {

// The most bounces an operator applies: prt::kMaxBounces (prt/precompute.h,
// which pins the two equal).
inline constexpr int kMaxLightBounces = 64;
// The most levels of source patches (cells doubling from the finest: 2^31
// times its size spans any scene prt takes).
inline constexpr int kMaxPatchLevels = 32;

struct LightBounce {
  int bounces = 0;                      // B, applied at run time; 0: no operator
  static constexpr std::uint32_t kNoParent = 0xffffffffu;
  std::uint32_t patches = 0;            // source patches, of every level
  std::vector<std::uint32_t> patch;     // per point: its patch of the finest level (< patches)
  std::vector<std::uint32_t> parent;    // per patch: the patch of the next level holding it (> itself), or kNoParent
  std::vector<std::uint32_t> offsets;   // points + 1: point i's entries are [offsets[i], offsets[i + 1])
  std::vector<std::uint32_t> source;    // per entry: a source patch, increasing within a row
  std::vector<float> weight;            // per entry: W_ip, sum over i's rays landing in p of (pi / sum cos) w cos b,
                                        // a half-precision value (files store 16 bits)
  // Links whose receiving end is a patch (link_clusters): per patch q a row
  // of (source, weight) like a point's, gathered once for all q's points;
  // a point's bounce is its own row's plus the rows of every patch holding
  // it. Empty (no offsets): none.
  std::vector<std::uint32_t> cluster_offsets;  // patches + 1, or empty
  std::vector<std::uint32_t> cluster_source;   // per cluster entry, increasing within a row
  std::vector<float> cluster_weight;           // per cluster entry, a half-precision value

  // Receivers at a probe volume's probes (prt precompute --lightmap WxH
  // --light-bounce --probes NXxNYxNZ): per probe a row of (source patch,
  // bands^2 SH weights) giving the SH of the lights' light arriving at the
  // probe from the scene's surfaces,
  //   c_k = sum_e W_ek mean_{j in p_e} L(j),
  // L the lights' radiance leaving the points (their direct light and its
  // B bounces: the surfaces as drawn), W_ek the sum over the probe's rays
  // whose front hit lands in patch p_e (a hit's share of each point around
  // it, the patch as coarse as the hit's distance allows, as for the points'
  // rows) of (4 pi / rays) Y_k(w). The grid is prt::probe_grid(scene mesh,
  // dims) (probe (i, j, k) is row i + NX (j + NY k)), its points moved off
  // surfaces as prt::compute_probe_transfer moves them: a probe volume of
  // the same grid takes these rows (prt render --probes --object).
  struct ProbeRows {
    std::array<int, 3> dims{0, 0, 0};  // 0 0 0: no probe rows
    glm::dvec3 min{0.0}, max{0.0};     // the grid's box (prt::ProbeGrid)
    int bands = 0;                     // of each probe's SH (3: 9 coefficients)
    std::vector<std::uint32_t> offsets;  // probes + 1: probe q's entries are [offsets[q], offsets[q + 1])
    std::vector<std::uint32_t> source;   // per entry: a source patch, increasing within a row
    std::vector<float> weight;           // per entry bands^2 values (W_e0 .. W_e(n^2-1)), half-precision values
    bool empty() const { return offsets.empty(); }
    std::size_t probes() const { return empty() ? 0 : offsets.size() - 1; }
    std::size_t entries() const { return source.size(); }
    // Bytes of its arrays as a file stores them (u32 offsets and sources,
    // f16 weights).
    std::size_t bytes() const { return 4 * offsets.size() + 4 * source.size() + 2 * weight.size(); }
  };
  ProbeRows probes;

  bool empty() const { return bounces == 0; }
  std::size_t points() const { return patch.size(); }
  std::size_t entries() const { return source.size() + cluster_source.size(); }
  // Bytes of the operator's arrays (as stored in a transfer file), its probe
  // rows' included.
  std::size_t bytes() const;
};

// What is wrong with `b` for `points` points, or "" when nothing is: 1 to
// kMaxLightBounces bounces, one patch per point below `patches`, one parent
// per patch above it (or none), every patch holding a point, offsets from 0
// increasing to entries(), sources increasing within a row and below
// `patches`, weights finite, >= 0 and half-precision values; probe rows (when
// there are any) for a grid of 2 to kMaxProbeDim a side (prt/probes.h's
// rule) with a finite box, 1 to 8 bands, one row per probe of the same
// kind, their weights finite half-precision values of either sign. An empty
// operator (0 bounces, no arrays) is fine.
std::string light_bounce_problem(const LightBounce& b, std::size_t points);

// Hierarchical radiosity's links at both ends (Hanrahan, Salzman & Aupperle
// 1991): every entry of a point's row whose source patch lies `offset` + 1
// or more levels above the finest moves to the row of the point's patch
// `offset` levels below that source's (the receiver's cluster then no finer
// than the source, less `offset` levels), its weight divided by the
// cluster's points, so that the cluster's points share the row's mean. Far
// light, which neighbours receive alike, is then gathered once per cluster:
// fewer entries to store and to apply, at the cost of the differences
// between neighbours' views of far patches. The result's weights are
// rounded to half precision; when no entry moves, it has no cluster rows.
LightBounce link_clusters(const LightBounce& b, int offset);

// The indirect radiance at every point, bounces 1..B of `direct` (the
// radiance leaving each point: the lights' direct light), with each point's
// diffuse albedo (one per point). Accumulated in double. Throws prt::Error
// for sizes other than b.points().
std::vector<glm::vec3> light_bounce(const LightBounce& b, std::span<const glm::vec3> direct,
                                    std::span<const glm::vec3> albedo);

// The probes' SH of the lights' light (see ProbeRows): per probe bands^2 RGB
// coefficients, out[q * n^2 + k], from `leaving`, the lights' radiance
// leaving every point (their direct light plus light_bounce's). Accumulated
// in double. Throws prt::Error for sizes other than b.points() or an
// operator without probe rows.
std::vector<glm::vec3> light_bounce_at_probes(const LightBounce& b, std::span<const glm::vec3> leaving);

}  // namespace prt
