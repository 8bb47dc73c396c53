// bench/frame_bench.cpp - prt_frame_bench: frame time of the GL runtime on a
// large mesh, for whatever OpenGL 4.5 the machine gives through EGL (a GPU's
// driver, or Mesa llvmpipe), and the bandwidth it implies.
//
//   prt_frame_bench MESH [--subdivide L] [--size WxH] [--frames N] [--bands 3,4,5] [--channels 3] [--compute 1]
//
// The mesh is split L times (each triangle into 4 at its edge midpoints,
// shared edges once), transfers are synthetic (random; shading cost does not
// depend on the values), and every frame is drawn and waited for (glFinish),
// without read-back. For each band count it prints the frame time, the
// transfer bytes the vertex shader reads per frame (each vertex once: vertices
// x channels x coefficients padded to a multiple of 4, x 4 bytes), and that
// divided by the frame time; and the same frame in plain Lambert shading.
// --compute 1 also times the same dot products as a compute-shader pass (no
// rasterisation): the bandwidth the memory system gives that access pattern.
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>

#include <glm/geometric.hpp>

#include "synthetic_transfer.h"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

prt::Mesh subdivide(const prt::Mesh& in) {
  std::vector<glm::vec3> p = in.positions, n = in.normals;
  std::vector<glm::uvec3> t;
  t.reserve(in.triangles.size() * 4);
  std::map<std::pair<unsigned, unsigned>, unsigned> mid;
  auto midpoint = [&](unsigned a, unsigned b) {
    const auto key = std::minmax(a, b);
    const auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const unsigned v = unsigned(p.size());
    p.push_back(0.5f * (p[a] + p[b]));
    const glm::vec3 s = n[a] + n[b];
    n.push_back(glm::length(s) > 0 ? glm::normalize(s) : glm::vec3(0.0f));
    mid.emplace(key, v);
    return v;
  };
  for (const glm::uvec3& tri : in.triangles) {
    const unsigned ab = midpoint(tri.x, tri.y), bc = midpoint(tri.y, tri.z), ca = midpoint(tri.z, tri.x);
    t.emplace_back(tri.x, ab, ca);
    t.emplace_back(ab, tri.y, bc);
    t.emplace_back(ca, bc, tri.z);
    t.emplace_back(ab, bc, ca);
  }
  return prt::make_mesh(std::move(p), std::move(t), std::move(n), {}, {}, in.source + " (subdivided)");
}

// The same dot products as a compute shader (one invocation per vertex,
// vec4 loads from a storage buffer of the padded layout, radiance written to
// another buffer), in the renderer's context: what the arithmetic and the
// memory traffic cost without the graphics pipeline. Returns ms per pass.
double compute_pass_ms(std::size_t vertices, int coeffs, int channels, int passes) {
  const int vec4s = (coeffs + 3) / 4;
  const std::string src = "#version 450 core\nlayout(local_size_x = 256) in;\n"
                          "layout(std430, binding = 0) readonly buffer T { vec4 t[]; };\n"
                          "layout(std430, binding = 1) writeonly buffer B { vec4 b[]; };\n"
                          "layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };\n"
                          "layout(location = 0) uniform uint n;\n"
                          "void main() {\n  const uint v = gl_GlobalInvocationID.x;\n  if (v >= n) return;\n"
                          "  vec3 r = vec3(0.0);\n"
                          "  for (int c = 0; c < " + std::to_string(channels) + "; ++c)\n"
                          "    for (int i = 0; i < " + std::to_string(vec4s) + "; ++i) {\n"
                          "      const vec4 x = t[(v * " + std::to_string(channels) + "u + uint(c)) * " +
                          std::to_string(vec4s) + "u + uint(i)];\n"
                          "      r[c % 3] += dot(x, vec4(L[4*i][c], L[4*i+1][c], L[4*i+2][c], L[4*i+3][c]));\n"
                          "    }\n  b[v] = vec4(r, 1.0);\n}\n";
  const char* text = src.c_str();
  const GLuint sh = glCreateShader(GL_COMPUTE_SHADER);
  glShaderSource(sh, 1, &text, nullptr);
  glCompileShader(sh);
  GLint ok = 0;
  glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
  if (!ok) throw prt::Error("compute shader does not compile");
  const GLuint prog = glCreateProgram();
  glAttachShader(prog, sh);
  glLinkProgram(prog);
  glDeleteShader(sh);
  GLuint bufs[2];
  glCreateBuffers(2, bufs);
  const std::size_t tbytes = vertices * std::size_t(channels) * std::size_t(vec4s) * 16;
  std::vector<float> init(tbytes / 4, 0.01f);
  glNamedBufferStorage(bufs[0], GLsizeiptr(tbytes), init.data(), 0);
  glNamedBufferStorage(bufs[1], GLsizeiptr(vertices * 16), nullptr, 0);
  glUseProgram(prog);
  glUniform1ui(0, GLuint(vertices));
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, bufs[0]);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, bufs[1]);
  const GLuint groups = GLuint((vertices + 255) / 256);
  glDispatchCompute(groups, 1, 1);
  glFinish();
  const auto t0 = std::chrono::steady_clock::now();
  for (int p = 0; p < passes; ++p) glDispatchCompute(groups, 1, 1);
  glFinish();
  const double ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / passes;
  glDeleteBuffers(2, bufs);
  glDeleteProgram(prog);
  return ms;
}

