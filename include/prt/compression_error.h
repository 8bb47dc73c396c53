// prt/compression_error.h - how much a compressed transfer changes the
// picture (issue 16, in progress): the relative RMS of relit radiance,
// compressed against uncompressed, over a set of lightings and (glossy)
// eye points. What `--target-error` is to be measured with.
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/precompute.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace prt {

struct CompressionErrorOptions {
  std::vector<std::vector<glm::dvec3>> lights;  // SH lightings (RGB, at least bands^2 each)
  std::vector<glm::dvec3> eyes;                 // glossy transfers: the eye points (a ring of views)
  double gloss = 16, specular = 0.5;            // the lobe seen from them
};

// sqrt(sum |a - b|^2 / sum |b|^2) over every vertex, lighting and (glossy)
// eye, a the compressed transfer's radiance, b the uncompressed one's (CPU,
// relight / relight_glossy). Throws prt::Error without lightings, or without
// eyes for a glossy transfer.
double compression_error(const Transfer& t, const CompressedTransfer& c, const Mesh& mesh,
                         const CompressionErrorOptions& options);

// The smallest compression (in bytes: ClusteredSignal::bytes) whose relit
// error is at most `target`, chosen per signal among a grid of K x N (K in
// 1, 4, 16, 64, 128, 256; N in 1, 2, 4, 8, 12, 16, 24; capped at the rows
// and each signal's dimension), candidates tried in increasing size, the
// first that meets its target the answer. The coefficients first, by the
// error of the diffuse radiance alone: at most `target`, or target / 2 for a
// glossy transfer; then its glossy matrices, with those coefficients, by the
// error of the whole (diffuse and glossy) radiance over the eyes: at most
// `target`. `explanation` says what was chosen per signal and what the next
// smaller candidate measured; options holds the K x N (glossy_clusters and
// glossy_vectors the glossy matrices'), error the final relit error. Throws
// prt::Error when a signal's grid never meets its target (naming the best
// error reached), for a target outside (0, 1) or an inconsistent transfer.
// `progress` is called after each candidate (tried, both grids' size).
struct CompressionChoice {
  CompressOptions options;
  CompressedTransfer compressed;
  double error = 0;
  std::size_t bytes = 0;
  int tried = 0;
  std::string explanation;
};
CompressionChoice choose_compression(const Transfer& t, const Mesh& mesh, const CompressionErrorOptions& errors,
                                     double target, int weight_bits = 16, const Progress& progress = {});

// `count` eye points on a horizontal ring around the mesh's bounding-box
// centre at the distance of prt render's default camera (a 40 degree view
// framing the bounding sphere), starting on +Z.
std::vector<glm::dvec3> eye_ring(const Mesh& mesh, int count);

}  // namespace prt
