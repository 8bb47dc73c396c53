// bench/lights_figures.cpp - the figures of docs/LIGHTS.md "On the GPU":
//   prt_lights_figures SCENE LIGHTMAP.prt [--frames N] [--shadow-map-size N] [--frames-only] [--one-light]
//                      [--bounce-budget W]...
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
//    docs/LIGHTS.md "Bounce"'s frame: the sky kept, the light's direct light
//    and bounce added again each frame when LIGHTMAP.prt has an operator,
//    whole and within each --bounce-budget), against the static lightmapped
//    frame (the lightmap drawn, not relit: an engine's baked frame), N frames
//    each, in this process.
// 3. With --one-light and an operator, for each --bounce-budget: how the
//    bounce converges over frames after the light jumps, and how far each
//    frame is from the converged one while it moves.
#include <prt/direct_light.h>
#include <prt/light_bounce.h>
#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/render.h>
#include <prt/scene.h>
#include <prt/transfer_file.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <optional>
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

// 3. The bounce's convergence over frames: the light jumps (from the
// circle's start to a quarter turn on), or moves along the circle (1/40 of a
// turn a frame); each frame's lit texels against the converged frame of the
// same light (a second renderer, whole bounce).
void convergence(const prt::Scene& scene, const prt::LightmapTransfer& t, const prt::LightmapTexels& texels,
                 prt::Renderer& r, const prt::Camera& cam, int shadow_size,
                 const std::function<std::vector<prt::Light>(double)>& lights_at,
                 const std::vector<std::uint64_t>& budgets) {
  const std::size_t nc = std::size_t(t.transfer.bands) * t.transfer.bands;
  prt::Renderer whole;
  whole.set_scene(scene, t);
  whole.set_lighting(std::vector<glm::dvec3>(nc, glm::dvec3(0.0)));
  whole.set_light_points(texels.positions, texels.normals, texels.albedo);
  whole.set_shadow_map_size(shadow_size);
  const auto converged = [&](double f) {
    whole.set_lights(lights_at(f));
    whole.render(cam, 64, 36);
    return whole.lightmap_radiance();
  };
  for (std::uint64_t budget : budgets) {
    r.set_light_bounce_budget(0);
    r.set_lights(lights_at(0));
    r.render(cam, 64, 36);
    r.set_light_bounce_budget(budget);
    r.set_lights(lights_at(10));
    const std::vector<glm::vec3> goal = converged(10);
    std::printf("  budget %llu, the light jumped a quarter turn: lit texels' relative RMS to the converged frame",
                static_cast<unsigned long long>(budget));
    int n = 0;
    do {
      r.render(cam, 64, 36);
      ++n;
      if (n <= 4 || r.light_bounce_done()) std::printf(" %d: %.2f%%", n, 100 * agreement(r.lightmap_radiance(), goal).rel_rms);
    } while (!r.light_bounce_done() && n < 1000);
    std::printf(" (done after %d frames)\n", n);
    double worst = 0, sum = 0;
    const int moving = 20;
    for (int f = 1; f <= moving; ++f) {
      r.set_lights(lights_at(10 + f));
      r.render(cam, 64, 36);
      const double err = agreement(r.lightmap_radiance(), converged(10 + f)).rel_rms;
      worst = std::max(worst, err);
      sum += err;
    }
    std::printf("  budget %llu, the light moving 1/40 turn a frame: mean %.2f%%, worst %.2f%% over %d frames\n",
                static_cast<unsigned long long>(budget), 100 * sum / moving, 100 * worst, moving);
    std::fflush(stdout);
  }
}

