// Headless OpenGL 4.5 PRT renderer: EGL context, buffers, shaders, frames.
// See prt/render.h.
#include <prt/error.h>
#include <prt/render.h>
#include <prt/transfer_io.h>

#include "shaders.h"

#define EGL_EGLEXT_PROTOTYPES 0
#include <EGL/egl.h>
#include <EGL/eglext.h>
#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

namespace prt {

namespace {

std::string hex(unsigned v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04X", v);
  return buf;
}

[[noreturn]] void egl_fail(const std::string& what) {
  throw Error("no OpenGL 4.5 context: " + what + " (EGL error " + hex(unsigned(eglGetError())) + ")");
}

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const std::string s = std::string(" ") + list + " ";
  return s.find(std::string(" ") + name + " ") != std::string::npos;
}

void check_gl(const char* what) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) throw Error(std::string("OpenGL error ") + hex(e) + " in " + what);
}

GLuint compile(GLenum type, const char* source, const char* name) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetShaderiv(s, GL_INFO_LOG_LENGTH, &len);
    std::string log(std::size_t(std::max(len, 1)), '\0');
    glGetShaderInfoLog(s, len, nullptr, log.data());
    glDeleteShader(s);
    throw Error(std::string("shader ") + name + " does not compile: " + log.c_str());
  }
  return s;
}

GLuint link(const char* vs_src, const char* fs_src, const char* name) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vs_src, name);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, fs_src, name);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  const GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  glLinkProgram(p);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetProgramiv(p, GL_INFO_LOG_LENGTH, &len);
    std::string log(std::size_t(std::max(len, 1)), '\0');
    glGetProgramInfoLog(p, len, nullptr, log.data());
    glDeleteProgram(p);
    throw Error(std::string("shader program ") + name + " does not link: " + log.c_str());
  }
  return p;
}

constexpr int kMaxCoeffs = kMaxRenderBands * kMaxRenderBands;  // LightBlock in shaders/mesh.vert.glsl

}  // namespace

Camera default_camera(const Mesh& mesh, double fov_deg) {
  if (mesh.positions.empty()) throw Error("default camera: the mesh has no vertices");
  if (!(fov_deg > 0 && fov_deg < 180)) throw Error("default camera: field of view must be in (0, 180) degrees");
  const glm::dvec3 c = (glm::dvec3(mesh.bounds_min()) + glm::dvec3(mesh.bounds_max())) * 0.5;
  double r = 0;
  for (const auto& p : mesh.positions) r = std::max(r, glm::length(glm::dvec3(p) - c));
  if (r <= 0) r = 1;
  Camera cam;
  cam.target = c;
  cam.eye = c + glm::dvec3(0, 0, 1.05 * r / std::sin(glm::radians(fov_deg) / 2));
  cam.up = {0, 1, 0};
  cam.fov_deg = fov_deg;
  return cam;
}

struct Renderer::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  bool external = false;  // the caller's context (Renderer(use_current_context)); not ours to make current or destroy

  GLuint mesh_program = 0, background_program = 0;
  GLuint vao = 0, empty_vao = 0;
  GLuint position_buffer = 0, index_buffer = 0, transfer_buffer = 0, light_buffer = 0;
  GLuint latlong_texture = 0, cube_texture = 0;
  GLuint fbo = 0, color_rb = 0, depth_rb = 0;
  int fbo_width = 0, fbo_height = 0;

  GLsizei index_count = 0;
  int bands = 0, channels = 0;
  bool have_lighting = false;
  int environment = 0;  // 0 none, 1 lat-long, 2 cube
  glm::dmat3 env_rotation{1.0};
  std::string device;

  void make_current() const {
    if (external) return;
    if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))
      throw Error("cannot make the OpenGL context current (EGL error " + hex(unsigned(eglGetError())) + ")");
  }

  void create_context();
  void check_version(const char* how);
  void create_objects();
  void draw(const Camera& cam, int width, int height);
  void destroy();
  void resize(int w, int h);
};

