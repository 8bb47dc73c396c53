// OpenGL helpers of the runtime. See gl_util.h.
#include "gl_util.h"

#include <prt/error.h>

#include <fmt/format.h>
#include <algorithm>
#include <cstdio>

namespace prt::gl {

std::string hex(unsigned v) { return fmt::format("0x{:04X}", v); }

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const std::string s = std::string(" ") + list + " ";
  return s.find(std::string(" ") + name + " ") != std::string::npos;
}

void check_gl(const char* what) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) throw Error(std::string("OpenGL error ") + hex(e) + " in " + what);
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
