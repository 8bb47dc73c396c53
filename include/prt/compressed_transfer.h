// prt/compressed_transfer.h - transfer compressed by clustered PCA (Sloan,
// Hall, Hart & Snyder 2003; docs/COMPRESSION.md): the data, its CPU
// relighting and decompression, and the per-cluster products the renderer
// decodes with on the GPU (prt/render.h). The fit is prt::precompute's
// (prt/cpca.h, compress_transfer in prt/precompute.h), the choice of its
// size by a relit-error target prt::analysis's (prt/compression_error.h);
// files are prt/transfer_io.h's.
//
// A stored row x_p of a transfer (a vertex's diffuse coefficients, all its
// channels; or its glossy matrices) is approximated as
//   x_p ~ m_k + sum_{j < N} w_pj b_kj,   k = cluster[p],
// so that relighting needs, per frame, only the lighting through each
// cluster's mean and basis (K (N + 1) products with L) and per vertex the N
// weights: B_p = (m_k . L) + sum_j w_pj (b_kj . L), and for glossy
// L'_p = (M_k L) + sum_j w_pj (B_kj L) before the view-dependent lobe.
#pragma once

#include <prt/mesh.h>
#include <prt/transfer.h>

#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

// One compressed array: `dim` values per row, in float.
struct ClusteredSignal {
  int clusters = 0, vectors = 0;
  std::size_t dim = 0;
  std::vector<float> means;            // clusters x dim
  std::vector<float> bases;            // clusters x vectors x dim
  std::vector<std::uint32_t> cluster;  // per row
  std::vector<float> weights;          // rows x vectors (16-bit: the values the quantised ones stand for)
  // 32: float weights; 16: each weight quantised to round(w / s) s with
  // s = max |w| / 32767 over its cluster's rows, one scale per cluster and
  // vector (weight_scales, clusters x vectors): error at most s / 2 per weight.
  int weight_bits = 32;
  std::vector<float> weight_scales;
  std::size_t rows() const { return cluster.size(); }
  // Bits of a stored cluster index: the narrowest of 8, 16, 32 that holds
  // clusters - 1 (files store it so; in memory it is always 32).
  int index_bits() const { return index_bits_for(clusters); }
  static int index_bits_for(int clusters) { return clusters <= 256 ? 8 : clusters <= 65536 ? 16 : 32; }
  // Bytes of the representation as stored: per row index_bits / 8 (cluster)
  // + (weight_bits / 8) N (weights), per cluster 4 (N + 1) dim, and 4 N
  // scales when 16-bit (without the file's 32-byte signal header and padding).
  std::size_t bytes() const;
  // bytes() of a fit of `rows` rows of `dim` values with K clusters and N
  // vectors (each capped as compress_transfer caps them) before it is made.
  static std::size_t planned_bytes(std::size_t rows, std::size_t dim, int clusters, int vectors, int weight_bits);
  // Row r's approximation (dim values).
  void reconstruct(std::size_t r, float* out) const;
};

// A 16-bit weight as stored: w / scale rounded to the nearest integer,
// within +-32767 (0 for a zero scale); and the weight it stands for, that
// code times the scale in float (what ClusteredSignal::weights holds).
inline std::int16_t weight_code(float w, float scale) {
  if (!(scale > 0.0f)) return 0;
  const long q = std::lround(w / scale);
  return std::int16_t(q < -32767 ? -32767 : q > 32767 ? 32767 : q);
}
inline float quantised_weight(float w, float scale) { return float(weight_code(w, scale)) * scale; }

