// bench/lights_figures.cpp - the figures of docs/LIGHTS.md "On the GPU":
//   prt_lights_figures SCENE LIGHTMAP.prt [--frames N] [--shadow-map-size N] [--frames-only] [--one-light]
// 1. Shadow maps against traced rays: the GPU's direct light from lights at
//    the lightmap's texel sample points (Renderer::lightmap_radiance under a
//    black map) against prt::DirectLight's at the same points, relative RMS
//    over the covered texels and channels, and the fraction of texels whose
//    visibility differs (a change of a tenth of the value), for a point light
//    in three places and for a spot and the sun, at shadow-map sizes 256 to
//    4096.
// 2. Frame: 1280 x 720, the scene's lightmap relit each frame with 4 point
//    lights moving (each round a circle, so every cube is redrawn every
//    frame) and a sun turning (--one-light: one point light moving, no sun:
//    docs/LIGHTS.md "Bounce"'s frame, the light's bounce applied every frame
//    when LIGHTMAP.prt has an operator), against the static lightmapped frame (the
//    lightmap drawn, not relit: an engine's baked frame), N frames each, in
//    this process.
#include <prt/direct_light.h>
#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/render.h>
#include <prt/scene.h>
#include <prt/transfer_file.h>

#include <glm/geometric.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

struct Agreement {
  double rel_rms = 0, flipped = 0;
};
Agreement agreement(const std::vector<glm::vec3>& gpu, const std::vector<glm::vec3>& cpu) {
  double num = 0, den = 0;
  std::size_t flipped = 0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const glm::dvec3 d = glm::dvec3(gpu[i]) - glm::dvec3(cpu[i]);
    num += glm::dot(d, d);
    den += glm::dot(glm::dvec3(cpu[i]), glm::dvec3(cpu[i]));
    flipped += glm::length(d) > 0.1 * std::max(glm::length(glm::dvec3(cpu[i])), 1e-6);
  }
  return {den > 0 ? std::sqrt(num / den) : 0.0, double(flipped) / double(cpu.size())};
}

