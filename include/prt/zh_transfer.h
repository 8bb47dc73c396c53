// prt/zh_transfer.h - local, deformable PRT (Sloan, Luna & Snyder,
// SIGGRAPH 2005): each vertex's transfer as a few zonal-harmonic lobes
// (prt/zh.h) whose axes are stored in the vertex's own frame, so that the
// transfer turns with the surface when the mesh deforms (docs/LDPRT.md).
//
// The vertex frame (docs/CONVENTIONS.md, "Vertex frames"): columns tangent,
// bitangent, normal, right-handed (bitangent = normal x tangent). The
// tangent is set at rest, where the mesh has texture coordinates, by the UV
// tangent (the direction of increasing u, averaged over the vertex's
// triangles), else by the edge rule (the first edge of the vertex, triangles
// in file order, next corner then previous, not along the normal). Either
// is kept as a TangentRule: a combination of the vertex's edges to one or two
// neighbours, which a pose evaluates on its own positions, so the frame moves
// with the surface (a rigid motion turns it with the mesh; the UV tangent is
// carried exactly by any deformation affine over the rule's triangle). A
// vertex with a zero normal (only degenerate triangles, or none) has no
// frame; a vertex with a normal but no usable edge gets one from its normal
// alone (FrameKind::Normal, Duff et al. 2017's basis: it follows the normal,
// not the turn about it).
#pragma once

#include <prt/dynamic_ao.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace prt {

// The smallest share of a tangent combination's length that must lie in the
// tangent plane for it to set the tangent: below it the combination runs
// nearly along the normal and its projection's direction is noise (1e-3:
// within 0.06 degrees of the normal). Also the smallest |sin| of the angle
// between a UV rule's two projected edges.
inline constexpr double kFrameEdgeMin = 1e-3;

// The least agreement of a vertex's per-triangle UV tangents for the UV
// tangent to be used: |sum_f w_f t_f| / sum_f w_f, t_f the unit tangents in
// the vertex's tangent plane, w_f the corner angles. At a mirrored UV seam
// the two sides' tangents cancel (agreement near 0) and the average is
// noise; 0.5 keeps any vertex whose tangents spread less than about +-60
// degrees, and such vertices take the edge rule.
inline constexpr double kUvTangentAgreement = 0.5;

enum class FrameKind : std::uint8_t { None = 0, Edge = 1, Normal = 2, Uv = 3 };

// How vertex v's tangent is found in any pose: the part of
// wa (p_a - p_v) + wb (p_b - p_v) perpendicular to v's normal. The edge rule
// is (a = b = the neighbour, wa = 1, wb = 0); a UV tangent uses a triangle's
// other two corners (a != b); a = b = v (weights 0) is no tangent, the frame of
// the normal alone. Set at rest by vertex_frames, stored in the file.
struct TangentRule {
  std::uint32_t a = 0, b = 0;
  float wa = 0, wb = 0;
  bool operator==(const TangentRule&) const = default;
};
// The kind a rule gives vertex v where its tangent is usable.
FrameKind rule_kind(const TangentRule& r, std::uint32_t v);

struct VertexFrames {
  std::vector<glm::mat3> frames;  // columns tangent, bitangent, normal; identity where kind is None
  std::vector<FrameKind> kinds;
  std::vector<TangentRule> rules;  // every vertex's (vertex_frames), or the rules a pose was given
};
// Every vertex's rest frame and tangent rule (the rules above) from the
// mesh's positions, triangles, normals and corner_uvs.
VertexFrames vertex_frames(const Mesh& mesh);
// The frames of a pose from rest rules (one per vertex, indices in range:
// zh_transfer_problem): a rule whose posed combination is zero or along the
// normal gives the frame of the normal alone; a zero normal, no frame.
VertexFrames posed_frames(const Mesh& posed, const std::vector<TangentRule>& rules);

// XXH3-64 of the vertex count (u64) and the triangles (u32 triples): what a
// posed mesh must share with the rest pose.
std::uint64_t topology_hash(const Mesh& mesh);