void Renderer::Impl::create_context() {
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  std::string tried;
  auto try_init = [&](EGLDisplay d, const char* name) {
    if (d == EGL_NO_DISPLAY) {
      tried += std::string(tried.empty() ? "" : ", ") + name + ": no display (EGL error " + hex(unsigned(eglGetError())) + ")";
      return false;
    }
    EGLint major = 0, minor = 0;
    if (!eglInitialize(d, &major, &minor)) {
      tried += std::string(tried.empty() ? "" : ", ") + name + ": eglInitialize failed (EGL error " + hex(unsigned(eglGetError())) + ")";
      return false;
    }
    display = d;
    return true;
  };
  // 1. Mesa's surfaceless platform: no X, no Wayland, no DRM device needed.
  if (get_platform_display && has_extension(client_ext, "EGL_MESA_platform_surfaceless"))
    try_init(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr), "surfaceless");
  // 2. The first EGL device (NVIDIA's headless path).
  if (display == EGL_NO_DISPLAY && get_platform_display && has_extension(client_ext, "EGL_EXT_platform_device")) {
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    EGLDeviceEXT devices[8];
    EGLint n = 0;
    if (query_devices && query_devices(8, devices, &n) && n > 0)
      try_init(get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[0], nullptr), "device");
  }
  // 3. Whatever the default display is.
  if (display == EGL_NO_DISPLAY) try_init(eglGetDisplay(EGL_DEFAULT_DISPLAY), "default display");
  if (display == EGL_NO_DISPLAY) throw Error("no OpenGL 4.5 context: no usable EGL display; tried " + tried);

  const char* ext = eglQueryString(display, EGL_EXTENSIONS);
  if (!has_extension(ext, "EGL_KHR_surfaceless_context"))
    throw Error("no OpenGL 4.5 context: the EGL display lacks EGL_KHR_surfaceless_context");
  if (!eglBindAPI(EGL_OPENGL_API)) egl_fail("eglBindAPI(EGL_OPENGL_API)");

  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                                   EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  if (!eglChooseConfig(display, config_attribs, &config, 1, &configs) || configs < 1) {
    if (!has_extension(ext, "EGL_KHR_no_config_context")) egl_fail("no EGL config renders desktop OpenGL");
    config = EGL_NO_CONFIG_KHR;
  }
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
  if (context == EGL_NO_CONTEXT) egl_fail("eglCreateContext(4.5 core)");
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) egl_fail("eglMakeCurrent(no surface)");
  check_version("EGL");
}

void Renderer::Impl::check_version(const char* how) {
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  device = std::string(renderer ? renderer : "?") + ", " + (version ? version : "?");
  if (major * 10 + minor < 45) {
    if (external) throw Error("no OpenGL 4.5 context: the current context is " + device);
    throw Error(std::string("no OpenGL 4.5 context: got ") + device + " (" + how + " error " +
                hex(unsigned(eglGetError())) + ")");
  }
}

void Renderer::Impl::create_objects() {
  mesh_program = link(shaders::mesh_vert_glsl, shaders::mesh_frag_glsl, "mesh");
  background_program = link(shaders::background_vert_glsl, shaders::background_frag_glsl, "background");
  glCreateVertexArrays(1, &vao);
  glCreateVertexArrays(1, &empty_vao);
  glCreateBuffers(1, &light_buffer);
  glNamedBufferStorage(light_buffer, GLsizeiptr(kMaxCoeffs * 4 * sizeof(float)), nullptr, GL_DYNAMIC_STORAGE_BIT);
  glCreateFramebuffers(1, &fbo);
  check_gl("creating the renderer's objects");
}

void Renderer::Impl::resize(int w, int h) {
  if (w == fbo_width && h == fbo_height) return;
  if (color_rb) glDeleteRenderbuffers(1, &color_rb);
  if (depth_rb) glDeleteRenderbuffers(1, &depth_rb);
  glCreateRenderbuffers(1, &color_rb);
  glCreateRenderbuffers(1, &depth_rb);
  glNamedRenderbufferStorage(color_rb, GL_RGBA32F, w, h);
  glNamedRenderbufferStorage(depth_rb, GL_DEPTH_COMPONENT32F, w, h);
  glNamedFramebufferRenderbuffer(fbo, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_rb);
  glNamedFramebufferRenderbuffer(fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_rb);
  const GLenum status = glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER);
  check_gl("allocating the framebuffer");
  if (status != GL_FRAMEBUFFER_COMPLETE)
    throw Error("RGBA32F framebuffer of " + std::to_string(w) + "x" + std::to_string(h) + " is incomplete (" +
                hex(status) + ")");
  fbo_width = w;
  fbo_height = h;
}

