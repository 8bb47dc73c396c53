// bench/light_bounce_figures.cpp - the figures of docs/LIGHTS.md "Bounce":
//   prt_light_bounce_figures SCENE ENV [--lightmap WxH] [--samples N] [--bounces B]
//                            [--reference-samples M] [--patches K1,K2,...] [--ratios R1,R2,...]
// For the scene's lightmap (interreflected, B bounces, N rays a texel),
// precomputed with the lights' bounce operator at each finest patch size K
// (in mean texel sizes; 0: one texel a patch) and ratio R (a hit at distance
// d goes to the coarsest patch of cell at most R d; 0: the finest always, so
// K = 0, R = 0 is the gather itself):
// 1. Storage and time: the operator's bytes per covered texel against the SH
//    lightmap's (its stored rows), its entries per receiver and per source
//    patch; the precompute's time against the same lightmap without it.
// 2. Accuracy (of the bounce alone, and in brackets of the lit texels:
//    direct + bounce): a point light in three places (the same as
//    bench/lights_figures.cpp's), its bounce (the operator applied to its
//    direct light at the texels) against prt reference's bounce (the
//    reference with the light under a black map, B bounces, M paths a texel,
//    less the direct light it shares bit for bit), relative RMS over the
//    covered texels with the reference's own noise taken out (as prt compare
//    does); beside it the sky's interreflected lightmap relit under ENV
//    against its reference under ENV at the same texels: the error the two
//    share, the discretisation of the lightmap.
#include <prt/direct_light.h>
#include <prt/envmap.h>
#include <prt/light_bounce.h>
#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/reference.h>
#include <prt/scene.h>