struct Timing {
  double lit_ms = 0, static_ms = 0, maps = 0;
};
// Section 2's frames: `frames` of `r` with the lights moving (the sky relit
// with them unless `one_light`) and as many static frames of `still`, in runs
// of kRun each, so that neither pays for the other's caches more than once
// a run; the medians (this machine's other work makes outliers).
Timing time_frames(prt::Renderer& r, prt::Renderer& still, const prt::Camera& cam, bool one_light,
                   std::uint64_t budget, int frames, const std::function<std::vector<prt::Light>(double)>& lights_at) {
  const auto median = [](std::vector<double> ms) {
    std::nth_element(ms.begin(), ms.begin() + std::ptrdiff_t(ms.size() / 2), ms.end());
    return ms[ms.size() / 2];
  };
  const auto clock = [](const std::function<void()>& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  r.set_lights({});
  r.set_lightmap_relight(!one_light);
  r.set_light_bounce_budget(budget);
  r.set_lights(lights_at(0));
  r.render(cam, 1280, 720);  // warm-up
  int maps = 0;
  std::vector<double> lit, base;
  constexpr int kRun = 5;
  for (int f = 1, moved = 0; moved < frames; ++f) {
    if ((f / kRun) % 2 == 0) {
      base.push_back(clock([&] { still.render(cam, 1280, 720); }));
      continue;
    }
    ++moved;
    lit.push_back(clock([&] {
      r.set_lights(lights_at(moved));
      r.render(cam, 1280, 720);
    }));
    maps += r.shadow_maps_drawn();
  }
  return Timing{median(lit), median(base), double(maps) / frames};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: prt_lights_figures SCENE LIGHTMAP.prt [--frames N]\n");
    return 2;
  }
  int frames = 20, shadow_size = prt::kDefaultShadowMapSize;
  bool table = true, one_light = false;
  std::vector<std::uint64_t> budgets;  // --bounce-budget, each measured
  int link = -1;                       // --link-clusters K: prt::link_clusters(operator, K) first
  for (int i = 3; i < argc; ++i) {
    if (std::strcmp(argv[i], "--frames") == 0 && i + 1 < argc) frames = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--shadow-map-size") == 0 && i + 1 < argc) shadow_size = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--frames-only") == 0) table = false;
    else if (std::strcmp(argv[i], "--one-light") == 0) one_light = true;
    else if (std::strcmp(argv[i], "--link-clusters") == 0 && i + 1 < argc) link = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--bounce-budget") == 0 && i + 1 < argc) budgets.push_back(std::strtoull(argv[++i], nullptr, 10));
  }
  try {
    const prt::Scene scene = prt::load_scene(argv[1]);
    prt::LightmapTransfer t = prt::read_transfer_as<prt::LightmapTransfer>(argv[2]);
    if (link >= 0) t.transfer.light_bounce = prt::link_clusters(t.transfer.light_bounce, link);
    if (!t.transfer.light_bounce.empty())
      std::printf("light-bounce operator: %.1f entries a texel\n",
                  double(t.transfer.light_bounce.entries()) / double(t.transfer.light_bounce.points()));
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
    // The direct light alone: with an operator in the file, a renderer of
    // the transfer without it (the bounce is section 3's).
    std::optional<prt::Renderer> plain;
    if (table && !t.transfer.light_bounce.empty()) {
      prt::LightmapTransfer direct_only = t;
      direct_only.transfer.light_bounce = {};
      plain.emplace();
      plain->set_scene(scene, direct_only);
      plain->set_lighting(std::vector<glm::dvec3>(nc, glm::dvec3(0.0)));
      plain->set_light_points(texels.positions, texels.normals, texels.albedo);
    }
    prt::Renderer& shadows = plain ? *plain : r;
    if (table) std::printf("| light | 256 | 512 | 1024 | 2048 | 4096 |\n|---|---|---|---|---|---|\n");
    for (const auto& [name, light] : cases) {
      if (!table) break;
      const std::vector<prt::Light> one{light};
      const std::vector<glm::vec3> cpu = traced.radiance(one, texels.positions, texels.normals, texels.albedo);
      std::printf("| %s |", name);
      for (int size : {256, 512, 1024, 2048, 4096}) {
        shadows.set_shadow_map_size(size);
        shadows.set_lights(one);
        shadows.render(cam, 64, 36);
        const std::vector<glm::vec3> gpu = shadows.lightmap_radiance();
        const Agreement a = agreement(gpu, cpu);
        std::printf(" %.2f%% (%.2f%%) |", 100 * a.rel_rms, 100 * a.flipped);
      }
      std::printf("\n");
      std::fflush(stdout);
    }

    // 2. Frames: 4 moving point lights and a turning sun against the static lightmap.
    r.set_shadow_map_size(shadow_size);
    const auto lights_at = [&](double f) {
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
    // The sky is relit every frame with the lights (4 lights and a sun: the
    // sun turns with it) or kept (one light moving: only the lights' part is
    // added again to the sky's radiance, as an engine's static lightmap).
    // The static frame is drawn by a second renderer of the same scene, in
    // runs between the lit ones, so that both see the same load on this
    // shared machine (whose speed drifts by tens of percent in minutes).
    prt::Renderer still;
    still.set_scene(scene, t);
    still.set_lighting(std::vector<glm::dvec3>(nc, glm::dvec3(0.0)));
    still.set_lightmap_relight(false);
    still.render(cam, 1280, 720);  // its one relight
    const bool bounce = !t.transfer.light_bounce.empty();
    std::printf("\nframe 1280x720 (%s), the median of %d frames each, the static lightmapped frame drawn in runs "
                "between the lit ones:\n",
                r.device().c_str(), frames);
    std::vector<std::uint64_t> runs{0};
    if (bounce) runs.insert(runs.end(), budgets.begin(), budgets.end());
    for (std::uint64_t budget : runs) {
      const Timing m = time_frames(r, still, cam, one_light, budget, frames, lights_at);
      std::printf("  relit, %s: %.2f ms against the static frame's %.2f ms (%.2fx; the lights' update %.2f ms, %.2fx the "
                  "static frame), %.1f shadow maps redrawn per frame at %d texels%s\n",
                  one_light ? "1 moving point light" : "4 moving point lights and a turning sun", m.lit_ms, m.static_ms,
                  m.lit_ms / m.static_ms, m.lit_ms - m.static_ms, (m.lit_ms - m.static_ms) / m.static_ms, m.maps,
                  shadow_size,
                  !bounce          ? ""
                  : budget == 0    ? ", its bounce whole every frame"
                                   : (", its bounce within " + std::to_string(budget) + " units a frame").c_str());
      std::fflush(stdout);
    }
    if (bounce && one_light) convergence(scene, t, texels, r, cam, shadow_size, lights_at, budgets);
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "prt_lights_figures: %s\n", ex.what());
    return 1;
  }
  return 0;
}