void Renderer::Impl::destroy() {
  if (display == EGL_NO_DISPLAY && !external) return;
  if (external || (context != EGL_NO_CONTEXT && eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))) {
    const GLuint buffers[] = {position_buffer, index_buffer, transfer_buffer, light_buffer};
    glDeleteBuffers(4, buffers);
    const GLuint textures[] = {latlong_texture, cube_texture};
    glDeleteTextures(2, textures);
    const GLuint rbs[] = {color_rb, depth_rb};
    glDeleteRenderbuffers(2, rbs);
    glDeleteFramebuffers(1, &fbo);
    const GLuint vaos[] = {vao, empty_vao};
    glDeleteVertexArrays(2, vaos);
    glDeleteProgram(mesh_program);
    glDeleteProgram(background_program);
    if (external) {
      external = false;  // destroyed once
      return;
    }
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  }
  if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
  // No eglTerminate: the display is shared by every Renderer of the process.
  context = EGL_NO_CONTEXT;
  display = EGL_NO_DISPLAY;
}

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {
  try {
    impl_->create_context();
    impl_->create_objects();
  } catch (...) {
    impl_->destroy();
    throw;
  }
}

Renderer::Renderer(UseCurrentContext) : impl_(std::make_unique<Impl>()) {
  impl_->external = true;
  try {
    if (!glGetString(GL_VERSION)) throw Error("no OpenGL 4.5 context: no OpenGL context is current");
    impl_->check_version("GL");
    impl_->create_objects();
  } catch (...) {
    impl_->destroy();
    throw;
  }
}

Renderer::~Renderer() {
  if (impl_) impl_->destroy();
}
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&& other) noexcept {
  if (this != &other) {
    if (impl_) impl_->destroy();
    impl_ = std::move(other.impl_);
  }
  return *this;
}

std::string Renderer::device() const { return impl_->device; }
int Renderer::bands() const { return impl_->bands; }

