// The clustered-PCA pass (renderer_impl.h): compressed rows, per-cluster
// products of the lighting, cluster colours.
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

// A compressed signal's rows for shaders/compressed.glsl: per row the
// cluster index, then the weights (16-bit: the integers q = w / s, two per
// word; 32-bit: floats), in a storage buffer, and the buffer of its
// per-cluster products (`run` vec4s per vector). Throws, naming
// GL_MAX_SHADER_STORAGE_BLOCK_SIZE, when a buffer exceeds it.
ClusterRows make_cluster_rows(const ClusteredSignal& s, std::size_t run, const char* what, const gl::Limits& lim) {
  ClusterRows r;
  r.vectors = s.vectors;
  r.weight_bits = s.weight_bits;
  r.row_words = 1 + (s.weight_bits == 16 ? (s.vectors + 1) / 2 : s.vectors);
  const std::size_t N = std::size_t(s.vectors), rows = s.rows();
  // Both buffers are bound whole as storage blocks: checked before anything is built.
  r.bytes = rows * std::size_t(r.row_words) * sizeof(std::uint32_t);
  if (r.bytes > lim.storage_block)
    throw Error(fmt::format("compressed {} of {} rows need {} bytes on the GPU in one storage buffer ({} per row); "
                            "this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes",
                            what, rows, r.bytes, std::size_t(r.row_words) * sizeof(std::uint32_t), lim.storage_block));
  r.product_bytes = std::size_t(s.clusters) * (N + 1) * run * 16;
  if (r.product_bytes > lim.storage_block)
    throw Error(fmt::format("the per-cluster products of the compressed {} need {} bytes on the GPU in one storage "
                            "buffer; this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes",
                            what, r.product_bytes, lim.storage_block));
  std::vector<std::uint32_t> words(std::max<std::size_t>(rows, 1) * std::size_t(r.row_words), 0u);
  for (std::size_t p = 0; p < rows; ++p) {
    std::uint32_t* w = words.data() + p * std::size_t(r.row_words);
    const std::size_t k = s.cluster[p];
    w[0] = s.cluster[p];
    for (std::size_t j = 0; j < N; ++j) {
      const float x = s.weights[p * N + j];
      if (s.weight_bits == 16) {
        // The integer the dequantised weight stands for (prt/compressed_transfer.h).
        const std::int16_t q = weight_code(x, s.weight_scales[k * N + j]);
        w[1 + j / 2] |= (std::uint32_t(std::int32_t(q)) & 0xffffu) << (16 * (j & 1));
      } else {
        std::memcpy(&w[1 + j], &x, sizeof(float));
      }
    }
  }
  r.buffer = make_buffer(words.data(), words.size() * sizeof(std::uint32_t));
  r.products = make_buffer(nullptr, std::max<std::size_t>(r.product_bytes, 16), GL_DYNAMIC_STORAGE_BIT);
  r.clusters = s;
  r.clusters.cluster.clear();
  r.clusters.weights.clear();
  return r;
}

// The products of cluster_lighting (or glossy_cluster_lighting: `run` RGB
// values per vector) as the shaders read them, vec4s, each basis vector's
// scaled by its 16-bit weights' scale (compressed.glsl's weights are the integers).
std::vector<float> product_vec4s(const std::vector<glm::dvec3>& p, const ClusteredSignal& s, std::size_t run) {
  const std::size_t per = std::size_t(s.vectors) + 1;
  std::vector<float> out(std::max<std::size_t>(p.size(), 1) * 4, 0.0f);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t kj = i / run, k = kj / per, j = kj % per;
    const double scale = j == 0 || s.weight_bits != 16 ? 1.0 : double(s.weight_scales[k * (per - 1) + (j - 1)]);
    for (int c = 0; c < 3; ++c) out[4 * i + std::size_t(c)] = float(scale * p[i][c]);
  }
  return out;
}

// A colour per cluster for Shading::Clusters: a hash of the index to a hue
// of full saturation and a value in [0.55, 1] (never grey, the analytic
// vertices' colour), linear RGB.
glm::vec3 cluster_colour(std::uint32_t k) {
  std::uint32_t h = k * 0x9e3779b9u;
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  const float hue = float(h & 0xffffu) / 65536.0f * 6.0f, value = 0.55f + 0.45f * float((h >> 16) & 0xffu) / 255.0f;
  const int sector = int(hue);
  const float f = hue - float(sector);
  const float rise = value * f, fall = value * (1.0f - f);
  switch (sector) {
    case 0: return {value, rise, 0.0f};
    case 1: return {fall, value, 0.0f};
    case 2: return {0.0f, value, rise};
    case 3: return {0.0f, fall, value};
    case 4: return {rise, 0.0f, value};
    default: return {value, 0.0f, fall};
  }
}

}  // namespace detail::render

