// prt/transfer.h - per-vertex SH radiance transfer (Sloan, Kautz & Snyder 2002).
//
// For a vertex with normal n and albedo rho, the transfer vector T maps
// lighting coefficients L_k (docs/CONVENTIONS.md) to outgoing radiance:
//   B = sum_k T_k L_k,  T_k = (rho/pi) integral V(w) max(n.w, 0) Y_k(w) dw  (shadowed)
// so a white (rho = 1) surface under constant radiance 1, unshadowed, gives
// exactly B = 1. Interreflected adds the diffuse bounces between the mesh's
// surfaces (see docs/PRECOMPUTE.md).
#pragma once

#include <prt/mesh.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

enum class TransferMode : std::uint32_t { Unshadowed = 0, Shadowed = 1, Interreflected = 2 };
TransferMode parse_transfer_mode(std::string_view name);  // "unshadowed", "shadowed", "interreflected"
std::string_view transfer_mode_name(TransferMode m);

struct TransferOptions {
  TransferMode mode = TransferMode::Shadowed;
  int bands = 5;                 // 1..16 (any up to sh::kMaxBands works)
  int samples = 1024;            // ~rays per vertex: 2*samples directions over the sphere
  int bounces = 1;               // interreflected only; 0 = shadowed; at most this many
  // Interreflected: stop adding bounces once one adds less than this fraction
  // of the direct transfer's energy (mean |T| over all coefficients; see
  // Transfer::bounce_energy); Transfer::bounces says how many were computed.
  // 0: always `bounces`.
  double bounce_tolerance = 0;
  glm::vec3 albedo{1.0f};        // used when the mesh has no colours or vertex_colors is false
  bool vertex_colors = false;    // use the mesh's per-vertex colours as albedo
  int threads = 0;               // 0: all cores
  std::uint64_t seed = 1;        // rotates the direction set; same seed, same inputs -> same bits
  double offset = 0;             // ray origin offset; 0: 1e-4 x the mesh's bounding-box diagonal
};

// Per-vertex results. Layout of a transfer array: vertex-major,
// [vertex][channel][k] with k < bands^2, channels 1 (grey albedo: one
// channel serves R, G and B) or 3.
struct Transfer {
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

  std::vector<float> coeffs;         // the transfer of `mode` (interreflected: direct + all bounces)
  std::vector<float> direct;         // interreflected only: the shadowed (0-bounce) part, same layout
  std::vector<float> ao;             // kappa_A = (1/pi) integral V max(n.w,0) dw, per vertex (1 if unshadowed)
  std::vector<glm::vec3> bent_normals;  // normalised cosine-weighted mean unoccluded direction
  std::vector<double> bounce_energy;    // mean |T| added by each bounce (diagnostics)
  double direct_energy = 0;             // interreflected: mean |T| of the direct part (not stored in files)

  std::size_t stride() const { return std::size_t(channels) * bands * bands; }
  const float* vertex(std::size_t v) const { return coeffs.data() + v * stride(); }
};

// Progress callback: (work done, work total, phase name). Called from one
// thread at a time; return false to cancel (compute_transfer then throws
// prt::Error("cancelled")).
using Progress = std::function<bool(std::size_t done, std::size_t total, const char* phase)>;

// Computes the transfer. Throws prt::Error on bad options. Deterministic:
// the same mesh, options and thread count give the same bits.
Transfer compute_transfer(const Mesh& mesh, const TransferOptions& options, const Progress& progress = {});

// Outgoing radiance of every vertex under lighting coefficients `light`
// (RGB, bands^2 or more; extra bands are ignored): RGB per vertex.
std::vector<glm::vec3> relight(const Transfer& t, const std::vector<glm::dvec3>& light);
// The same from the `direct` (shadowed) part of an interreflected transfer.
std::vector<glm::vec3> relight_direct(const Transfer& t, const std::vector<glm::dvec3>& light);

}  // namespace prt