void Renderer::set_mesh(const Mesh& mesh, const Transfer& t) {
  if (t.vertices != mesh.vertex_count())
    throw Error("transfer has " + std::to_string(t.vertices) + " vertices, the mesh " +
                std::to_string(mesh.vertex_count()));
  check_matches(t, mesh, "transfer");
  if (t.bands < 1 || t.bands > kMaxRenderBands)
    throw Error("transfer has " + std::to_string(t.bands) + " bands; the renderer takes 1 to " +
                std::to_string(kMaxRenderBands));
  if (t.channels != 1 && t.channels != 3)
    throw Error("transfer has " + std::to_string(t.channels) + " channels (expected 1 or 3)");
  if (t.coeffs.size() != t.vertices * t.stride())
    throw Error("transfer has " + std::to_string(t.coeffs.size()) + " coefficients, expected " +
                std::to_string(t.vertices * t.stride()));
  if (mesh.triangles.empty()) throw Error("the mesh has no triangles");
  Impl& m = *impl_;
  m.make_current();
  clear_mesh();
  glCreateBuffers(1, &m.position_buffer);
  glNamedBufferStorage(m.position_buffer, GLsizeiptr(mesh.positions.size() * sizeof(glm::vec3)),
                       mesh.positions.data(), 0);
  glCreateBuffers(1, &m.index_buffer);
  glNamedBufferStorage(m.index_buffer, GLsizeiptr(mesh.triangles.size() * sizeof(glm::uvec3)),
                       mesh.triangles.data(), 0);
  glCreateBuffers(1, &m.transfer_buffer);
  glNamedBufferStorage(m.transfer_buffer, GLsizeiptr(t.coeffs.size() * sizeof(float)), t.coeffs.data(), 0);
  glVertexArrayVertexBuffer(m.vao, 0, m.position_buffer, 0, sizeof(glm::vec3));
  glVertexArrayAttribFormat(m.vao, 0, 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(m.vao, 0, 0);
  glEnableVertexArrayAttrib(m.vao, 0);
  glVertexArrayElementBuffer(m.vao, m.index_buffer);
  check_gl("uploading the mesh and transfer");
  m.index_count = GLsizei(mesh.triangles.size() * 3);
  m.bands = t.bands;
  m.channels = t.channels;
  m.have_lighting = false;
}

void Renderer::clear_mesh() {
  Impl& m = *impl_;
  m.make_current();
  const GLuint buffers[] = {m.position_buffer, m.index_buffer, m.transfer_buffer};
  glDeleteBuffers(3, buffers);
  m.position_buffer = m.index_buffer = m.transfer_buffer = 0;
  m.index_count = 0;
  m.bands = m.channels = 0;
  m.have_lighting = false;
}

void Renderer::set_lighting(std::span<const glm::dvec3> coeffs) {
  Impl& m = *impl_;
  if (m.bands == 0) throw Error("set_lighting: no mesh uploaded");
  const std::size_t n = std::size_t(m.bands) * m.bands;
  if (coeffs.size() < n)
    throw Error("lighting has " + std::to_string(coeffs.size()) + " coefficients, the transfer needs " +
                std::to_string(n) + " (" + std::to_string(m.bands) + " bands)");
  std::vector<float> v(n * 4, 0.0f);
  for (std::size_t k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) v[k * 4 + std::size_t(c)] = float(coeffs[k][c]);
  m.make_current();
  glNamedBufferSubData(m.light_buffer, 0, GLsizeiptr(v.size() * sizeof(float)), v.data());
  check_gl("uploading the lighting");
  m.have_lighting = true;
}

void Renderer::set_environment(const EnvMap& map) {
  const std::size_t expected = std::size_t(map.width) * map.height * 3 * (map.is_cube() ? 6 : 1);
  if (map.width <= 0 || map.height <= 0 || map.rgb.size() != expected)
    throw Error("environment " + map.source + ": inconsistent size");
  Impl& m = *impl_;
  m.make_current();
  clear_environment();
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (map.is_cube()) {
    glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &m.cube_texture);
    glTextureStorage2D(m.cube_texture, 1, GL_RGB32F, map.width, map.width);
    const std::size_t face = std::size_t(map.width) * map.width * 3;
    for (int f = 0; f < 6; ++f)  // faces are stored in GL's orientation and order
      glTextureSubImage3D(m.cube_texture, 0, 0, 0, f, map.width, map.width, 1, GL_RGB, GL_FLOAT,
                          map.rgb.data() + face * std::size_t(f));
    glTextureParameteri(m.cube_texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(m.cube_texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    m.environment = 2;
  } else {
    // Row 0 (the top, theta = 0) becomes t = 0.
    glCreateTextures(GL_TEXTURE_2D, 1, &m.latlong_texture);
    glTextureStorage2D(m.latlong_texture, 1, GL_RGB32F, map.width, map.height);
    glTextureSubImage2D(m.latlong_texture, 0, 0, 0, map.width, map.height, GL_RGB, GL_FLOAT, map.rgb.data());
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    m.environment = 1;
  }
  check_gl("uploading the environment map");
}

void Renderer::clear_environment() {
  Impl& m = *impl_;
  m.make_current();
  const GLuint textures[] = {m.latlong_texture, m.cube_texture};
  glDeleteTextures(2, textures);
  m.latlong_texture = m.cube_texture = 0;
  m.environment = 0;
}

void Renderer::set_environment_rotation(const glm::dmat3& R) { impl_->env_rotation = R; }

void Renderer::Impl::draw(const Camera& cam, int width, int height) {
  Impl& m = *this;
  if (width <= 0 || height <= 0)
    throw Error("image size " + std::to_string(width) + "x" + std::to_string(height) + " is empty");
  GLint max_rb = 0;
  m.make_current();
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
  if (width > max_rb || height > max_rb)
    throw Error("image size " + std::to_string(width) + "x" + std::to_string(height) + " exceeds the limit " +
                std::to_string(max_rb));
  if (m.bands > 0 && !m.have_lighting) throw Error("render: no lighting set for the mesh");
  if (!(cam.fov_deg > 0 && cam.fov_deg < 180)) throw Error("camera: field of view must be in (0, 180) degrees");
  const glm::dvec3 fwd = cam.target - cam.eye;
  if (!(glm::length(fwd) > 0) || !(glm::length(glm::cross(fwd, cam.up)) > 1e-12 * glm::length(fwd)))
    throw Error("camera: eye equals target or up is parallel to the view direction");
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(cam.eye[i]) || !std::isfinite(cam.target[i]) || !std::isfinite(cam.up[i]))
      throw Error("camera: non-finite eye, target or up");

  m.resize(width, height);
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glViewport(0, 0, width, height);
  const float black[4] = {0, 0, 0, 1};
  const float far_depth = 1.0f;
  glClearNamedFramebufferfv(m.fbo, GL_COLOR, 0, black);
  glClearNamedFramebufferfv(m.fbo, GL_DEPTH, 0, &far_depth);

  const double aspect = double(width) / height;
  const double tan_half = std::tan(glm::radians(cam.fov_deg) / 2);
  const glm::dvec3 f = glm::normalize(fwd);
  const glm::dvec3 r = glm::normalize(glm::cross(f, cam.up));
  const glm::dvec3 u = glm::cross(r, f);

  if (m.environment != 0) {
    glDisable(GL_DEPTH_TEST);
    glUseProgram(m.background_program);
    const glm::vec3 fv(f), rv(r * tan_half * aspect), uv(u * tan_half);
    const glm::mat3 rot_t(glm::transpose(m.env_rotation));
    glUniform3fv(0, 1, &fv[0]);
    glUniform3fv(1, 1, &rv[0]);
    glUniform3fv(2, 1, &uv[0]);
    glUniformMatrix3fv(3, 1, GL_FALSE, &rot_t[0][0]);
    glUniform1i(6, m.environment == 2 ? 1 : 0);
    glBindTextureUnit(0, m.latlong_texture);
    glBindTextureUnit(1, m.cube_texture);
    glBindVertexArray(m.empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }

  if (m.index_count > 0) {
    // Near/far planes from the distance to the target, generous on both sides.
    const double dist = glm::length(fwd);
    const glm::dmat4 view = glm::lookAt(cam.eye, cam.target, cam.up);
    const glm::dmat4 proj = glm::perspective(glm::radians(cam.fov_deg), aspect, dist * 1e-3, dist * 1e3);
    const glm::mat4 view_proj(proj * view);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);  // open meshes show their back faces
    glUseProgram(m.mesh_program);
    glUniformMatrix4fv(0, 1, GL_FALSE, &view_proj[0][0]);
    glUniform1i(1, m.bands * m.bands);
    glUniform1i(2, m.channels);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.transfer_buffer);
    glBindBufferBase(GL_UNIFORM_BUFFER, 1, m.light_buffer);
    glBindVertexArray(m.vao);
    glDrawElements(GL_TRIANGLES, m.index_count, GL_UNSIGNED_INT, nullptr);
  }
  glBindVertexArray(0);
  check_gl("rendering");
}

