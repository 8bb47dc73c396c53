// The per-vertex SH pass (renderer_impl.h): the transfer uploaded by
// set_mesh, and the compute pass that dots every row with the lighting.
#include "renderer_impl.h"

#include <prt/filter.h>
#include <prt/sh.h>
#include <prt/transfer_io.h>

#include "sh_glsl.h"
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

GLuint Renderer::Impl::relight_program(int coeffs, int vec4s, int ch, Source from, bool vertex_albedo) {
  // Unshadowed (Source::Analytic) reads no rows: the plain program.
  const bool packed = compressed && from != Source::Analytic;
  GLuint& p = relight_programs[{coeffs, vec4s, ch, int(from), vertex_albedo ? 1 : 0, packed ? coeff_rows.vectors : -1,
                                packed ? coeff_rows.weight_bits : 0}];
  if (!p) {
    const int shader_bands = int(std::lround(std::sqrt(double(coeffs))));
    p = gl::link_compute(shaders::relight_comp_glsl, "relight",
                         fmt::format("#define COEFFS {}\n#define BANDS {}\n#define VEC4S {}\n#define CHANNELS {}\n"
                                     "#define SOURCE {}\n#define VERTEX_ALBEDO {}\n#define COMPRESSED {}\n",
                                     coeffs, shader_bands, vec4s, ch, int(from), vertex_albedo ? 1 : 0, packed ? 1 : 0) +
                             sh_band_sums_glsl(shader_bands) + (packed ? compressed_defines(coeff_rows, 1) : std::string()));
  }
  return p;
}

void Renderer::set_mesh(const Mesh& mesh, const Transfer& t) {
  if (const std::string p = transfer_problem(t); !p.empty()) throw Error("inconsistent transfer: " + p);
  check_matches(t, mesh, "transfer");
  check_bands(t);
  const std::size_t rows = t.stored_vertices();
  set_mesh(mesh, t.albedo, t.vertex_colors);
  Impl& m = *impl_;
  if (!t.light_bounce.empty())  // the lights' bounce at the vertices (bounce_pass.h)
    m.bounce = std::make_unique<detail::BouncePass>(t.light_bounce, m.limits);
  const int stride = t.bands * t.bands;
  // With no stored vertex, an interreflected transfer's direct part is its
  // transfer: both are the clamped cosine everywhere.
  m.has_direct = !t.direct.empty() || (t.mode == TransferMode::Interreflected && rows == 0);
  // Analytic vertices spare their rows on the GPU but cost every vertex a
  // 4-byte slot. Where that costs more than it spares (few analytic
  // vertices), their rows are evaluated here and uploaded as stored ones.
  const std::size_t analytic = t.vertices - rows;
  const std::size_t row_bytes =
      std::size_t(t.channels) * std::size_t((stride + 3) / 4 * 4) * sizeof(float) * (t.direct.empty() ? 1 : 2);
  m.source = rows == 0                                                              ? Source::Analytic
             : analytic > 0 && analytic * row_bytes > t.vertices * sizeof(std::uint32_t) ? Source::Mixed
                                                                                    : Source::Stored;
  // The arrays go up a block of rows at a time, straight from t (no copy of
  // a whole array on the CPU).
  const auto array = [&](bool direct, const char* what) {
    const std::vector<float>& a = direct ? t.direct : t.coeffs;
    if (m.source == Source::Stored && analytic > 0)  // every vertex's row: dense_transfer's, one at a time
      return make_transfer_array(t.vertices, t.channels, stride, m.limits, what, [&](std::size_t v, float* scratch) {
        if (const float* row = direct ? t.stored_direct(v) : t.stored(v)) return row;
        const std::vector<double> d = vertex_transfer(t, mesh, v, direct);
        for (std::size_t i = 0; i < d.size(); ++i) scratch[i] = float(d[i]);
        return static_cast<const float*>(scratch);
      });
    return make_transfer_array(rows, t.channels, stride, m.limits, what,
                               [&](std::size_t r, float*) { return a.data() + r * t.stride(); });
  };
  m.transfer = array(false, "transfer");
  if (!t.direct.empty()) m.direct = array(true, "direct part");
  if (m.source == Source::Mixed) m.slot_buffer = make_buffer(t.slots.data(), t.slots.size() * sizeof(std::uint32_t));
  std::vector<std::size_t> every(t.glossy ? t.vertices : 0);
  for (std::size_t v = 0; v < every.size(); ++v) every[v] = v;
  m.finish_transfer(t, mesh, every);
}

