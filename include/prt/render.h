// prt/render.h - headless OpenGL 4.5 PRT renderer (EGL, no window, no display).
//
// The classic PRT runtime: every vertex's transfer vector lives on the GPU
// (a std430 float array, the layout of prt::Transfer: [vertex][channel][k]),
// and per frame only the (rotated) lighting coefficients are uploaded. The
// vertex shader takes the dot product of the two, the fragment shader outputs
// the interpolated colour (Gouraud), so pixels at vertices equal
// prt::relight() of those vertices. The environment is drawn as background,
// looked up per pixel by the view direction.
//
// Conventions (docs/CONVENTIONS.md): rotating the lighting by R moves light
// arriving from d to arrive from R d. The caller rotates the coefficients on
// the CPU (sh::Rotation) and passes the same R to set_environment_rotation(),
// so the background at view direction d shows L(R^T d).
//
// Context: eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA) (Mesa,
// llvmpipe included), falling back to the first EGL_PLATFORM_DEVICE_EXT
// device (NVIDIA), then the default display; desktop OpenGL 4.5 core, no
// surface (EGL_KHR_surfaceless_context), rendering into an RGBA32F + depth
// framebuffer object. No GL types appear here.
//
// Interactive use (prt view): Renderer(Renderer::use_current_context) takes
// the caller's current OpenGL 4.5 core context (a GLFW window's) instead of
// creating one; the caller keeps it current while calling the renderer.
// present() draws the same frame as render() into the same framebuffer
// object and blits it to the context's default framebuffer (sRGB-encoded
// when that framebuffer is sRGB-capable) instead of reading it back.
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <memory>
#include <span>
#include <string>
#include <vector>

namespace prt {

// The most bands the renderer's lighting block holds (16^2 = 256 vec4s).
inline constexpr int kMaxRenderBands = 16;

// A perspective camera; the image's vertical field of view is fov_deg, the
// horizontal one follows from the image's aspect ratio.
struct Camera {
  glm::dvec3 eye{0.0, 0.0, 3.0};
  glm::dvec3 target{0.0, 0.0, 0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  double fov_deg = 40.0;
};

// The default camera: looks from +Z toward the centre c of the mesh's
// bounding box, far enough that the bounding sphere (centre c, radius the
// largest distance from c to a vertex) fits the vertical field of view with
// a 5% margin: eye = c + (0, 0, 1.05 r / sin(fov/2)), up = +Y.
Camera default_camera(const Mesh& mesh, double fov_deg = 40.0);

// A linear RGB float image, row 0 at the top (what write_image takes).
struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // width * height * 3
  glm::vec3 at(int x, int y) const {
    const std::size_t i = (std::size_t(y) * width + x) * 3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

class Renderer {
 public:
  // Creates the headless context. Throws prt::Error("no OpenGL 4.5 context:
  // ... (EGL error 0x...)") when EGL or OpenGL 4.5 core is not available.
  Renderer();
  // Uses the OpenGL context current on the calling thread (it must be 4.5
  // core; throws prt::Error otherwise). It is not destroyed with the Renderer.
  struct UseCurrentContext {};
  static constexpr UseCurrentContext use_current_context{};
  explicit Renderer(UseCurrentContext);
  ~Renderer();
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // GL_RENDERER and GL_VERSION, e.g. "llvmpipe (LLVM 15.0.6, 256 bits), 4.5 (Core Profile) Mesa 22.3.6".
  std::string device() const;

  // Uploads positions, triangle indices and the transfer coefficients (the
  // whole transfer; any band count up to kMaxRenderBands, 1 or 3 channels).
  // Throws prt::Error when the transfer was not computed for this mesh
  // (vertex count, mesh hash) or its arrays are inconsistent.
  void set_mesh(const Mesh& mesh, const Transfer& transfer);
  void clear_mesh();
  int bands() const;  // of the uploaded transfer; 0 without a mesh

  // The lighting of the next frames: RGB coefficients, at least bands()^2
  // (extra ones are ignored). Only these bands()^2 vec4s go to the GPU.
  void set_lighting(std::span<const glm::dvec3> coeffs);

  // Background: a lat-long or cube map (uploaded once as a float texture),
  // drawn behind the mesh with the rotation of set_environment_rotation.
  // Without one the background is black.
  void set_environment(const EnvMap& map);
  void clear_environment();
  void set_environment_rotation(const glm::dmat3& R);

  // Renders a frame; throws prt::Error for a zero or too large size, a
  // degenerate camera, or a mesh without lighting.
  Image render(const Camera& camera, int width, int height);

  // Draws the frame render() would draw (width x height) and blits it to the
  // current context's default framebuffer, scaled to window_width x
  // window_height. The caller swaps buffers. Returns true when the blit
  // encodes sRGB (the default framebuffer is sRGB-capable), false when the
  // window receives linear values.
  bool present(const Camera& camera, int width, int height, int window_width, int window_height);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace prt