#include <glm/geometric.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Relative RMS of `ours` against a reference with standard errors `se`,
// over texels and channels: sqrt(max(sum |d|^2 - sum se^2, 0) / sum |ref|^2),
// the reference's own noise taken out (prt compare's correction).
double rel_rms(const std::vector<glm::vec3>& ours, const std::vector<glm::vec3>& ref, const std::vector<glm::vec3>& se) {
  double num = 0, noise = 0, den = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const glm::dvec3 d = glm::dvec3(ours[i]) - glm::dvec3(ref[i]);
    num += glm::dot(d, d);
    noise += glm::dot(glm::dvec3(se[i]), glm::dvec3(se[i]));
    den += glm::dot(glm::dvec3(ref[i]), glm::dvec3(ref[i]));
  }
  return den > 0 ? std::sqrt(std::max(num - noise, 0.0) / den) : 0.0;
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
    std::fprintf(stderr,
                 "usage: prt_light_bounce_figures SCENE ENV [--lightmap WxH] [--samples N] [--bounces B] "
                 "[--reference-samples M] [--patches K1,K2,...]\n");
    return 2;
  }
  int width = 64, height = 64, samples = 1024, bounces = 2, ref_samples = 4096;
  std::vector<double> patches{1}, ratios{0.25, 0.5, 1.0}, clusters{-1};
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string o = argv[i], v = argv[i + 1];
    if (o == "--lightmap") std::sscanf(v.c_str(), "%dx%d", &width, &height);
    else if (o == "--samples") samples = std::stoi(v);
    else if (o == "--bounces") bounces = std::stoi(v);
    else if (o == "--reference-samples") ref_samples = std::stoi(v);
    else if (o == "--patches" || o == "--ratios" || o == "--clusters") {
      std::vector<double>& list = o == "--patches" ? patches : o == "--ratios" ? ratios : clusters;
      list.clear();
      std::stringstream s(v);
      for (std::string k; std::getline(s, k, ',');) list.push_back(std::stod(k));
    }
  }
  try {
    const prt::Scene scene = prt::load_scene(argv[1]);
    const prt::EnvMap env = prt::load_envmap(argv[2]);
    prt::LightmapTexels texels = prt::lightmap_texels(scene, width, height, scene.lightmap_uv_set());
    prt::move_texels_out_of_geometry(scene.mesh, texels);
    double spacing = 0;
    for (float s : texels.texel_size) spacing += s;
    spacing /= double(texels.texel_size.size());
    prt::TransferOptions o;
    o.mode = prt::TransferMode::Interreflected;
    o.bounces = bounces;
    o.samples = samples;
    auto t0 = std::chrono::steady_clock::now();
    const prt::LightmapTransfer plain = prt::compute_lightmap_transfer(scene, texels, o);
    const double plain_s = seconds_since(t0);
    const std::size_t T = texels.positions.size();
    const double sh_bytes = double(plain.transfer.coeffs.size() * sizeof(float)) / double(T);
    std::printf("%s, %dx%d lightmap: %zu covered texels (mean texel %.4g), %d rays, %d bounces; SH lightmap %.0f bytes "
                "a texel (stored rows), precomputed in %.2f s\n\n",
                argv[1], width, height, T, spacing, samples, bounces, sh_bytes, plain_s);

    // The references: the sky's under ENV, and each light's under a black map.
    const auto hit_albedo = [&](std::uint32_t tri, float u, float v) { return scene.albedo(tri, u, v); };
    prt::ReferenceOptions ro;
    ro.mode = prt::TransferMode::Interreflected;
    ro.bounces = bounces;
    ro.samples = ref_samples;
    t0 = std::chrono::steady_clock::now();
    const prt::ReferenceResult sky_ref = prt::render_reference_at_points(scene.mesh, env, ro, texels.positions,
                                                                         texels.normals, texels.albedo, hit_albedo);
    const std::vector<glm::vec3> sky = prt::relight(plain.transfer, prt::texel_points(texels),
                                                    prt::project(env, plain.transfer.bands));
    const double sky_error = rel_rms(sky, sky_ref.radiance, sky_ref.std_error);
    std::printf("the sky's interreflected lightmap under %s against its reference (%d paths, %.1f s): %.2f%%\n\n", argv[2],
                ref_samples, seconds_since(t0), 100 * sky_error);
    const glm::dvec3 lo(scene.mesh.bounds_min()), hi(scene.mesh.bounds_max());
    const glm::dvec3 c = 0.5 * (lo + hi), e = hi - lo;
    const std::vector<std::pair<const char*, prt::Light>> lights = {
        {"centre", point(c + glm::dvec3(0.0, 0.2 * e.y, 0.0), 3.0)},
        {"by a wall", point(c + glm::dvec3(0.35 * e.x, 0.1 * e.y, -0.3 * e.z), 3.0)},
        {"low", point(c + glm::dvec3(-0.2 * e.x, -0.3 * e.y, 0.25 * e.z), 3.0)}};
    const prt::EnvMap black = prt::make_latlong(8, 4, std::vector<float>(8 * 4 * 3, 0.0f), "black");
    const prt::DirectLight traced(scene.mesh);
    std::vector<std::vector<glm::vec3>> direct, ref_bounce, ref_se, ref_total;
    for (const auto& [name, light] : lights) {
      ro.lights = {light};
      const prt::ReferenceResult r = prt::render_reference_at_points(scene.mesh, black, ro, texels.positions,
                                                                     texels.normals, texels.albedo, hit_albedo);
      direct.push_back(traced.radiance(ro.lights, texels.positions, texels.normals, texels.albedo));
      std::vector<glm::vec3> b(T);
      for (std::size_t i = 0; i < T; ++i) b[i] = r.radiance[i] - direct.back()[i];
      ref_bounce.push_back(std::move(b));
      ref_se.push_back(r.std_error);
      ref_total.push_back(r.radiance);
    }

    std::printf("| patch (texels) | ratio | patches | entries a receiver | entries a patch | bytes a texel | x SH lightmap | "
                "precompute x | bounce error: centre | by a wall | low | apply ms |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (double k : patches)
     for (double ratio : ratios) {
      o.light_bounce = true;
      o.light_bounce_patch = k > 0 ? k * spacing : 1e-4 * spacing;  // 0: one texel a patch
      o.light_bounce_ratio = ratio > 0 ? ratio : 1e-9;               // 0: the finest patches only
      t0 = std::chrono::steady_clock::now();
      const prt::LightmapTransfer lt = prt::compute_lightmap_transfer(scene, texels, o);
      const double s = seconds_since(t0);
      for (double cluster : clusters) {
      const prt::LightBounce b = cluster < 0 ? lt.transfer.light_bounce : prt::link_clusters(lt.transfer.light_bounce, int(cluster));
      const std::string linked = cluster < 0 ? "" : ", clusters " + std::to_string(int(cluster));
      std::printf("| %g | %g%s | %u | %.1f | %.1f | %.0f | %.2f | %.2f |", k, ratio, linked.c_str(), b.patches, double(b.entries()) / double(T),
                  double(b.entries()) / double(b.patches), double(b.bytes()) / double(T),
                  double(b.bytes()) / double(T) / sh_bytes, s / plain_s);
      double apply_ms = 0;
      for (std::size_t l = 0; l < lights.size(); ++l) {
        const auto a0 = std::chrono::steady_clock::now();
        const std::vector<glm::vec3> ours = prt::light_bounce(b, direct[l], texels.albedo);
        apply_ms += 1e3 * seconds_since(a0);
        // Of the bounce alone, and of the lit texels (direct + bounce, the direct exact).
        std::vector<glm::vec3> lit(T);
        for (std::size_t i = 0; i < T; ++i) lit[i] = direct[l][i] + ours[i];
        std::printf(" %.2f%% (%.2f%%) |", 100 * rel_rms(ours, ref_bounce[l], ref_se[l]),
                    100 * rel_rms(lit, ref_total[l], ref_se[l]));
      }
      std::printf(" %.2f |\n", apply_ms / double(lights.size()));
      std::fflush(stdout);
      }
    }
  } catch (const std::exception& x) {
    std::fprintf(stderr, "prt_light_bounce_figures: %s\n", x.what());
    return 1;
  }
  return 0;
}