// What both set_mesh overloads upload alike: ambient occlusion, bent
// normals, the glossy rows of `glossy_vertices` (hemisphere matrices for
// the analytic ones) and what the glossy pass needs of the header.
void Renderer::Impl::finish_transfer(const Transfer& t, const Mesh& mesh, const std::vector<std::size_t>& glossy_vertices) {
  translucent = t.subsurface.has_value();
  if (!t.ao.empty()) ao_buffer = make_buffer(t.ao.data(), t.ao.size() * sizeof(float));
  if (!t.bent_normals.empty())
    bent_buffer = make_buffer(t.bent_normals.data(), t.bent_normals.size() * sizeof(glm::vec3));
  if (t.glossy) {
    glossy_array = make_glossy_array(t, mesh, glossy_vertices, limits);
    glossy_row_texels = int(glossy_row_floats(t) / 4);
    has_glossy = true;
    // What glossy_shading_problem reads of the transfer: the header, not its arrays.
    glossy_header = Transfer{};
    glossy_header.header() = t.header();
    glossy_header.glossy = true;
    set_lobe(GlossyShading{});
  }
  check_gl("uploading the transfer");
  bands = band_limit = t.bands;
  channels = t.channels;
  shading = t.glossy ? Shading::Glossy : Shading::Transfer;
}

// The first band_limit^2 lighting coefficients, zeros up to the next
// multiple of 4 (the shader reads whole vec4s of transfer).
void Renderer::Impl::upload_lighting() {
  sky_stale = true;
  if (light.empty()) return;
  const std::size_t keep = std::size_t(band_limit) * band_limit, padded = (keep + 3) / 4 * 4;
  std::vector<float> v(padded * 4, 0.0f);
  std::copy_n(light.begin(), std::ptrdiff_t(keep * 4), v.begin());
  make_current();
  glNamedBufferSubData(light_buffer, 0, GLsizeiptr(v.size() * sizeof(float)), v.data());
  check_gl("uploading the lighting");
  upload_cluster_lighting();
}

