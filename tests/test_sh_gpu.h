// Running GLSL at many directions in a compute shader (headless EGL through
// the runtime's private context code, which the test builds in; see
// test_sh_shader and test_three_interop).
#pragma once

#include <prt/render.h>

#include "egl_context.h"
#include "gl_util.h"

#include <glm/vec3.hpp>

#include <memory>
#include <string>
#include <vector>

namespace prt::test {

// The context, made once per process; null (with why) when there is none.
inline gl::EglContext* sh_gpu_context(std::string& why) {
  static std::unique_ptr<gl::EglContext> context;
  static std::string reason;
  static bool tried = false;
  if (!tried) {
    tried = true;
    try {
      context = std::make_unique<gl::EglContext>();
      context->create();
    } catch (const NoGlContext& e) {
      reason = e.what();
      context.reset();
    }
  }
  why = reason;
  if (context) context->make_current();
  return context.get();
}

// Compiles `decls` (GLSL 4.50 declarations) with a main() that sets
// `vec3 d = dirs[i]` and runs `body` (GLSL statements writing
// outs[per * i + j] as vec4, j < per), and returns outs' xyz, `per` per
// direction. Throws prt::Error when the code does not compile or link.
inline std::vector<glm::dvec3> run_at_directions(const std::string& decls, const std::string& body, int per,
                                                 const std::vector<glm::dvec3>& dirs) {
  const std::string src =
      "#version 450\nlayout(local_size_x = 64) in;\n"
      "layout(std430, binding = 0) readonly buffer Dirs { vec4 dirs[]; };\n"
      "layout(std430, binding = 1) writeonly buffer Outs { vec4 outs[]; };\n" +
      decls +
      "void main() {\n"
      "    uint i = gl_GlobalInvocationID.x;\n"
      "    if (i >= uint(dirs.length())) return;\n"
      "    vec3 d = dirs[i].xyz;\n" +
      body + "}\n";
  const GLuint prog = gl::link_compute(src.c_str(), "test snippet", "");
  std::vector<float> in;
  for (const auto& d : dirs) in.insert(in.end(), {float(d.x), float(d.y), float(d.z), 0.0f});
  const std::size_t n = dirs.size() * std::size_t(per) * 4;
  const GLuint bin = gl::make_buffer(in.data(), in.size() * sizeof(float));
  const GLuint bout = gl::make_buffer(nullptr, n * sizeof(float), GL_DYNAMIC_STORAGE_BIT);
  glUseProgram(prog);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, bin);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, bout);
  glDispatchCompute(GLuint((dirs.size() + 63) / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<float> out(n);
  glGetNamedBufferSubData(bout, 0, GLsizeiptr(n * sizeof(float)), out.data());
  gl::check_gl("test snippet");
  glDeleteBuffers(1, &bin);
  glDeleteBuffers(1, &bout);
  glDeleteProgram(prog);
  std::vector<glm::dvec3> r;
  for (std::size_t i = 0; i < n; i += 4) r.emplace_back(out[i], out[i + 1], out[i + 2]);
  return r;
}

}  // namespace prt::test