// What a compression's size was chosen for (`prt compress --target-error`,
// prt::choose_compression; docs/COMPRESSION.md): the target, the error
// distribution it was measured over and the figures measured there. Files
// store it as JSON (docs/FORMAT.md, kind 12; version 6).
struct CompressionChoiceRecord {
  double target = 0;                       // relative RMS radiance error, in (0, 1)
  std::string statistic = "p95";           // what the target holds to: "p95" or "mean" over the samples
  std::string metric = "band";             // the fits' metric: "band" or "plain"
  bool exhaustive = false;                 // the search: every candidate fitted in full, or the quick one
  std::vector<std::string> maps, spectra;  // the lighting maps' names; the spectra the rotations took on in turn
  bool sun = false;                        // a point light too (prt::ErrorDistribution::sun)
  int rotations = 0;                       // per map
  std::uint64_t seed = 0;                  // of the rotations
  int eyes = 0;                            // glossy: eyes on a sphere (0: diffuse)
  std::vector<double> exponents, speculars;  // glossy: Phong exponents and specular strengths
  // Measured on the chosen compression: the whole radiance's relit error
  // over the samples, and the transfer-space bound (no lighting exceeds it).
  double mean = 0, p95 = 0, max = 0, bound = 0;
  std::uint64_t samples = 0, vertices = 0;  // vertices: those measured
};
// What is wrong with `r`, or "": target in (0, 1), a known statistic and
// metric, at least one map, rotations >= 1, eyes >= 0 with exponents and
// strengths exactly when eyes > 0, every figure finite and >= 0, mean <= max,
// samples and vertices >= 1.
std::string compression_choice_problem(const CompressionChoiceRecord& r);
// The record as one JSON object (docs/FORMAT.md lists its keys), and back:
// parse_compression_choice throws prt::Error naming the problem (not JSON,
// a key missing or of the wrong type, compression_choice_problem's).
std::string compression_choice_json(const CompressionChoiceRecord& r);
CompressionChoiceRecord parse_compression_choice(std::string_view json);
// One paragraph for prt info: the target, the distribution, the figures.
std::string describe_choice(const CompressionChoiceRecord& r);

// A transfer whose stored rows (and glossy matrices) are compressed:
// `transfer` holds everything else (header, slots, ambient occlusion, bent
// normals) with its coeffs, direct and glossy_matrices arrays empty.
struct CompressedTransfer {
  Transfer transfer;
  ClusteredSignal coeffs;  // the rows of Transfer::coeffs (stride() values each)
  ClusteredSignal glossy;  // the rows of Transfer::glossy_matrices (glossy_stride() each), when transfer.glossy
  std::optional<CompressionChoiceRecord> choice;  // what its size was chosen for, when it was chosen by a target
};

// What is wrong with `c`, or "": the uncompressed part as transfer_problem
// (prt/transfer.h) with its coefficients, direct part and glossy matrices
// empty; each signal one row per stored vertex of the transfer's stride
// (glossy_stride() for the glossy one, present exactly when
// transfer.glossy), 1 <= clusters <= 2^24, 0 <= vectors <= dim, arrays of
// their sizes, cluster indices below clusters, every value finite, 16-bit
// weights multiples of their scale within 32767 steps; and the choice
// record's compression_choice_problem.
std::string compressed_transfer_problem(const CompressedTransfer& c);

// The per-cluster lighting products, shared by the CPU relighting below and
// the renderer (prt/render.h), which uploads them each frame:
//
// cluster_lighting: the lighting through cluster k's mean (j = 0) and basis
// vector j - 1 (j = 1..N) of a diffuse signal whose rows are `channels` (1
// or 3) runs of bands^2 coefficients, out[k (N + 1) + j] RGB (one channel
// serves R, G and B). `light` holds at least bands^2 coefficients; only
// those are read.
std::vector<glm::dvec3> cluster_lighting(const ClusteredSignal& s, int channels, int bands,
                                         std::span<const glm::dvec3> light);
// glossy_cluster_lighting: M L for cluster k's mean matrix (j = 0) and each
// basis matrix (j = 1..N) of the glossy signal `g`, in the glossy layout of
// transfer `t` (its header: packed symmetric, or nc x nc per channel):
// out[(k (N + 1) + j) nc + i] = (M_kj L)_i RGB, nc = bands^2. Reads only g's
// means and bases. Contract (prt::InternalError): t is glossy, g's rows are
// its glossy_stride() long and `light` holds at least nc coefficients.
std::vector<glm::dvec3> glossy_cluster_lighting(const Transfer& t, const ClusteredSignal& g,
                                                std::span<const glm::dvec3> light);

// The transfer the compressed one approximates, every row reconstructed.
Transfer decompress(const CompressedTransfer& c);

// relight() and relight_glossy() of the compressed transfer by per-cluster
// products (see above); the same results as of decompress(c) up to float
// rounding. `mesh` is the mesh it was computed for.
std::vector<glm::vec3> relight(const CompressedTransfer& c, const Mesh& mesh, const std::vector<glm::dvec3>& light);
std::vector<glm::vec3> relight_glossy(const CompressedTransfer& c, const Mesh& mesh,
                                      const std::vector<glm::dvec3>& light, const GlossyShading& shading);

}  // namespace prt
