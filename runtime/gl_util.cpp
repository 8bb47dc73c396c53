// OpenGL helpers of the runtime. See gl_util.h.
#include "gl_util.h"

#include <prt/error.h>

#include <fmt/format.h>
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>

namespace prt::gl {

std::string hex(unsigned v) { return fmt::format("0x{:04X}", v); }

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const std::string s = std::string(" ") + list + " ";
  return s.find(std::string(" ") + name + " ") != std::string::npos;
}

const char* error_name(unsigned e) {
  switch (e) {
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
    case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_CONTEXT_LOST: return "GL_CONTEXT_LOST";
  }
  return "unknown";
}

void check_gl(const std::string& what) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR)
    throw Error(fmt::format("OpenGL error {} ({}) in {}", hex(e), error_name(e), what));
}

namespace {

// PRT_TEST_GL_LIMITS="NAME=VALUE,...": lowers the named limits (tests make
// the renderer meet them with small meshes).
void apply_test_limits(Limits& l) {
  const char* env = std::getenv("PRT_TEST_GL_LIMITS");
  if (!env || !*env) return;
  const std::string s = env;
  for (std::size_t at = 0; at < s.size();) {
    std::size_t end = s.find(',', at);
    if (end == std::string::npos) end = s.size();
    const std::string item = s.substr(at, end - at);
    at = end + 1;
    const std::size_t eq = item.find('=');
    std::uint64_t value = 0;
    const char* first = item.data() + (eq == std::string::npos ? item.size() : eq + 1);
    const auto [ptr, ec] = std::from_chars(first, item.data() + item.size(), value);
    const std::string name = item.substr(0, eq);
    std::uint64_t* field = name == "GL_MAX_SHADER_STORAGE_BLOCK_SIZE" ? &l.storage_block
                           : name == "GL_MAX_TEXTURE_BUFFER_SIZE"     ? &l.texture_buffer_texels
                           : name == "GL_MAX_COMPUTE_WORK_GROUP_COUNT" ? &l.work_groups
                           : name == "GL_MAX_TEXTURE_SIZE"             ? &l.texture_size
                                                                        : nullptr;
    if (!field || eq == std::string::npos || ec != std::errc() || ptr != item.data() + item.size() || value == 0)
      throw Error(fmt::format("PRT_TEST_GL_LIMITS: '{}' is not NAME=VALUE with NAME one of "
                              "GL_MAX_SHADER_STORAGE_BLOCK_SIZE, GL_MAX_TEXTURE_BUFFER_SIZE, "
                              "GL_MAX_COMPUTE_WORK_GROUP_COUNT, GL_MAX_TEXTURE_SIZE and VALUE a positive integer",
                              item));
    *field = std::min(*field, value);
  }
}

}  // namespace

Limits limits() {
  GLint64 block = 0, texels = 0, align = 0, side = 0;
  GLint groups = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &block);
  glGetInteger64v(GL_MAX_TEXTURE_SIZE, &side);
  glGetInteger64v(GL_MAX_TEXTURE_BUFFER_SIZE, &texels);
  glGetInteger64v(GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, &align);
  glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, 0, &groups);
  Limits l;
  l.storage_block = std::uint64_t(std::max<GLint64>(block, 0));
  l.texture_buffer_texels = std::uint64_t(std::max<GLint64>(texels, 0));
  l.work_groups = std::uint64_t(std::max<GLint>(groups, 0));
  l.storage_align = std::uint64_t(std::max<GLint64>(align, 1));
  l.texture_size = std::uint64_t(std::max<GLint64>(side, 0));
  apply_test_limits(l);
  return l;
}

std::string device_string() {
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  return std::string(renderer ? renderer : "?") + ", " + (version ? version : "?");
}

int version() {
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  return major * 10 + minor;
}

std::string with_defines(const char* src, const std::string& defines) {
  std::string text = src;
  if (!defines.empty()) text.insert(text.find('\n') + 1, defines);
  return text;
}

GLuint compile_shader(GLenum type, const char* source, const char* name) {
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

namespace {

GLuint check_link(GLuint p, const char* name) {
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

}  // namespace

GLuint link_compute(const char* src, const char* name, const std::string& defines) {
  const GLuint cs = compile_shader(GL_COMPUTE_SHADER, with_defines(src, defines).c_str(), name);
  const GLuint p = glCreateProgram();
  glAttachShader(p, cs);
  glLinkProgram(p);
  glDeleteShader(cs);
  return check_link(p, name);
}

GLuint link_program(const char* vs_src, const char* fs_src, const char* name, const std::string& defines) {
  const GLuint vs = compile_shader(GL_VERTEX_SHADER, with_defines(vs_src, defines).c_str(), name);
  GLuint fs = 0;
  try {
    fs = compile_shader(GL_FRAGMENT_SHADER, fs_src, name);
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
  return check_link(p, name);
}

GLuint make_buffer(const void* data, std::size_t bytes, GLbitfield flags) {
  GLuint b = 0;
  glCreateBuffers(1, &b);
  glNamedBufferStorage(b, GLsizeiptr(std::max<std::size_t>(bytes, 4)), bytes ? data : nullptr, flags);
  return b;
}

}  // namespace prt::gl
