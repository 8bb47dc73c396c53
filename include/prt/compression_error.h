// prt/compression_error.h - how much a compressed transfer changes the
// picture (issue 16, in progress): the relative RMS of relit radiance,
// compressed against uncompressed, over a set of lightings and (glossy)
// eye points. What `--target-error` is to be measured with.
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include <glm/vec3.hpp>

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

// `count` eye points on a horizontal ring around the mesh's bounding-box
// centre at the distance of prt render's default camera (a 40 degree view
// framing the bounding sphere), starting on +Z.
std::vector<glm::dvec3> eye_ring(const Mesh& mesh, int count);

}  // namespace prt