// The #defines and shared source of a compressed program (shaders/compressed.glsl).
std::string Renderer::Impl::compressed_defines(const ClusterRows& r, int product_run) const {
  return fmt::format("#define VECTORS {}\n#define WEIGHT_BITS {}\n#define ROW_WORDS {}\n#define PRODUCT_RUN {}\n{}", r.vectors,
                     r.weight_bits, r.row_words, product_run, shaders::compressed_glsl);
}

void Renderer::set_mesh(const Mesh& mesh, const CompressedTransfer& c) {
  if (const std::string p = compressed_transfer_problem(c); !p.empty())
    throw Error("inconsistent compressed transfer: " + p);
  const Transfer& t = c.transfer;
  check_matches(t, mesh, "transfer");
  check_bands(t);
  const std::size_t rows = t.stored_vertices(), analytic = t.vertices - rows;
  if (t.vertices >= std::size_t(0x80000000u))
    throw Error(fmt::format("compressed transfer of {} vertices: the renderer takes fewer than 2^31", t.vertices));
  set_mesh(mesh, t.albedo, t.vertex_colors);
  Impl& m = *impl_;
  m.compressed = true;
  m.has_direct = false;  // compress_transfer drops the direct part
  // Analytic vertices are shaded as in the uncompressed path (from their
  // normal in the diffuse pass, their hemisphere matrix in the glossy pass),
  // told apart by their slot; stored rows have no dense form to fall back on.
  m.source = rows == 0 ? Source::Analytic : analytic > 0 ? Source::Mixed : Source::Stored;
  std::vector<std::size_t> analytic_list;
  if (analytic > 0) {
    // Slots: a stored vertex's row, or the top bit and the analytic vertex's index.
    std::vector<std::uint32_t> slots(t.vertices);
    for (std::size_t v = 0; v < t.vertices; ++v) {
      if (t.is_analytic(v)) {
        slots[v] = 0x80000000u | std::uint32_t(analytic_list.size());
        analytic_list.push_back(v);
      } else {
        slots[v] = t.slots[v];
      }
    }
    m.slot_buffer = make_buffer(slots.data(), slots.size() * sizeof(std::uint32_t));
  }
  if (rows > 0) {
    m.coeff_rows = make_cluster_rows(c.coeffs, 1, "coefficients", m.limits);
    if (t.glossy)
      m.glossy_rows = make_cluster_rows(c.glossy, std::size_t(t.bands) * t.bands, "glossy matrices", m.limits);
  }
  if (t.glossy && m.glossy_rows) {
    // Vertices by cluster (analytic ones last: key K), cut into workgroups of 64.
    constexpr std::uint32_t kNone = 0xffffffffu;
    const std::uint32_t K = std::uint32_t(c.glossy.clusters);
    std::vector<std::vector<std::uint32_t>> by(std::size_t(K) + 1);
    for (std::uint32_t v = 0; v < std::uint32_t(t.vertices); ++v)
      by[t.is_analytic(v) ? K : c.glossy.cluster[t.slots.empty() ? v : t.slots[v]]].push_back(v);
    std::vector<std::uint32_t> order, chunk;
    for (std::uint32_t k = 0; k <= K; ++k)
      for (std::size_t at = 0; at < by[k].size(); at += 64) {
        chunk.push_back(k == K ? kNone : k);
        for (std::size_t i = 0; i < 64; ++i) order.push_back(at + i < by[k].size() ? by[k][at + i] : kNone);
      }
    m.glossy_chunks = chunk.size();
    // The glossy pass goes by cluster, not by runs of vertices: it binds
    // these whole, so each must fit one storage block.
    const std::pair<const char*, std::size_t> whole[] = {
        {"radiance (16 bytes per vertex)", t.vertices * 16},
        {"normals (12 bytes per vertex)", t.vertices * 12},
        {"positions (12 bytes per vertex)", t.vertices * 12},
        {"slots (4 bytes per vertex)", analytic > 0 ? t.vertices * 4 : 0},
        {"vertex order by cluster", order.size() * sizeof(std::uint32_t)},
    };
    for (const auto& [what, bytes] : whole)
      if (bytes > m.limits.storage_block)
        throw Error(fmt::format("compressed glossy shading of {} vertices binds its {} whole: {} bytes; this OpenGL's "
                                "GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes: use a smaller mesh, or the "
                                "uncompressed file",
                                t.vertices, what, bytes, m.limits.storage_block));
    // Uniform blocks of as many clusters' products as the block size allows,
    // each starting at the buffer offset alignment.
    GLint64 block = 0, align = 0;
    glGetInteger64v(GL_MAX_UNIFORM_BLOCK_SIZE, &block);
    glGetInteger64v(GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, &align);
    m.glossy_cluster_bytes = std::size_t(c.glossy.vectors + 1) * std::size_t(t.bands) * t.bands * 16;
    const std::size_t per_block = std::min<std::size_t>(std::size_t(block) / m.glossy_cluster_bytes, K);
    m.glossy_block_clusters = int(per_block);
    m.glossy_block_chunks.clear();
    if (per_block > 0) {
      const std::size_t a = std::size_t(std::max<GLint64>(align, 16)), blocks = (K + per_block - 1) / per_block;
      m.glossy_block_stride = (per_block * m.glossy_cluster_bytes + a - 1) / a * a;
      for (std::size_t b = 0; b <= blocks; ++b)  // the first chunk of cluster b C (b = blocks: of the analytic ones)
        m.glossy_block_chunks.push_back(std::size_t(
            std::lower_bound(chunk.begin(), chunk.end(), std::uint32_t(std::min<std::size_t>(b * per_block, K)),
                             [&](std::uint32_t x, std::uint32_t want) { return (x == kNone ? K : x) < want; }) -
            chunk.begin()));
      m.glossy_block_chunks.push_back(chunk.size());
      glDeleteBuffers(1, &m.glossy_rows.products);
      m.glossy_rows.product_bytes = blocks * m.glossy_block_stride;
      m.glossy_rows.products = make_buffer(nullptr, m.glossy_rows.product_bytes, GL_DYNAMIC_STORAGE_BIT);
    }
    m.glossy_order_buffer = make_buffer(order.data(), std::max<std::size_t>(order.size(), 1) * sizeof(std::uint32_t));
    m.glossy_chunk_buffer = make_buffer(chunk.data(), std::max<std::size_t>(chunk.size(), 1) * sizeof(std::uint32_t));
  }
  // Shading::Clusters: the glossy matrices' clusters when there are some
  // (the larger signal, what the glossy shading decodes), else the
  // coefficients'; analytic vertices grey.
  const ClusteredSignal& shown = t.glossy ? c.glossy : c.coeffs;
  std::vector<glm::vec3> colours(t.vertices, glm::vec3(0.5f));
  for (std::size_t v = 0; v < t.vertices; ++v)
    if (!t.is_analytic(v)) colours[v] = cluster_colour(shown.cluster[t.slots.empty() ? v : t.slots[v]]);
  m.cluster_color_buffer = make_buffer(colours.data(), colours.size() * sizeof(glm::vec3));
  m.finish_transfer(t, mesh, analytic_list);
}

