// OpenGL helpers of the runtime (private to runtime/): the GL headers with
// the 4.5 core prototypes (GLVND's libOpenGL exports them), error checks,
// shader compilation and linking with #defines, buffers, extension lists.
// Every function works on the calling thread's current context.
#pragma once

#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>

#include <cstddef>
#include <cstdint>
#include <string>

namespace prt::gl {

// "0x%04X", as GL and EGL error codes appear in messages.
std::string hex(unsigned v);

// Whether `name` is a whole word of the space-separated extension list
// (an EGL or GL extension string); false for a null list.
bool has_extension(const char* list, const char* name);

// "GL_OUT_OF_MEMORY" for 0x0505, and so on; "unknown" for a code GL does not define.
const char* error_name(unsigned error);

// Throws prt::Error("OpenGL error 0x0505 (GL_OUT_OF_MEMORY) in <what>") when
// glGetError() reports one.
void check_gl(const std::string& what);

// The implementation limits the renderer sizes its buffers and dispatches by.
// PRT_TEST_GL_LIMITS="GL_MAX_SHADER_STORAGE_BLOCK_SIZE=4096,..." lowers any
// of them but the alignment (a test hook: tests meet the limits with small
// meshes); prt::Error for a malformed value.
struct Limits {
  std::uint64_t storage_block = 0;          // GL_MAX_SHADER_STORAGE_BLOCK_SIZE, bytes
  std::uint64_t texture_buffer_texels = 0;  // GL_MAX_TEXTURE_BUFFER_SIZE, texels
  std::uint64_t work_groups = 0;            // GL_MAX_COMPUTE_WORK_GROUP_COUNT in x
  std::uint64_t storage_align = 1;          // GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, bytes
  std::uint64_t texture_size = 0;           // GL_MAX_TEXTURE_SIZE, texels a side of a 2D texture
};
Limits limits();

// GL_RENDERER ", " GL_VERSION of the current context ("?" for a missing string).
std::string device_string();
// GL_MAJOR_VERSION * 10 + GL_MINOR_VERSION of the current context (45 for 4.5).
int version();

// Inserts `defines` (e.g. "#define MODE 1\n") right after a shader's #version line.
std::string with_defines(const char* src, const std::string& defines);
// Compiles one shader; throws prt::Error("shader <name> does not compile: <log>").
GLuint compile_shader(GLenum type, const char* source, const char* name);
// A compute program with `defines`; throws prt::Error naming the program
// when it does not compile or link.
GLuint link_compute(const char* src, const char* name, const std::string& defines);
// A vertex + fragment program; `defines` go into the vertex shader.
GLuint link_program(const char* vs_src, const char* fs_src, const char* name, const std::string& defines = {});

// An immutable buffer of `bytes` (at least 4) initialised from `data`
// (uninitialised when data is null or bytes is 0), with storage `flags`.
GLuint make_buffer(const void* data, std::size_t bytes, GLbitfield flags = 0);

}  // namespace prt::gl
