// The lightmap pass (lightmap_pass.h; shaders/lightmap.comp.glsl,
// lightmap.vert.glsl, lightmap.frag.glsl).
#include "lightmap_pass.h"

#include <prt/error.h>
#include <prt/transfer.h>

#include "shaders.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>

namespace prt::detail {

namespace {

GLuint make_texture(int width, int height, const float* rgba, bool repeat) {
  GLuint tex = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &tex);
  glTextureStorage2D(tex, 1, GL_RGBA32F, width, height);
  if (rgba) glTextureSubImage2D(tex, 0, 0, 0, width, height, GL_RGBA, GL_FLOAT, rgba);
  glTextureParameteri(tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(tex, GL_TEXTURE_WRAP_S, repeat ? GL_REPEAT : GL_CLAMP_TO_EDGE);
  glTextureParameteri(tex, GL_TEXTURE_WRAP_T, repeat ? GL_REPEAT : GL_CLAMP_TO_EDGE);
  return tex;
}

// The texels the image pass writes (texel, source covered texel; the top
// bit marks a gutter): the covered texels and 4 rings of gutter
// (lightmap_sources).
std::vector<std::uint32_t> image_writes(const LightmapLayout& l, int rings) {
  const std::vector<std::uint32_t> source = lightmap_sources(l, rings);
  std::vector<std::uint8_t> covered(source.size(), 0);
  for (std::uint32_t t : l.texels) covered[t] = 1;
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < source.size(); ++i)
    if (source[i] != kNoTexel) {
      out.push_back(std::uint32_t(i));
      out.push_back(source[i] | (covered[i] ? 0u : 0x80000000u));
    }
  return out;
}

// Throws prt::Error when the lightmap's texture (a page's width by every
// page's rows, stacked as the layout indexes them) is past GL_MAX_TEXTURE_SIZE.
void check_texture_size(const LightmapLayout& l, std::uint64_t side) {
  if (std::uint64_t(l.width) <= side && std::uint64_t(l.height) <= side) return;
  if (l.pages == 1)
    throw Error(fmt::format("the lightmap's {}x{} atlas is past this OpenGL's largest texture ({} texels a side, "
                            "GL_MAX_TEXTURE_SIZE): bake a smaller one (prt precompute --lightmap WxH, each side at "
                            "most {})",
                            l.width, l.height, side, side));
  throw Error(fmt::format("the lightmap's {} is drawn from one {}x{} texture, the pages stacked, which is past this "
                          "OpenGL's largest texture ({} texels a side, GL_MAX_TEXTURE_SIZE): bake it on fewer, "
                          "larger pages (prt precompute --lightmap WxH --pages N, with W and N x H at most {}; wider "
                          "pages of fewer rows hold as many texels)",
                          lightmap_size_text(l), l.width, l.height, side, side));
}

}  // namespace

