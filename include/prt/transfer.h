// prt/transfer.h - per-vertex SH radiance transfer (Sloan, Kautz & Snyder 2002).
//
// For a vertex with normal n and albedo rho, the transfer vector T maps
// lighting coefficients L_k (docs/CONVENTIONS.md) to outgoing radiance:
//   B = sum_k T_k L_k,  T_k = (rho/pi) integral V(w) max(n.w, 0) Y_k(w) dw  (shadowed)
// so a white (rho = 1) surface under constant radiance 1, unshadowed, gives
// exactly B = 1. Interreflected adds the diffuse bounces between the mesh's
// surfaces (see docs/PRECOMPUTE.md).
#pragma once

#include <prt/light_bounce.h>
#include <prt/mesh.h>
#include <prt/subsurface.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

enum class TransferMode : std::uint32_t { Unshadowed = 0, Shadowed = 1, Interreflected = 2 };
TransferMode parse_transfer_mode(std::string_view name);  // "unshadowed", "shadowed", "interreflected"
std::string_view transfer_mode_name(TransferMode m);

// What every per-point transfer records of how it was computed: the file
// header's values (docs/FORMAT.md), shared by Transfer and ZhTransfer (and so
// by the compressed and lightmap kinds, which hold a Transfer). One struct,
// so that a kind made from another copies it whole (header() = other.header()).
struct TransferHeader {
  int bands = 0;
  int channels = 1;
  TransferMode mode = TransferMode::Shadowed;
  int bounces = 0;               // computed (at most TransferOptions::bounces)
  int samples = 0;
  glm::vec3 albedo{1.0f};
  bool vertex_colors = false;
  std::uint64_t seed = 0;
  std::size_t vertices = 0;
  std::uint64_t mesh_hash = 0;
  // A translucent material's transfer (prt/subsurface_scatter.h): what it
  // was computed from. Empty for every other transfer.
  std::optional<SubsurfaceRecord> subsurface;

  TransferHeader& header() { return *this; }
  const TransferHeader& header() const { return *this; }
};

// Which row of a kind's stored arrays holds vertex v (analytic vertices,
// below, store none): shared by Transfer and ZhTransfer.
// slots[v]: the row of vertex v, or kAnalytic. Empty: every vertex is
// stored, vertex v in row v (no analytic vertex).
struct RowSlots {
  static constexpr std::uint32_t kAnalytic = 0xffffffffu;
  std::vector<std::uint32_t> slots;

  bool is_analytic(std::size_t v) const { return !slots.empty() && slots[v] == kAnalytic; }
  // The row of vertex v, or kAnalytic.
  std::size_t row(std::size_t v) const { return slots.empty() ? v : slots[v]; }
  std::size_t analytic_vertices() const;  // counted over slots
};

// Per-vertex results. Layout of a transfer array: [row][channel][k] with
// k < bands^2, channels 1 (grey albedo: one channel serves R, G and B) or 3,
// one row per *stored* vertex, in vertex order.
//
// Analytic vertices (docs/PRECOMPUTE.md, "Analytic vertices"): a vertex with
// a normal none of whose rays hit anything has exactly the unshadowed
// transfer (rho/pi) A_l Y_lm(n): the shadowed form's occluded sum is empty,
// and interreflection gathers nothing into it (it sees no surface). Such a
// vertex stores no coefficients; relight() and the renderer evaluate the
// clamped cosine about the mesh's normal, with the albedo compute_transfer
// used (vertex_albedo). In an unshadowed transfer every vertex with a normal
// is analytic, so nothing is stored but for vertices without one (transfer 0).
// The rows a directional lightmap keeps of each texel's matrix (L1: k = 0..3).
inline constexpr int kDirectionalRows = 4;

struct Transfer : TransferHeader, RowSlots {
  // shading_hash(mesh, vertex_colors) of the mesh the transfer was computed
  // for: analytic vertices take their normal and albedo from the mesh, which
  // mesh_hash (positions, triangles) does not cover. 0: not recorded (files
  // of format version 1, which have no analytic vertices).
  std::uint64_t shading_hash = 0;

  std::vector<float> coeffs;         // stored rows: the transfer of `mode` (interreflected: direct + all bounces)
  std::vector<float> direct;         // interreflected only: the shadowed (0-bounce) part, same rows
  std::vector<float> ao;             // kappa_A = (1/pi) integral V max(n.w,0) dw, per vertex (1 if unshadowed)
  std::vector<glm::vec3> bent_normals;  // normalised cosine-weighted mean unoccluded direction, per vertex
  std::vector<double> bounce_energy;    // mean |T| added by each bounce (diagnostics)

