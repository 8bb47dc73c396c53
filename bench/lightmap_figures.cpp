// bench/lightmap_figures.cpp - the figures of docs/LIGHTMAPS.md that are not
// timings of the precompute (bench_lightmap.cpp has those):
//   prt_lightmap_figures SCENE LIGHTMAP.prt MAP... [--frames N]
// 1. Storage: bytes per covered texel of the float rows, of 8- and 16-bit
//    coefficient textures with a scale and bias per coefficient, and of half
//    floats; and the relit error each adds (relative RMS over the covered
//    texels against the float rows) under every MAP, turned 0, 90, 180, 270
//    degrees.
// 2. Frame: a lightmapped frame (relight + draw) at 1280 x 720 against the
//    same scene drawn from a static lightmap (an unlit textured frame), both
//    read back, N frames each, in this process.
#include <prt/envmap.h>
#include <prt/gltf.h>
#include <prt/lightmap.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/scene.h>
#include <prt/transfer_io.h>

#include <glm/geometric.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

// IEEE half rounding of a float (round to nearest even, as GPUs store RGBA16F).
float to_half(float x) {
  if (x == 0.0f || !std::isfinite(x)) return x;
  int e = 0;
  const float m = std::frexp(x, &e);  // x = m 2^e, |m| in [0.5, 1)
  if (e < -13) return std::ldexp(std::nearbyint(std::ldexp(x, 24)), -24);  // subnormal: steps of 2^-24
  return std::ldexp(std::nearbyint(std::ldexp(m, 11)), e - 11);
}

double relit_error(const prt::Transfer& shape, const std::vector<float>& rows, const std::vector<float>& approx,
                   const std::vector<glm::dvec3>& light) {
  const std::size_t stride = shape.stride(), nc = std::size_t(shape.bands) * shape.bands;
  double e2 = 0, b2 = 0;
  for (std::size_t i = 0; i * stride < rows.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const std::size_t ch = shape.channels == 1 ? 0 : std::size_t(c);
      double a = 0, b = 0;
      for (std::size_t k = 0; k < nc; ++k) {
        a += double(rows[i * stride + ch * nc + k]) * light[k][c];
        b += double(approx[i * stride + ch * nc + k]) * light[k][c];
      }
      e2 += (a - b) * (a - b);
      b2 += a * a;
    }
  return b2 > 0 ? std::sqrt(e2 / b2) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s SCENE LIGHTMAP.prt MAP... [--frames N]\n", argv[0]);
    return 2;
  }
  int frames = 20;
  std::vector<std::string> maps;
  for (int i = 3; i < argc; ++i) {
    if (std::strcmp(argv[i], "--frames") == 0 && i + 1 < argc) frames = std::atoi(argv[++i]);
    else maps.push_back(argv[i]);
  }
  try {
    const prt::Scene scene = prt::load_scene(argv[1]);
    const prt::LightmapTransfer lt = prt::read_lightmap_transfer(argv[2]);
    const prt::LightmapTexels texels = prt::lightmap_texels(scene, lt.layout.width, lt.layout.height, lt.layout.uv_set,
                                                            lt.transfer.vertex_colors ? nullptr : &lt.transfer.albedo);
    prt::check_matches(lt, texels, argv[2]);
    const prt::Transfer& t = lt.transfer;
    const std::size_t stride = t.stride();
    const std::vector<float> rows = prt::dense_transfer(t, prt::texel_points(texels));
    const prt::LightmapQuantization q8 = prt::quantize_lightmap(rows, stride, 8), q16 = prt::quantize_lightmap(rows, stride, 16);
    std::vector<float> half(rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) half[i] = to_half(rows[i]);
    std::printf("%s: %zu covered texels, %d bands, %d channel(s), %zu coefficients per texel\n", argv[2],
                lt.layout.texels.size(), t.bands, t.channels, stride);
    std::printf("bytes per texel: float %zu, half %zu, 16-bit %zu, 8-bit %zu (textures of 4: 8-bit RGBA %zu)\n",
                4 * stride, 2 * stride, 2 * stride, stride, 4 * ((stride + 3) / 4));
    std::printf("%-16s %8s %12s %12s %12s\n", "map", "turn", "8-bit", "16-bit", "half");
    for (const std::string& m : maps) {
      const std::vector<glm::dvec3> base = prt::project(prt::load_envmap(m), t.bands);
      for (int turn = 0; turn < 360; turn += 90) {
        std::vector<glm::dvec3> light(base.size());
        prt::sh::Rotation(t.bands, prt::sh::rotation_from_euler(turn, 0, 0)).apply(base, light);
        std::printf("%-16s %8d %12.3g %12.3g %12.3g\n", std::string(m.substr(m.find_last_of('/') + 1)).c_str(), turn,
                    relit_error(t, rows, q8.decoded, light), relit_error(t, rows, q16.decoded, light),
                    relit_error(t, rows, half, light));
      }
    }
    // Frames.
    prt::Renderer r;
    r.set_scene(scene, lt);
    const std::vector<glm::dvec3> light = prt::project(prt::load_envmap(maps[0]), t.bands);
    r.set_lighting(light);
    const prt::Camera cam = prt::framing_camera(scene.mesh, 60.0, 1280.0 / 720.0);
    const auto time = [&](bool relight) {
      r.set_lightmap_relight(relight);
      r.render(cam, 1280, 720);  // warm-up (and the static lightmap's one relight)
      const auto t0 = std::chrono::steady_clock::now();
      for (int f = 0; f < frames; ++f) r.render(cam, 1280, 720);
      return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / frames;
    };
    const double lit = time(true), unlit = time(false);
    std::printf("frame 1280x720 on %s: lightmapped %.2f ms, static lightmap (unlit textured) %.2f ms, ratio %.2f "
                "(target <= 2)\n",
                r.device().c_str(), lit, unlit, lit / unlit);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