// A local deformable transfer. Rows as prt::Transfer's: one per stored
// vertex in vertex order (slots; analytic vertices store nothing and are the
// clamped cosine about the posed normal, which one lobe holds exactly).
// The header (bands: n, 1 to zh::kMaxBands; channels 1 or 3; mesh_hash:
// Mesh::hash() of the rest pose) and slots are prt::Transfer's.
struct ZhTransfer : TransferHeader, RowSlots {
  int lobes = 0;                    // K, 1 to zh::kMaxLobes
  std::uint64_t topology_hash = 0;  // topology_hash() of the rest pose
  // Relative error of the fit over the stored rows, sqrt(sum |t - t~|^2 /
  // sum |t|^2) in the SH transfer's space (diagnostic; stored in the file).
  double fit_error = 0;

  // Per stored row: lobes x 3 unit axes in the vertex's rest frame (x
  // tangent, y bitangent, z normal), shared by the channels.
  std::vector<float> axes;
  // Per stored row: channels x lobes x bands coefficients g_il ([c][i][l]).
  std::vector<float> coeffs;
  std::vector<float> rest_ao;  // dynamic_ao() of the rest pose, per vertex, or empty (prt/dynamic_ao.h)
  // Every vertex's tangent rule, from the rest pose (vertex_frames): what
  // posing evaluates on the posed positions.
  std::vector<TangentRule> tangents;

  std::size_t axes_stride() const { return std::size_t(lobes) * 3; }
  std::size_t coeffs_stride() const { return std::size_t(channels) * lobes * bands; }
  std::size_t stride() const { return axes_stride() + coeffs_stride(); }  // floats per stored row
  std::size_t stored_vertices() const { return vertices - analytic_vertices(); }
};

// How many of t's vertices take each kind of tangent rule (rule_kind).
struct TangentCounts {
  std::size_t uv = 0, edge = 0, none = 0;
};
TangentCounts tangent_counts(const ZhTransfer& t);

// What is wrong with `t`, or "": bands, lobes, channels, mode, albedo, at
// least one vertex, slots as prt::Transfer's, array sizes, unit finite axes
// (|a| within 1e-3 of 1), finite coefficients, rest occlusion empty or one
// value in [0, 1] per vertex, one tangent rule per vertex (neighbours in
// range, finite weights, the shapes TangentRule describes).
std::string zh_transfer_problem(const ZhTransfer& t);

// Throws prt::Error unless `posed` can pose `t`: the same vertex count and
// triangles (topology_hash), and vertex colours when t's albedo is them;
// `what` names the transfer in the message.
void check_pose(const ZhTransfer& t, const Mesh& posed, const std::string& what);

// What posing found: vertices without a frame in the pose (zero transfer),
// vertices whose frame came from the normal alone, and from the UV tangent.
struct PoseReport {
  std::size_t no_frame = 0;
  std::size_t normal_only = 0;
  std::size_t uv = 0;
};

// Every vertex's SH transfer (channels x bands^2 floats, row v = vertex v)
// in the pose `posed` (check_pose): the lobes turned by each vertex's posed
// frame (posed_frames with t.tangents), t_lm = sum_i g_il sqrt(4 pi/(2l+1)) Y_lm(F a_i); analytic vertices
// the clamped cosine about the posed normal with the albedo. A vertex without
// a posed frame gets zero (as a vertex without a normal at rest).
std::vector<float> posed_transfer(const ZhTransfer& t, const Mesh& posed, PoseReport* report = nullptr);

// Dynamic ambient occlusion (prt/dynamic_ao.h; docs/LDPRT.md): the factor
// each vertex's posed radiance is scaled by to restore the occlusion the
// local lobes cannot follow, (A_pose + kAoFloor) / (A_rest + kAoFloor), A the
// dynamic_ao of the pose and of the rest pose (ZhTransfer::rest_ao, which
// the file must hold: prt precompute --basis zh --dynamic-ao). At rest it
// is 1. Throws prt::Error when t has no rest occlusion or posed is no pose
// of it (check_pose).
inline constexpr float kAoFloor = 0.05f;  // keeps a vertex dark at rest from taking huge factors (A's error ~0.04)
std::vector<float> dynamic_ao_factor(const ZhTransfer& t, const Mesh& posed, const DynamicAoOptions& options = {});

// The same as a prt::Transfer (every vertex stored, no analytic slot), for
// the tools that take one: relight, the renderer, the reference comparison.
Transfer posed_as_transfer(const ZhTransfer& t, const Mesh& posed, PoseReport* report = nullptr);

}  // namespace prt