LightmapPass::LightmapPass(const Scene& scene, const LightmapTexels& texels, const LightmapTransfer& t,
                           const gl::Limits& limits) {
  check_texture_size(t.layout, limits.texture_size);
  const Transfer& tr = t.transfer;
  bands_ = tr.bands;
  channels_ = tr.channels;
  width_ = t.layout.width;
  height_ = t.layout.height;
  pages_ = t.layout.pages;
  texels_ = t.layout.texels.size();
  work_groups_ = std::max<std::uint64_t>(limits.work_groups, 1);
  const Mesh points = texel_points(texels);
  const std::size_t row_bytes = tr.stride() * sizeof(float);
  if (texels_ * row_bytes > limits.storage_block || texels_ * 16 > limits.storage_block)
    throw Error(fmt::format("the lightmap's {} texels x {} bytes of transfer exceed this OpenGL's storage block size "
                            "({} MB, GL_MAX_SHADER_STORAGE_BLOCK_SIZE): use a smaller atlas or fewer bands",
                            texels_, row_bytes, limits.storage_block >> 20));
  // Dense rows: analytic texels evaluated from their normal and albedo here.
  const std::vector<float> rows = dense_transfer(tr, points, false);
  rows_ = gl::make_buffer(rows.data(), rows.size() * sizeof(float));
  bytes_ = rows.size() * sizeof(float);
  if (!tr.direct.empty()) {
    const std::vector<float> d = dense_transfer(tr, points, true);
    direct_ = gl::make_buffer(d.data(), d.size() * sizeof(float));
    bytes_ += d.size() * sizeof(float);
  }
  radiance_ = gl::make_buffer(nullptr, std::max<std::size_t>(texels_, 1) * 16);
  sky_ = gl::make_buffer(nullptr, std::max<std::size_t>(texels_, 1) * 16);
  const std::vector<std::uint32_t> writes = image_writes(t.layout, 4);
  writes_ = writes.size() / 2;
  writes_buffer_ = gl::make_buffer(writes.data(), writes.size() * sizeof(std::uint32_t));
  texture_buffer_texels_ = limits.texture_buffer_texels;
  if (std::max(writes_, texels_) > texture_buffer_texels_)
    throw Error(fmt::format("the lightmap's {} texels and {} image writes exceed this OpenGL's buffer textures "
                            "({} texels, GL_MAX_TEXTURE_BUFFER_SIZE): use a smaller atlas",
                            texels_, writes_, texture_buffer_texels_));
  glCreateTextures(GL_TEXTURE_BUFFER, GLsizei(write_views_.size()), write_views_.data());
  glTextureBuffer(write_views_[0], GL_RGBA32F, radiance_);
  glTextureBuffer(write_views_[1], GL_RG32UI, writes_buffer_);
  lightmap_ = make_texture(width_, height_, nullptr, false);
  const float zero[4] = {0, 0, 0, 0};
  glClearTexImage(lightmap_, 0, GL_RGBA, GL_FLOAT, zero);
  const std::vector<glm::vec4> albedo = lightmap_image(t.layout, texels.albedo);
  texel_albedo_ = make_texture(width_, height_, &albedo[0].x, false);
  for (const Texture& tex : scene.textures) textures_.push_back(make_texture(tex.width, tex.height, &tex.texels[0].x, true));

  // Geometry: positions, the base colour's UVs (set 0, or zeros), the lightmap UVs.
  const Mesh& mesh = scene.mesh;
  const std::size_t V = mesh.vertex_count();
  positions_ = gl::make_buffer(mesh.positions.data(), V * sizeof(glm::vec3));
  const std::vector<glm::vec2> none(scene.uv_sets.empty() ? V : 0, glm::vec2(0.0f));
  uv_base_ = gl::make_buffer(scene.uv_sets.empty() ? none.data() : scene.uv_sets[0].data(), V * sizeof(glm::vec2));
  uv_lightmap_ = gl::make_buffer(scene.uv_sets.at(std::size_t(t.layout.uv_set)).data(), V * sizeof(glm::vec2));
  indices_ = gl::make_buffer(mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3));
  glCreateVertexArrays(1, &vao_);
  const GLuint buffers[3] = {positions_, uv_base_, uv_lightmap_};
  const GLint sizes[3] = {3, 2, 2};
  for (GLuint a = 0; a < 3; ++a) {
    glVertexArrayVertexBuffer(vao_, a, buffers[a], 0, GLsizei(sizes[a] * sizeof(float)));
    glVertexArrayAttribFormat(vao_, a, sizes[a], GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao_, a, a);
    glEnableVertexArrayAttrib(vao_, a);
  }
  glVertexArrayElementBuffer(vao_, indices_);
  for (const SceneObject& o : scene.objects) {
    Batch b;
    b.first = GLsizei(o.first_triangle * 3);
    b.count = GLsizei(o.triangle_count * 3);
    if (!tr.vertex_colors) {
      // One albedo for every texel (--albedo): it is every fragment's too,
      // so detail changes nothing; the materials' albedo is not the scene's.
      b.base_color = glm::vec4(tr.albedo, 1.0f);
    } else if (o.material >= 0) {
      const Material& m = scene.materials[std::size_t(o.material)];
      b.base_color = m.base_color;
      b.texture = m.texture_uv_set == 0 ? m.base_color_texture : -1;  // the pass samples textures at set 0
    }
    batches_.push_back(b);
  }
  draw_program_ = gl::link_program(shaders::lightmap_vert_glsl, shaders::lightmap_frag_glsl, "lightmap draw");
  gl::check_gl("uploading the lightmap");
}

LightmapPass::~LightmapPass() {
  const GLuint buffers[] = {rows_, direct_, radiance_, sky_, writes_buffer_, positions_, uv_base_, uv_lightmap_, indices_};
  for (GLuint b : buffers)
    if (b) glDeleteBuffers(1, &b);
  if (lightmap_) glDeleteTextures(1, &lightmap_);
  glDeleteTextures(GLsizei(write_views_.size()), write_views_.data());
  if (texel_albedo_) glDeleteTextures(1, &texel_albedo_);
  if (!textures_.empty()) glDeleteTextures(GLsizei(textures_.size()), textures_.data());
  if (vao_) glDeleteVertexArrays(1, &vao_);
  if (draw_program_) glDeleteProgram(draw_program_);
  for (const auto& [key, p] : programs_) glDeleteProgram(p);
}

GLuint LightmapPass::program(int pass, int coeffs) {
  const auto key = std::make_pair(pass, coeffs);
  if (auto it = programs_.find(key); it != programs_.end()) return it->second;
  const std::string defines = fmt::format("#define PASS {}\n#define COEFFS {}\n#define NC {}\n#define CHANNELS {}\n#define LAYERS {}\n", pass,
                                          pass == 0 ? coeffs : 0, bands_ * bands_, channels_, pass == 1 ? coeffs : 0);
  return programs_[key] = gl::link_compute(shaders::lightmap_comp_glsl, "lightmap relight", defines);
}