Image Renderer::render(const Camera& cam, int width, int height) {
  Impl& m = *impl_;
  m.draw(cam, width, height);
  std::vector<float> rgba(std::size_t(width) * height * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadnPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, GLsizei(rgba.size() * sizeof(float)), rgba.data());
  check_gl("reading the frame back");
  glBindFramebuffer(GL_FRAMEBUFFER, 0);

  Image img;
  img.width = width;
  img.height = height;
  img.rgb.resize(std::size_t(width) * height * 3);
  for (int y = 0; y < height; ++y) {  // GL row 0 is the bottom
    const float* src = rgba.data() + std::size_t(height - 1 - y) * width * 4;
    float* dst = img.rgb.data() + std::size_t(y) * width * 3;
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) dst[x * 3 + c] = src[x * 4 + c];
  }
  return img;
}

bool Renderer::present(const Camera& cam, int width, int height, int window_width, int window_height) {
  Impl& m = *impl_;
  m.draw(cam, width, height);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  GLint encoding = GL_LINEAR;
  glGetNamedFramebufferAttachmentParameteriv(0, GL_BACK_LEFT, GL_FRAMEBUFFER_ATTACHMENT_COLOR_ENCODING, &encoding);
  const bool srgb = encoding == GL_SRGB;
  if (srgb) glEnable(GL_FRAMEBUFFER_SRGB);
  glViewport(0, 0, window_width, window_height);
  glBlitNamedFramebuffer(m.fbo, 0, 0, 0, width, height, 0, 0, window_width, window_height, GL_COLOR_BUFFER_BIT,
                         (width == window_width && height == window_height) ? GL_NEAREST : GL_LINEAR);
  if (srgb) glDisable(GL_FRAMEBUFFER_SRGB);
  check_gl("presenting the frame");
  return srgb;
}

}  // namespace prt