// The relighting pass of the current transfer shading (Transfer, Direct,
// Unshadowed, Glossy: its diffuse part, then glossy.comp.glsl toward `eye`)
// into radiance_buffer; returns that buffer.
GLuint Renderer::Impl::relight(const glm::dvec3& eye) {
  const TransferArray& a = shading == Shading::Direct && direct ? direct : transfer;
  const Source s = shading == Shading::Unshadowed ? Source::Analytic : source;
  const bool vertex_albedo = albedo_buffer != 0;
  glUseProgram(relight_program(band_limit * band_limit, (bands * bands + 3) / 4, channels, s, vertex_albedo));
  if (s != Source::Stored) {  // the clamped cosine of analytic vertices (relight.comp.glsl)
    float cosine[kMaxRenderBands] = {};
    for (int l = 0; l < bands; ++l) cosine[l] = float(sh::clamped_cosine_factor(l) / 3.14159265358979323846);
    glUniform1fv(2, kMaxRenderBands, cosine);
    if (!vertex_albedo) glUniform3f(1, albedo[0], albedo[1], albedo[2]);
  }
  glBindTextureUnit(3, a.texture);
  if (compressed && s != Source::Analytic) {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, coeff_rows.buffer);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, coeff_rows.products);
  }
  glBindBufferBase(GL_UNIFORM_BUFFER, 1, light_buffer);
  // Runs of `chunk` vertices (set_mesh): each binds its range of the
  // per-vertex storage buffers (bytes per vertex: radiance 16, normals,
  // colours and positions 12, slots 4), which the shaders index from the
  // run's first vertex (u_first); rows (buffer textures, compressed rows)
  // are read by vertex or row number as before.
  const auto bind_run = [](GLuint binding, GLuint buffer, std::size_t first, std::size_t n, std::size_t bytes) {
    glBindBufferRange(GL_SHADER_STORAGE_BUFFER, binding, buffer, GLintptr(first * bytes), GLsizeiptr(n * bytes));
  };
  for (std::size_t first = 0; first < vertex_count; first += chunk) {
    const std::size_t n = std::min(chunk, vertex_count - first);
    glUniform1ui(0, GLuint(n));      // u_vertices: of this run
    glUniform1ui(18, GLuint(first));  // u_first
    bind_run(2, radiance_buffer, first, n, 16);
    if (s != Source::Stored) {
      bind_run(5, normal_buffer, first, n, 12);
      if (vertex_albedo) bind_run(6, albedo_buffer, first, n, 12);
      if (s == Source::Mixed) bind_run(4, slot_buffer, first, n, 4);
    }
    glDispatchCompute(GLuint((n + 63) / 64), 1, 1);
  }
  if (shading == Shading::Glossy) {
    if (compressed) upload_glossy_cluster_lighting();
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);  // the glossy pass reads the diffuse radiance
    glUseProgram(glossy_program(band_limit * band_limit));
    glUniform3f(1, float(eye.x), float(eye.y), float(eye.z));
    glUniform3fv(2, 1, &diffuse_scale[0]);
    glUniform1fv(3, kMaxRenderBands, lobe_factors.data());
    glBindTextureUnit(4, glossy_array.texture);
    if (!(compressed && glossy_rows)) {
      for (std::size_t first = 0; first < vertex_count; first += chunk) {
        const std::size_t n = std::min(chunk, vertex_count - first);
        glUniform1ui(0, GLuint(n));       // u_vertices: of this run
        glUniform1ui(22, GLuint(first));  // u_first
        bind_run(2, radiance_buffer, first, n, 16);
        bind_run(5, normal_buffer, first, n, 12);
        bind_run(7, position_buffer, first, n, 12);
        glDispatchCompute(GLuint((n + 63) / 64), 1, 1);
      }
    } else {
      // Work by cluster (order, chunk_cluster): the per-vertex buffers bound
      // whole (set_mesh checked that they fit a storage block), dispatches of
      // at most GL_MAX_COMPUTE_WORK_GROUP_COUNT workgroups from u_chunk_base.
      glUniform1ui(0, GLuint(vertex_count));
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, radiance_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, normal_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, position_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, glossy_rows.buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, glossy_rows.products);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, glossy_order_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, glossy_chunk_buffer);
      if (source == Source::Mixed) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, slot_buffer);
      const auto dispatch_chunks = [&](std::size_t first, std::size_t count) {
        for (std::size_t done = 0; done < count;) {
          const std::size_t n = std::min<std::size_t>(count - done, limits.work_groups);
          glUniform1ui(21, GLuint(first + done));  // u_chunk_base
          glDispatchCompute(GLuint(n), 1, 1);
          done += n;
        }
      };
      if (glossy_block_clusters == 0) {
        dispatch_chunks(0, glossy_chunks);
      } else {
        // One dispatch per uniform block of clusters, then the analytic vertices' chunks (block 0 bound, unread).
        const std::size_t blocks = glossy_block_chunks.size() - 2;
        for (std::size_t b = 0; b <= blocks; ++b) {
          const std::size_t first = glossy_block_chunks[b], count = glossy_block_chunks[b + 1] - first;
          if (count == 0) continue;
          const std::size_t block = b < blocks ? b : 0;
          glBindBufferRange(GL_UNIFORM_BUFFER, 2, glossy_rows.products, GLintptr(block * glossy_block_stride),
                            GLsizeiptr(std::size_t(glossy_block_clusters) * glossy_cluster_bytes));
          glUniform1ui(20, GLuint(block * std::size_t(glossy_block_clusters)));  // u_block_first
          dispatch_chunks(first, count);
        }
      }
    }
  }
  glMemoryBarrier(GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT);
  return radiance_buffer;
}

}  // namespace prt