double frame_ms(prt::Renderer& r, const prt::Camera& cam, int w, int h, int frames) {
  r.draw_only(cam, w, h);  // warm: compile, allocate
  const auto t0 = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) r.draw_only(cam, w, h);
  return 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / frames;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help")) {
    std::fprintf(stderr, "usage: prt_frame_bench MESH [--subdivide L] [--size WxH] [--frames N] [--bands 3,4,5] "
                         "[--channels 1|3] [--compute 1]\n");
    return argc < 2 ? 2 : 0;
  }
  std::string path = argv[1], bands_list = "3,4,5";
  int levels = 0, w = 1920, h = 1080, frames = 50, channels = 3;
  bool compute = false;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string o = argv[i], v = argv[i + 1];
    if (o == "--subdivide") levels = std::atoi(v.c_str());
    else if (o == "--size") std::sscanf(v.c_str(), "%dx%d", &w, &h);
    else if (o == "--frames") frames = std::atoi(v.c_str());
    else if (o == "--bands") bands_list = v;
    else if (o == "--channels") channels = std::atoi(v.c_str());
    else if (o == "--compute") compute = v == "1";
    else {
      std::fprintf(stderr, "unknown option %s\n", o.c_str());
      return 2;
    }
  }
  try {
    prt::Mesh mesh = prt::load_mesh(path);
    for (int l = 0; l < levels; ++l) mesh = subdivide(mesh);
    prt::Renderer r;
    const prt::EnvMap env = prt::make_latlong(2, 1, {1.0f, 0.9f, 0.8f, 0.3f, 0.4f, 0.5f});
    std::printf("device: %s\nmesh: %zu vertices, %zu triangles; image %dx%d; %d frames each\n", r.device().c_str(),
                mesh.vertex_count(), mesh.triangles.size(), w, h, frames);
    const prt::Camera cam = prt::default_camera(mesh);
    r.set_mesh(mesh, prt::bench::synthetic_transfer(mesh, 3, channels));
    r.set_lighting(prt::project(env, 3));
    r.set_shading(prt::Shading::Lambert);
    const double lambert = frame_ms(r, cam, w, h, frames);
    std::printf("plain Lambert: %.3f ms/frame (%.1f fps)\n", lambert, 1e3 / lambert);
    std::stringstream ss(bands_list);
    std::string item;
    while (std::getline(ss, item, ',')) {
      const int b = std::atoi(item.c_str());
      r.set_mesh(mesh, prt::bench::synthetic_transfer(mesh, b, channels));
      r.set_lighting(prt::project(env, b));
      const double ms = frame_ms(r, cam, w, h, frames);
      const double bytes = double(mesh.vertex_count()) * channels * ((b * b + 3) / 4 * 4) * 4.0;
      std::printf("PRT %d coefficients x %d channels: %.3f ms/frame (%.1f fps), %.2fx Lambert; transfer read %.1f MB/frame "
                  "-> %.1f GB/s\n",
                  b * b, channels, ms, 1e3 / ms, ms / lambert, bytes / 1e6, bytes / (ms * 1e-3) / 1e9);
      if (compute) {
        const double cms = compute_pass_ms(mesh.vertex_count(), b * b, channels, frames);
        std::printf("  the same dot products as a compute pass: %.3f ms -> %.1f GB/s\n", cms, bytes / (cms * 1e-3) / 1e9);
      }
    }
  } catch (const prt::Error& e) {
    std::fprintf(stderr, "prt_frame_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
