// The glossy pass (renderer_impl.h): glossy matrices and the lobe toward the eye.
#include "renderer_impl.h"

#include <prt/filter.h>
#include <prt/sh.h>
#include <prt/transfer_io.h>

#include "shaders.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

namespace prt {

using gl::check_gl;
using gl::make_buffer;

namespace detail::render {

// Floats of one vertex's glossy row on the GPU (glossy.comp.glsl): the
// packed triangle, or each channel's full matrix, padded to a multiple of 4.
std::size_t glossy_row_floats(const Transfer& t) {
  const std::size_t nc = std::size_t(t.bands) * t.bands;
  return t.glossy_symmetric() ? (nc * (nc + 1) / 2 + 3) / 4 * 4
                              : std::size_t(t.glossy_channels()) * ((nc * nc + 3) / 4 * 4);
}

// The glossy matrices of `vertices`, row i = vertices[i], as glossy.comp.glsl
// reads them, with its buffer texture: every vertex's for a Transfer (row v
// = vertex v), the analytic ones' for a compressed transfer. Analytic
// vertices store none: their hemisphere product matrices are evaluated here
// (vertex_glossy_matrix), so the shader reads them as it reads stored ones.
// Throws when the rows exceed the buffer texture limit, before building them.
TransferArray make_glossy_array(const Transfer& t, const Mesh& mesh, const std::vector<std::size_t>& vertices,
                                const gl::Limits& lim) {
  const std::size_t count = vertices.size(), row = glossy_row_floats(t), bytes = count * row * sizeof(float);
  check_texture_buffer(count * row / 4, lim,
                       fmt::format("glossy matrices of {} vertices at {} bands ({} bytes per vertex)", count, t.bands,
                                   row * sizeof(float)));
  if (count == 0) return {};
  const std::size_t nc = std::size_t(t.bands) * t.bands, channel = (nc * nc + 3) / 4 * 4;
  TransferArray a;
  a.bytes = bytes;
  a.buffer = upload_rows(count, row, [&](std::size_t n, float* dst) {
    const std::size_t v = vertices[n];
    if (const float* src = t.stored_glossy(v)) {
      if (t.glossy_symmetric()) std::copy_n(src, nc * (nc + 1) / 2, dst);
      else
        for (int c = 0; c < t.glossy_channels(); ++c) std::copy_n(src + std::size_t(c) * nc * nc, nc * nc, dst + std::size_t(c) * channel);
      return;
    }
    const std::vector<double> m = vertex_glossy_matrix(t, mesh, v);  // every channel's
    if (t.glossy_symmetric()) {
      for (std::size_t i = 0, k = 0; i < nc; ++i)
        for (std::size_t j = i; j < nc; ++j, ++k) dst[k] = float(m[i * nc + j]);
    } else {
      for (int c = 0; c < t.glossy_channels(); ++c)
        for (std::size_t i = 0; i < nc * nc; ++i) dst[std::size_t(c) * channel + i] = float(m[i]);
    }
  });
  glCreateTextures(GL_TEXTURE_BUFFER, 1, &a.texture);
  glTextureBuffer(a.texture, GL_RGBA32F, a.buffer);
  a.channels = t.glossy_channels();
  return a;
}

}  // namespace detail::render

void Renderer::Impl::set_lobe(const GlossyShading& s) {
  lobe = s;
  const std::vector<double> lambda = prt::glossy::phong_lobe_factors(s.gloss, glossy_header.bands);
  lobe_factors.fill(0.0f);
  for (std::size_t l = 0; l < lambda.size(); ++l) lobe_factors[l] = float(s.specular * lambda[l]);
  // relight_glossy's scaling of the diffuse part: rho_d / albedo, 0 for rho_d = 0.
  diffuse_scale = glm::vec3(1.0f);
  if (!(s.diffuse.x < 0 && s.diffuse.y < 0 && s.diffuse.z < 0))
    for (int c = 0; c < 3; ++c)
      diffuse_scale[c] = s.diffuse[c] == 0.0 ? 0.0f : float(s.diffuse[c] / double(glossy_header.albedo[c]));
}

GLuint Renderer::Impl::glossy_program(int coeffs) {
  const int nc = bands * bands, gch = glossy_header.glossy_channels();
  const bool symmetric = glossy_header.glossy_symmetric();
  // A compressed transfer without stored rows has every vertex's hemisphere
  // matrix in glossy_array, row v = vertex v: the plain program.
  const bool packed = compressed && glossy_rows;
  const int from = source == Source::Mixed ? 1 : 0;
  const int block_vec4s = packed ? glossy_block_clusters * int(glossy_cluster_bytes / 16) : 0;
  GLuint& p = glossy_programs[{coeffs, nc, gch, symmetric ? 1 : 0, packed ? glossy_rows.vectors : -1,
                               packed ? glossy_rows.weight_bits : 0, packed ? from : 0, block_vec4s}];
  if (!p) {
    const int shader_bands = int(std::lround(std::sqrt(double(coeffs))));
    p = gl::link_compute(shaders::glossy_comp_glsl, "glossy",
                         fmt::format("#define COEFFS {}\n#define BANDS {}\n#define NC {}\n#define GCH {}\n"
                                     "#define SYMMETRIC {}\n#define CH_FLOATS {}\n#define ROW_TEXELS {}\n"
                                     "#define COMPRESSED {}\n#define SOURCE {}\n",
                                     coeffs, shader_bands, nc, gch, symmetric ? 1 : 0, (nc * nc + 3) / 4 * 4,
                                     glossy_row_texels, packed ? 1 : 0, packed ? from : 0) +
                             fmt::format("#define PRODUCTS_UBO {}\n#define BLOCK_VEC4S {}\n", block_vec4s > 0 ? 1 : 0,
                                         std::max(block_vec4s, 1)) +
                             (packed ? compressed_defines(glossy_rows, nc) : std::string()));
  }
  return p;
}

void Renderer::set_glossy(double gloss, double specular, const glm::dvec3& diffuse) {
  Impl& m = *impl_;
  PRT_CHECK(m.has_glossy);
  GlossyShading s;
  s.gloss = gloss;
  s.specular = specular;
  s.diffuse = diffuse;
  if (const std::string p = glossy_shading_problem(m.glossy_header, s); !p.empty()) throw Error(p);
  m.set_lobe(s);
}

}  // namespace prt