// Compressed transfers: the per-cluster products of the lighting's first
// band_limit^2 coefficients (the rest zero: the leading blocks of the
// transfer, as the uncompressed passes' truncation), computed on the CPU by
// the functions prt::relight uses, and uploaded. K (N + 1) vec4s for the
// diffuse pass, K (N + 1) bands^2 for the glossy one.
void Renderer::Impl::upload_cluster_lighting() {
  if (!compressed || light_coeffs.empty() || !coeff_rows) return;
  upload_products(coeff_rows,
                  product_vec4s(cluster_lighting(coeff_rows.clusters, channels, bands, band_limited_lighting()),
                                coeff_rows.clusters, 1));
  // The glossy products (K (N + 1) bands^2, the larger part) when a glossy
  // frame first needs them (relight()), not while another shading is shown.
  glossy_products_stale = bool(glossy_rows);
  if (shading == Shading::Glossy) upload_glossy_cluster_lighting();
}

void Renderer::Impl::upload_glossy_cluster_lighting() {
  if (!glossy_products_stale) return;
  std::vector<float> v = product_vec4s(glossy_cluster_lighting(glossy_header, glossy_rows.clusters,
                                                               band_limited_lighting()),
                                       glossy_rows.clusters, std::size_t(bands) * bands);
  if (glossy_block_clusters > 0) {  // into the uniform blocks' layout
    std::vector<float> blocks(glossy_rows.product_bytes / sizeof(float), 0.0f);
    const std::size_t per = glossy_cluster_bytes / sizeof(float), C = std::size_t(glossy_block_clusters);
    for (std::size_t k = 0; k < std::size_t(glossy_rows.clusters.clusters); ++k)
      std::copy_n(v.begin() + std::ptrdiff_t(k * per), per,
                  blocks.begin() + std::ptrdiff_t((k / C) * glossy_block_stride / sizeof(float) + (k % C) * per));
    v.swap(blocks);
  }
  upload_products(glossy_rows, v);
  glossy_products_stale = false;
}

// The lighting's first band_limit^2 coefficients, zeros after them.
std::vector<glm::dvec3> Renderer::Impl::band_limited_lighting() const {
  const std::size_t keep = std::size_t(band_limit) * band_limit;
  std::vector<glm::dvec3> L(light_coeffs.size(), glm::dvec3(0.0));
  std::copy_n(light_coeffs.begin(), std::ptrdiff_t(std::min(keep, L.size())), L.begin());
  return L;
}

// Uploads products (vec4s) into the rows' product buffer (make_cluster_rows').
void Renderer::Impl::upload_products(ClusterRows& r, const std::vector<float>& v) {
  const std::size_t bytes = v.size() * sizeof(float), allocated = std::max<std::size_t>(r.product_bytes, 16);
  PRT_CHECK_OP(bytes, ==, allocated);
  glNamedBufferSubData(r.products, 0, GLsizeiptr(bytes), v.data());
  check_gl("uploading the cluster lighting");
}

}  // namespace prt