void LightmapPass::relight(int band_limit, bool direct, bool sky, const Lights& lights) {
  const auto dispatch = [&](std::size_t count) {
    glUniform1ui(0, GLuint(count));
    glUniform1ui(1, GLuint(width_));
    const std::size_t groups = (count + 63) / 64;
    for (std::size_t g = 0; g < groups; g += work_groups_) {
      glUniform1ui(2, GLuint(g * 64));
      glDispatchCompute(GLuint(std::min<std::size_t>(work_groups_, groups - g)), 1, 1);
    }
  };
  if (!radiance_sky_ && !sky_kept_) sky = true;
  if (sky) {
    glUseProgram(program(0, band_limit * band_limit));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, direct && direct_ ? direct_ : rows_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, radiance_);
    dispatch(texels_);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    radiance_sky_ = true;
    sky_kept_ = false;
  }
  // Light added into radiance_: the sky's kept aside in sky_ first, and
  // copied back into radiance_ on the relights that keep it.
  const auto bytes = GLsizeiptr(texels_ * 16);
  if (lights.add) {
    if (radiance_sky_) {
      glCopyNamedBufferSubData(radiance_, sky_, 0, 0, bytes);
      sky_kept_ = true;
    } else {
      glCopyNamedBufferSubData(sky_, radiance_, 0, 0, bytes);
    }
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    lights.add(radiance_);
    radiance_sky_ = false;
  } else if (!radiance_sky_) {
    glCopyNamedBufferSubData(sky_, radiance_, 0, 0, bytes);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    radiance_sky_ = true;
  }
  last_ = {{}, lights.layers, lights.layers ? lights.layer_count : 0};
  if (texels_ * std::size_t(last_.layer_count) > texture_buffer_texels_)
    throw Error(fmt::format("the lights' {} layers of {} texels exceed this OpenGL's buffer textures ({} texels, "
                            "GL_MAX_TEXTURE_BUFFER_SIZE): use a smaller atlas or fewer bounces",
                            last_.layer_count, texels_, texture_buffer_texels_));
  glUseProgram(program(1, last_.layer_count));
  // Attached each time: the layers' buffer is the caller's.
  glTextureBuffer(write_views_[2], GL_RGBA32F, last_.layers ? last_.layers : radiance_);
  for (std::size_t k = 0; k < write_views_.size(); ++k) glBindTextureUnit(GLuint(5 + k), write_views_[k]);
  glUniform1ui(4, GLuint(texels_));
  glBindImageTexture(0, lightmap_, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  dispatch(writes_);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  gl::check_gl("the lightmap pass");
}

void LightmapPass::draw(const glm::mat4& view_proj, bool detail) {
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  glUseProgram(draw_program_);
  glUniformMatrix4fv(0, 1, GL_FALSE, &view_proj[0][0]);
  glUniform1i(6, detail ? 1 : 0);
  glUniform1i(7, pages_);
  glBindTextureUnit(0, lightmap_);
  glBindTextureUnit(1, texel_albedo_);
  glBindVertexArray(vao_);
  for (const Batch& b : batches_) {
    glUniform4fv(4, 1, &b.base_color[0]);
    glUniform1i(5, b.texture >= 0 ? 1 : 0);
    if (b.texture >= 0) glBindTextureUnit(2, textures_[std::size_t(b.texture)]);
    glDrawElements(GL_TRIANGLES, b.count, GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(std::uintptr_t(b.first) * sizeof(std::uint32_t)));
  }
  gl::check_gl("drawing the lightmapped scene");
}

void LightmapPass::draw_geometry() const {
  glBindVertexArray(vao_);
  for (const Batch& b : batches_)
    glDrawElements(GL_TRIANGLES, b.count, GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(std::uintptr_t(b.first) * sizeof(std::uint32_t)));
}

std::vector<glm::vec3> LightmapPass::radiance() const {
  std::vector<glm::vec4> r(texels_);
  std::vector<glm::vec3> out(texels_);
  if (!texels_) return out;
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glGetNamedBufferSubData(radiance_, 0, GLsizeiptr(texels_ * 16), r.data());
  for (std::size_t i = 0; i < texels_; ++i) out[i] = glm::vec3(r[i]);
  // The layers the image's writes summed, in the same order.
  for (int k = 0; k < last_.layer_count; ++k) {
    glGetNamedBufferSubData(last_.layers, GLintptr(std::size_t(k) * texels_ * 16), GLsizeiptr(texels_ * 16), r.data());
    for (std::size_t i = 0; i < texels_; ++i) out[i] += glm::vec3(r[i]);
  }
  return out;
}

}  // namespace prt::detail