prt::Light point(glm::dvec3 at, double intensity) {
  prt::Light l;
  l.position = at;
  l.intensity = intensity;
  return l;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: prt_lights_figures SCENE LIGHTMAP.prt [--frames N]\n");
    return 2;
  }
  int frames = 20, shadow_size = prt::kDefaultShadowMapSize;
  bool table = true, one_light = false;
  for (int i = 3; i < argc; ++i) {
    if (std::strcmp(argv[i], "--frames") == 0 && i + 1 < argc) frames = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--shadow-map-size") == 0 && i + 1 < argc) shadow_size = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--frames-only") == 0) table = false;
    else if (std::strcmp(argv[i], "--one-light") == 0) one_light = true;
  }
  try {
    const prt::Scene scene = prt::load_scene(argv[1]);
    const prt::LightmapTransfer t = prt::read_transfer_as<prt::LightmapTransfer>(argv[2]);
    prt::LightmapTexels texels = prt::lightmap_texels(scene, t.layout.width, t.layout.height, t.layout.uv_set,
                                                      t.transfer.vertex_colors ? nullptr : &t.transfer.albedo);
    prt::move_texels_out_of_geometry(scene.mesh, texels);
    const prt::DirectLight traced(scene.mesh);
    prt::Renderer r;
    r.set_scene(scene, t);
    const std::size_t nc = std::size_t(t.transfer.bands) * t.transfer.bands;
    r.set_lighting(std::vector<glm::dvec3>(nc, glm::dvec3(0.0)));
    r.set_light_points(texels.positions, texels.normals, texels.albedo);
    const glm::dvec3 lo(scene.mesh.bounds_min()), hi(scene.mesh.bounds_max());
    const glm::dvec3 c = 0.5 * (lo + hi), e = hi - lo;
    const prt::Camera cam = prt::scene_camera(scene.mesh, 1280.0 / 720.0);

    // 1. Shadow maps against rays.
    prt::Light spot = point(c + glm::dvec3(0.3 * e.x, 0.45 * e.y, 0.2 * e.z), 8.0);
    spot.type = prt::LightType::Spot;
    spot.direction = glm::normalize(glm::dvec3(-0.2, -1.0, -0.1));
    spot.outer_cone = 0.7;
    prt::Light sun;
    sun.type = prt::LightType::Directional;
    sun.direction = glm::normalize(glm::dvec3(-0.6, -0.5, 0.6));
    const std::vector<std::pair<const char*, prt::Light>> cases = {
        {"point, centre", point(c + glm::dvec3(0.0, 0.2 * e.y, 0.0), 3.0)},
        {"point, by a wall", point(c + glm::dvec3(0.35 * e.x, 0.1 * e.y, -0.3 * e.z), 3.0)},
        {"point, low", point(c + glm::dvec3(-0.2 * e.x, -0.3 * e.y, 0.25 * e.z), 3.0)},
        {"spot", spot},
        {"sun", sun}};
    if (table) std::printf("| light | 256 | 512 | 1024 | 2048 | 4096 |\n|---|---|---|---|---|---|\n");
    for (const auto& [name, light] : cases) {
      if (!table) break;
      const std::vector<prt::Light> one{light};
      const std::vector<glm::vec3> cpu = traced.radiance(one, texels.positions, texels.normals, texels.albedo);
      std::printf("| %s |", name);
      for (int size : {256, 512, 1024, 2048, 4096}) {
        r.set_shadow_map_size(size);
        r.set_lights(one);
        r.render(cam, 64, 36);
        const std::vector<glm::vec3> gpu = r.lightmap_radiance();
        const Agreement a = agreement(gpu, cpu);
        std::printf(" %.2f%% (%.2f%%) |", 100 * a.rel_rms, 100 * a.flipped);
      }
      std::printf("\n");
      std::fflush(stdout);
    }

    // 2. Frames: 4 moving point lights and a turning sun against the static lightmap.
    r.set_shadow_map_size(shadow_size);
    const auto timed = [&](bool lit) {
      r.set_lights({});
      r.set_lightmap_relight(lit);
      const auto lights_at = [&](int f) {
        std::vector<prt::Light> ls;
        for (int k = 0; k < (one_light ? 1 : 4); ++k) {
          const double a = 2.0 * M_PI * (f / 40.0 + k / 4.0);
          ls.push_back(point(c + glm::dvec3(0.3 * e.x * std::cos(a), 0.2 * e.y, 0.3 * e.z * std::sin(a)), 2.0));
        }
        prt::Light s = sun;
        const double b = 0.05 * f;
        s.direction = glm::normalize(glm::dvec3(-0.6 * std::cos(b), -0.5, 0.6 + 0.2 * std::sin(b)));
        if (!one_light) ls.push_back(s);
        return ls;
      };
      if (lit) r.set_lights(lights_at(0));
      r.render(cam, 1280, 720);  // warm-up (and the static lightmap's one relight)
      int maps = 0;
      const auto t0 = std::chrono::steady_clock::now();
      for (int f = 1; f <= frames; ++f) {
        if (lit) r.set_lights(lights_at(f));
        r.render(cam, 1280, 720);
        maps += r.shadow_maps_drawn();
      }
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / frames;
      return std::make_pair(ms, double(maps) / frames);
    };
    const auto [base_ms, base_maps] = timed(false);
    const auto [lit_ms, lit_maps] = timed(true);
    std::printf("\nframe 1280x720 (%s), %d frames each:\n", r.device().c_str(), frames);
    std::printf("  static lightmapped frame: %.2f ms\n", base_ms);
    std::printf("  relit, %s: %.2f ms (%.2fx), %.1f shadow maps redrawn per frame at %d texels%s\n",
                one_light ? "1 moving point light" : "4 moving point lights and a turning sun", lit_ms, lit_ms / base_ms,
                lit_maps, shadow_size, t.transfer.light_bounce.empty() ? "" : ", the lights' bounce every frame");
    (void)base_maps;
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "prt_lights_figures: %s\n", ex.what());
    return 1;
  }
  return 0;
}