  // Glossy transfer matrices (docs/CONVENTIONS.md, "Glossy transfer"), when
  // `glossy`: M_p maps the lighting L (bands^2 per colour) to the transferred
  // incident radiance L'_p = M_p L. One row per stored vertex, the rows of
  // coeffs (an analytic vertex sees no surface, so its M_p is the hemisphere
  // product matrix of its normal, prt/glossy.h, and is not stored).
  //  - shadowed: M_p[i][j] = Int Y_i V_p Y_j ds, symmetric and colourless:
  //    one channel, rows i = 0..nc-1 from column i on (nc (nc + 1) / 2 floats);
  //  - interreflected: plus the light the hit points' diffuse transfer sends
  //    (albedo: one matrix per channel), not symmetric: nc x nc row-major per
  //    channel.
  // Unshadowed transfers have none (every M_p is the hemisphere's).
  bool glossy = false;
  std::vector<float> glossy_matrices;
  // The matrices' rows: 0 for all nc (a vertex's glossy transfer); 4
  // (kDirectionalRows) for a directional lightmap, whose texels keep only
  // rows k = 0..3 of M_p, the L1 of their incident radiance
  // (prt/lightmap_directional.h), every row nc long (not symmetric).
  int glossy_rows = 0;
  int glossy_channels() const { return mode == TransferMode::Interreflected ? channels : 1; }
  bool glossy_symmetric() const { return mode != TransferMode::Interreflected && glossy_rows == 0; }
  std::size_t glossy_row_count() const { return glossy_rows ? std::size_t(glossy_rows) : std::size_t(bands) * bands; }
  std::size_t glossy_stride() const {
    const std::size_t nc = std::size_t(bands) * bands;
    return std::size_t(glossy_channels()) * (glossy_symmetric() ? nc * (nc + 1) / 2 : glossy_row_count() * nc);
  }
  double direct_energy = 0;             // interreflected: mean |T| of the direct part (not stored in files)

  // Adaptive sample points (docs/PRECOMPUTE.md, "Adaptive sample points"):
  // interpolated[v] is 1 where vertex v's transfer (and glossy matrices,
  // ambient occlusion, bent normal) was interpolated from traced vertices
  // around it instead of traced, 0 where it was traced. Empty: every vertex
  // traced (any transfer not computed adaptively). Stored in the file as the
  // 'interpolated vertices' bit mask (docs/FORMAT.md).
  std::vector<std::uint8_t> interpolated;
  std::size_t interpolated_vertices() const;  // counted over `interpolated`

  // Interreflected transfers computed with --light-bounce (prt/light_bounce.h,
  // docs/LIGHTS.md "Bounce"): the gather kept as the operator that bounces
  // the lights' direct light, a row per vertex (texel). Empty otherwise.
  LightBounce light_bounce;

  std::size_t stride() const { return std::size_t(channels) * bands * bands; }
  std::size_t stored_vertices() const { return vertices - analytic_vertices(); }
  // The accessor every consumer uses: the stored transfer of vertex v
  // (stride() floats, [channel][k]), or nullptr when v is analytic (then it
  // is analytic_transfer() of the mesh's normal and vertex_albedo()).
  const float* stored(std::size_t v) const { return row_of(coeffs, v); }
  // The same for the direct part (interreflected transfers that keep it).
  const float* stored_direct(std::size_t v) const { return row_of(direct, v); }
  // Vertex v's stored glossy matrices (glossy_stride() floats), or nullptr
  // when v is analytic or the transfer has none.
  const float* stored_glossy(std::size_t v) const {
    const std::size_t r = row(v);
    return !glossy || r == kAnalytic ? nullptr : glossy_matrices.data() + r * glossy_stride();
  }

 private:
  const float* row_of(const std::vector<float>& a, std::size_t v) const {
    const std::size_t r = row(v);
    return r == kAnalytic ? nullptr : a.data() + r * stride();
  }
};

// The albedo of every transfer, per channel: [kMinAlbedo, kMaxAlbedo] = [0, 1]
// (energy conservation). compute_transfer and compute_wavelet_transfer
// refuse others, and transfer_problem finds them.
inline constexpr float kMinAlbedo = 0.0f, kMaxAlbedo = 1.0f;
inline bool albedo_in_range(const glm::vec3& a) {
  for (int c = 0; c < 3; ++c)
    if (!(a[c] >= kMinAlbedo && a[c] <= kMaxAlbedo)) return false;  // NaN too
  return true;
}

// The one consistency check of a transfer's data, used by write_transfer,
// read_transfer and the renderer: what is wrong with `t`, or "" when nothing
// is. bands 1 to 64, channels 1 or 3, a known mode, bounces and samples >= 0,
// albedo in range, at least one vertex; slots empty or one per vertex,
// numbering the stored vertices' rows 0, 1, 2, ... in vertex order;
// coefficients one row (stride() floats) per stored vertex; direct absent or
// the same size, and only in an interreflected transfer; ambient occlusion
// and bent normals absent or one per vertex; interpolated absent or one flag
// of 0 or 1 per vertex; bounce energy absent or 1 to bounces values; a
// subsurface record only on a three-channel transfer that is not glossy,
// its material and length scale valid; every value finite. Whether `t`
// fits a mesh is check_matches' (prt/transfer_io.h).
std::string transfer_problem(const Transfer& t);

// The unshadowed (clamped-cosine) transfer of a vertex with normal n and
// albedo rho: out[c bands^2 + k] = (rho_c / pi) A_l Y_lm(n) for c < channels
// (rho.x alone when channels is 1); 0 for a zero normal. In double: what
// relight() uses for analytic vertices.
void analytic_transfer(int bands, int channels, const glm::vec3& normal, const glm::vec3& albedo, double* out);

// The albedo compute_transfer used at vertex v of `mesh`: its colour clamped
// to [0, 1] when t.vertex_colors, t.albedo otherwise.
glm::vec3 vertex_albedo(const Transfer& t, const Mesh& mesh, std::size_t v);

// The transfer of vertex v whatever its kind (stride() values): the stored
// row, or the analytic one from `mesh`. `direct`: the direct part (the same
// for analytic vertices). For tests and tools; relight() does not copy.
std::vector<double> vertex_transfer(const Transfer& t, const Mesh& mesh, std::size_t v, bool direct = false);

// XXH3-64 (seed 0) of the mesh's normals (V x f32 x, y, z) followed, when
// vertex_colors, by its colours (V x f32 r, g, b): what analytic vertices
// are shaded from (Transfer::shading_hash).
std::uint64_t shading_hash(const Mesh& mesh, bool vertex_colors);

// The whole array with one row per vertex (row v = vertex v), analytic rows
// evaluated from `mesh` and rounded to float: the layout of a transfer with no
// analytic vertex. `direct`: of the direct part (the transfer itself when it
// keeps none).
std::vector<float> dense_transfer(const Transfer& t, const Mesh& mesh, bool direct = false);

// Marks vertices analytic (slots; see Transfer) and drops their rows from
// coeffs and direct (in place: the arrays keep their capacity, so that the
// rows are never held twice). `analytic` has one entry per vertex (non-zero:
// analytic). compute_transfer does this itself; for tests and tools.
void compact_transfer(Transfer& t, const std::vector<std::uint8_t>& analytic);

// Outgoing radiance of every vertex under lighting coefficients `light`
// (RGB, bands^2 or more; extra bands are ignored): RGB per vertex. `mesh` is
// the mesh t was computed for (check_matches): analytic vertices take their
// normal and albedo from it, evaluated exactly in double.
std::vector<glm::vec3> relight(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light);
// The same from the `direct` (shadowed) part of an interreflected transfer
// (the transfer itself when it keeps no direct part).
std::vector<glm::vec3> relight_direct(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light);

// ---- glossy shading (docs/CONVENTIONS.md, "Glossy transfer") ----

// Vertex v's glossy transfer matrix of channel c (< glossy_channels()), nc x
// nc row-major in double: its stored one unpacked, or for an analytic vertex
// the hemisphere product matrix of the mesh's normal (zero without a normal).
// Throws prt::Error when t has no glossy matrices.
std::vector<double> vertex_glossy_matrix(const Transfer& t, const Mesh& mesh, std::size_t v, int c = 0);

// What a glossy shading needs beyond the lighting: the eye point, the Phong
// exponent e >= 0, the specular strength rho_s >= 0, and the diffuse
// albedo rho_d (per channel; negative: the transfer's own albedo). A
// different rho_d scales the diffuse transfer by rho_d / albedo, which is
// exact for unshadowed and shadowed transfers; an interreflected transfer's
// bounces were computed with its albedo, so it takes only that, or 0.
struct GlossyShading {
  glm::dvec3 eye{0.0, 0.0, 3.0};
  double gloss = 16.0;
  double specular = 0.5;
  glm::dvec3 diffuse{-1.0};
};
// The problem with `s` for `t` (or ""): finite eye, e and rho_s in range,
// rho_d in [0, 1] or the transfer's own, and glossy matrices present.
std::string glossy_shading_problem(const Transfer& t, const GlossyShading& s);
// The factor per channel the diffuse part is scaled by: rho_d / albedo (1
// for the transfer's own albedo, 0 for rho_d = 0). For a valid shading.
glm::dvec3 glossy_diffuse_scale(const Transfer& t, const GlossyShading& s);

// L_o of every vertex toward the eye (RGB): diffuse rho_d/pi Int L V cos+ (the
// transfer's coefficients, scaled as above) plus rho_s sum_lm Lambda_l(e)
// (M_p L)_lm Y_lm(r), r the eye's mirror direction about the vertex normal
// (docs/CONVENTIONS.md). A vertex the eye sees from below its horizon
// (n.v <= 0) gets its diffuse part only. Throws prt::Error on a bad shading.
std::vector<glm::vec3> relight_glossy(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light,
                                      const GlossyShading& shading);

}  // namespace prt
