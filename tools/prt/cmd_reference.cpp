// prt reference: Monte Carlo ground truth of per-vertex outgoing radiance
// (no spherical harmonics), written as a vertex CSV with standard errors.
#include "commands.h"
#include "light_options.h"
#include "progress_bar.h"
#include "lightmap_inputs.h"
#include "subsurface_options.h"

#include <prt/vertex_csv.h>
#include <prt/compare.h>

#include <glm/geometric.hpp>
#include <prt/envmap.h>
#include <prt/io.h>
#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/mesh.h>
#include <prt/reference.h>
#include <prt/subsurface_reference.h>
#include <prt/rotation.h>

#include <fmt/core.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>

namespace prt::cli {

namespace {

struct ReferenceArgs {
  std::string mesh, env, output, mode = "shadowed", albedo = "0.8,0.8,0.8", rotate, material = "diffuse", eye;
  std::vector<const CLI::Option*> glossy_opts;  // --material glossy only
  ReferenceOptions opt;
  MeshOptions mesh_opt;
  int threads = 0;
  bool quiet = false;
  std::string lightmap;  // --lightmap WxH: the texels of prt precompute --lightmap, as an RGBA EXR
  int uv = -1;
  const CLI::Option *lightmap_opt = nullptr, *uv_opt = nullptr, *albedo_opt = nullptr;
  std::string lightmap_uv = "scene";  // --lightmap-uv, --uv-padding: as prt precompute's
  int uv_padding = 2;
  const CLI::Option *lightmap_uv_opt = nullptr, *uv_padding_opt = nullptr;
  std::string pages = "1";  // --pages, --texel-size: as prt precompute's
  double texel_size = 0;
  const CLI::Option *pages_opt = nullptr, *texel_opt = nullptr;
  std::string at;  // --at POINTS.csv: E(p, n)/pi at query points (what a probe volume gives there)
  LightArgs light;  // --lights, --sun (docs/LIGHTS.md)
  SubsurfaceArgs sss;  // --material subsurface: --sss, --sigma-a, --sigma-s, --eta, --length-scale
  const CLI::Option* samples_opt = nullptr;
};

// ENV (or `none`: black, the lights alone), a lat-long map; with --sun auto
// its sun taken out into the lights. Adds the scene's and --lights files'
// lights to a.opt.lights (`scene_lights`: the loaded scene's; null: read
// from MESH).
EnvMap reference_map(ReferenceArgs& a, const std::vector<Light>* scene_lights) {
  EnvMap map = a.env == "none" ? make_latlong(2, 1, std::vector<float>(6, 0.0f), "none (no environment)")
                               : load_envmap(a.env);
  require_finite(map);
  if (map.is_cube()) throw Error(a.env + ": prt reference needs a lat-long (2:1) map, not " + map.source_layout);
  a.opt.lights = command_lights(a.light, a.mesh, scene_lights);
  if (auto sun = take_sun(a.light, map, a.opt.rotation, a.quiet)) a.opt.lights.push_back(std::move(*sun));
  if (!a.quiet && !a.opt.lights.empty()) fmt::print(stderr, "lit by {} beside the map\n", describe_lights(a.opt.lights));
  return map;
}

// --at POINTS.csv: the radiance a white Lambertian surface at each point,
// facing its normal, reflects: E(p, n)/pi by Monte Carlo from p itself
// (no probes), what prt relight SCENE probes.prt ENV --at gives
// (docs/PROBES.md). Surfaces the paths hit reflect the scene's materials
// (or --albedo).
int run_at(ReferenceArgs& a) {
  if (a.opt.glossy) throw UsageError("--at: the reference at query points is diffuse (no --material glossy)");
  if (a.opt.vertex_colors) throw UsageError("--vertex-colors does not apply to --at");
  std::string ext = std::filesystem::path(a.output).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".csv") throw UsageError("--output: " + a.output + ": the reference at query points is a .csv (point,r,g,b,...)");
  check_not_input("--output", a.output, {{"SCENE", a.mesh}, {"ENV", a.env}, {"--at", a.at}});
  for_path("--output", [&] { check_writable(a.output); });
  std::unique_ptr<tbb::global_control> limit;
  if (a.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);
  const auto t0 = std::chrono::steady_clock::now();
  const prt::Scene scene = load_scene_or_mesh(a.mesh, a.mesh_opt);
  const bool override_albedo = a.albedo_opt->count() > 0 || scene.materials.empty();
  const glm::vec3 albedo = a.opt.albedo;
  const QueryPoints q = read_points_csv(a.at);
  const EnvMap map = reference_map(a, &scene.lights);
  std::vector<glm::vec3> positions(q.positions.size()), normals(q.normals.size()), white(q.positions.size(), glm::vec3(1.0f));
  for (std::size_t i = 0; i < positions.size(); ++i) {
    positions[i] = glm::vec3(q.positions[i]);
    normals[i] = glm::vec3(q.normals[i]);
  }
  const std::function<glm::vec3(std::uint32_t, float, float)> hit_albedo = [&](std::uint32_t tri, float u, float v) {
    return override_albedo ? albedo : glm::clamp(scene.albedo(tri, u, v), 0.0f, 1.0f);
  };
  Outputs out("reference");
  const std::optional<ReferenceResult> computed = run_with_progress(a.quiet, "reference", [&](const Progress& progress) {
    return render_reference_at_points(scene.mesh, map, a.opt, positions, normals, white, hit_albedo, progress);
  });
  if (!computed) return 130;
  out.write([&] { write_vertex_csv(a.output, computed->radiance, &computed->std_error, CsvKey::Point); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet)
    fmt::print(stderr, "wrote {}: {} points, {}, {} samples/point, {:.2f} s\n", a.output, positions.size(),
               transfer_mode_name(a.opt.mode), a.opt.samples,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return 0;
}

// What --material subsurface refuses, at vertices and texels alike.
void check_subsurface_reference(ReferenceArgs& a) {
  const char* why = "does not apply to --material subsurface";
  if (!a.at.empty()) throw UsageError(fmt::format("--at {} (the reference is at the mesh's vertices)", why));
  if (a.opt.vertex_colors) throw UsageError(fmt::format("--vertex-colors {} (the material's profile is its colour)", why));
  if (a.albedo_opt->count() > 0)
    throw UsageError(fmt::format("--albedo {} (the material's coefficients give its reflectance)", why));
  for (const CLI::Option* o : a.glossy_opts)
    if (o->count() > 0) throw UsageError(o->get_name() + " applies to --material glossy only");
  if (a.light.given())
    throw UsageError("--lights and --sun do not apply to --material subsurface: the reference is lit by the map alone");
  if (a.opt.mode == TransferMode::Unshadowed)
    throw UsageError("--mode unshadowed does not apply to --material subsurface (a translucent transfer is shadowed "
                     "or interreflected)");
  if (a.opt.offset < 0 || !std::isfinite(a.opt.offset))
    throw UsageError("--offset: must be a finite number >= 0 (0: 1e-4 x the bounding-box diagonal)");
  if (a.samples_opt->count() == 0) a.opt.samples = kSubsurfaceReferenceSamples;
}

// --lightmap WxH: the reference at the texel sample points prt precompute
// --lightmap traces (the same rasterisation, the same samples moved out of
// geometry), written in the relit lightmap's layout.
int run_lightmap(ReferenceArgs& a, const SubsurfaceRecord* sss = nullptr) {
  if (sss) check_subsurface_reference(a);
  if (a.opt.glossy) throw UsageError("--lightmap: a lightmap is diffuse (no --material glossy)");
  if (a.opt.vertex_colors) throw UsageError("--vertex-colors does not apply to --lightmap (the scene's materials are the albedo)");
  int width = 0, height = 0;
  for_option("--lightmap", [&] { parse_lightmap_size(a.lightmap, width, height); });
  std::string ext = std::filesystem::path(a.output).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".exr") throw UsageError("--output: " + a.output + ": a lightmap reference is an RGBA float EXR (.exr)");
  for_path("--output", [&] { check_writable(a.output); });
  std::unique_ptr<tbb::global_control> limit;
  if (a.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);
  const auto t0 = std::chrono::steady_clock::now();
  const SceneToBake bake = load_scene_to_bake(
      a.mesh, a.mesh_opt,
      {a.lightmap_uv, a.uv, a.uv_padding, a.pages, a.texel_size, a.uv_opt, a.uv_padding_opt, a.pages_opt, a.texel_opt},
      width, height, a.quiet);
  const prt::Scene& scene = bake.scene;
  if (!a.quiet) fmt::print(stderr, "{}\n", describe(scene));
  const EnvMap map = reference_map(a, sss ? nullptr : &scene.lights);  // a translucent transfer is the map's alone
  const bool override_albedo = a.albedo_opt->count() > 0;
  const glm::vec3 albedo = a.opt.albedo;
  LightmapTexels texels = lightmap_texels(scene, bake.atlas, override_albedo ? &albedo : nullptr);
  move_texels_out_of_geometry(scene.mesh, texels, a.opt.offset);
  const std::function<glm::vec3(std::uint32_t, float, float)> hit_albedo = [&](std::uint32_t tri, float u, float v) {
    return override_albedo ? albedo : scene.albedo(tri, u, v);
  };
  Outputs out("reference");
  if (!a.quiet && sss) fmt::print(stderr, "{}\n", describe_subsurface(*sss));
  const std::optional<ReferenceResult> computed = run_with_progress(a.quiet, "reference", [&](const Progress& progress) {
    if (sss)  // each texel at its point on its triangle, where prt precompute's surface integral receives it
      return render_subsurface_reference_at_points(scene.mesh, map, a.opt, *sss, texel_surface_points(scene.mesh, texels),
                                                   texels.normals, progress);
    return render_reference_at_points(scene.mesh, map, a.opt, texels.positions, texels.normals, texels.albedo,
                                      hit_albedo, progress);
  });
  if (!computed) return 130;
  const ReferenceResult& r = *computed;
  RgbaImage image = lightmap_rgba(texels.layout, r.radiance);
  // The standard errors beside (covered texels only), for prt compare's noise correction.
  image.std_error.assign(std::size_t(image.width) * std::size_t(image.height) * 3, 0.0f);
  for (std::size_t i = 0; i < r.std_error.size(); ++i)
    for (int c = 0; c < 3; ++c) image.std_error[3 * std::size_t(texels.layout.texels[i]) + std::size_t(c)] = r.std_error[i][c];
  write_lightmap_pages(out, a.output, texels.layout, std::move(image));
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet) {
    double se2 = 0, b2 = 0;
    for (std::size_t v = 0; v < r.radiance.size(); ++v) {
      se2 += double(glm::dot(r.std_error[v], r.std_error[v]));
      b2 += double(glm::dot(r.radiance[v], r.radiance[v]));
    }
    fmt::print(stderr, "wrote {}: lightmap {}, {} covered texels, {}, {} samples/texel, {:.2f} s\n", a.output,
               lightmap_size_text(texels.layout), r.radiance.size(), transfer_mode_name(a.opt.mode), a.opt.samples,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    fmt::print(stderr, "standard error: {:.3g} relative RMS\n", b2 > 0 ? std::sqrt(se2 / b2) : 0.0);
  }
  return 0;
}

// --material subsurface: L_o of a translucent mesh by probe-sampling the
// dipole (prt/subsurface_reference.h, docs/SUBSURFACE.md "The reference"),
// per vertex, written as the diffuse reference's CSV.
int run_subsurface(ReferenceArgs& a, const SubsurfaceRecord& record) {
  check_subsurface_reference(a);
  if (a.uv_opt->count() > 0) throw UsageError("--uv picks the lightmap's UV set: give --lightmap WxH too");
  for (const CLI::Option* o : {a.lightmap_uv_opt, a.uv_padding_opt, a.pages_opt, a.texel_opt})
    if (o->count() > 0) throw UsageError(o->get_name() + " shapes a lightmap's atlas: give --lightmap WxH too");
  for_path("--output", [&] { check_writable(a.output); });

  std::unique_ptr<tbb::global_control> limit;
  if (a.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);
  const auto t0 = std::chrono::steady_clock::now();
  const Mesh mesh = load_mesh(a.mesh, a.mesh_opt);
  if (!a.quiet) fmt::print(stderr, "{}\n", describe(mesh));
  EnvMap map = a.env == "none" ? make_latlong(2, 1, std::vector<float>(6, 0.0f), "none (no environment)")
                               : load_envmap(a.env);
  require_finite(map);
  if (map.is_cube()) throw Error(a.env + ": prt reference needs a lat-long (2:1) map, not " + map.source_layout);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n", describe(map), describe_subsurface(record));

  Outputs out("reference");
  const std::optional<ReferenceResult> computed =
      run_with_progress(a.quiet, "reference", [&](const Progress& progress) {
        return render_subsurface_reference(mesh, map, a.opt, record, progress);
      });
  if (!computed) return 130;
  const ReferenceResult& r = *computed;
  out.write([&] { write_vertex_csv(a.output, r.radiance, &r.std_error); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet) {
    double se2 = 0, b2 = 0;
    for (std::size_t v = 0; v < r.radiance.size(); ++v) {
      se2 += double(glm::dot(r.std_error[v], r.std_error[v]));
      b2 += double(glm::dot(r.radiance[v], r.radiance[v]));
    }
    fmt::print(stderr, "wrote {}: {} vertices, subsurface, {}{}, {} iterations/vertex, {:.2f} s\n", a.output,
               r.radiance.size(), transfer_mode_name(a.opt.mode),
               a.opt.mode == TransferMode::Interreflected ? fmt::format(" ({} bounces)", a.opt.bounces) : "",
               a.opt.samples, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    fmt::print(stderr, "standard error: {:.3g} relative RMS\n", b2 > 0 ? std::sqrt(se2 / b2) : 0.0);
  }
  return 0;
}

int run_reference(ReferenceArgs& a) {
  // Every option and the output path before any loading (each value alone
  // was checked while parsing).
  check_not_input("--output", a.output, {{"MESH", a.mesh}, {"ENV", a.env}});
  a.opt.mode = for_option("--mode", [&] { return parse_transfer_mode(a.mode); });
  double rgb[3];
  parse_triple(a.albedo, "--albedo", rgb);
  a.opt.albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  if (!a.rotate.empty()) {
    double e[3];
    parse_triple(a.rotate, "--rotate", e);
    a.opt.rotation = sh::rotation_from_euler(e[0], e[1], e[2]);
  }
  if (const std::optional<SubsurfaceRecord> sss = subsurface_record(a.sss, a.material))
    return a.lightmap_opt->count() > 0 ? run_lightmap(a, &*sss) : run_subsurface(a, *sss);
  if (a.lightmap_opt->count() > 0) {
    if (!a.at.empty()) throw UsageError("--at and --lightmap are two runs (query points, a lightmap's texels)");
    a.opt.glossy = a.material == "glossy";
    return run_lightmap(a);
  }
  if (!a.at.empty()) {
    a.opt.glossy = a.material == "glossy";
    return run_at(a);
  }
  if (a.uv_opt->count() > 0) throw UsageError("--uv picks the lightmap's UV set: give --lightmap WxH too");
  for (const CLI::Option* o : {a.lightmap_uv_opt, a.uv_padding_opt, a.pages_opt, a.texel_opt})
    if (o->count() > 0) throw UsageError(o->get_name() + " shapes a lightmap's atlas: give --lightmap WxH too");
  a.opt.glossy = a.material == "glossy";
  for (const CLI::Option* o : a.glossy_opts)
    if (o->count() > 0 && !a.opt.glossy) throw UsageError(o->get_name() + " applies to --material glossy only");
  if (a.opt.glossy) {
    if (a.eye.empty()) throw UsageError("--material glossy needs --eye x,y,z (the point the vertices are seen from)");
    if (a.opt.mode == TransferMode::Unshadowed)
      throw UsageError("--material glossy needs --mode shadowed or interreflected");
    double e[3];
    parse_triple(a.eye, "--eye", e);
    a.opt.eye = {e[0], e[1], e[2]};
  }
  if (a.opt.offset < 0 || !std::isfinite(a.opt.offset))
    throw UsageError("--offset: must be a finite number >= 0 (0: 1e-4 x the bounding-box diagonal)");
  for_path("--output", [&] { check_writable(a.output); });

  std::unique_ptr<tbb::global_control> limit;
  if (a.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);

  const auto t0 = std::chrono::steady_clock::now();
  const Mesh mesh = load_mesh(a.mesh, a.mesh_opt);
  if (!a.quiet) fmt::print(stderr, "{}\n", describe(mesh));
  const EnvMap map = reference_map(a, nullptr);
  if (!a.quiet) fmt::print(stderr, "{}\n", describe(map));
  if (a.opt.vertex_colors && mesh.colors.empty())
    fmt::print(stderr, "warning: {} has no vertex colours; using --albedo {}\n", a.mesh, a.albedo);

  Outputs out("reference");  // from here Ctrl-C stops cleanly, the write step included
  const std::optional<ReferenceResult> computed = run_with_progress(
      a.quiet, "reference", [&](const Progress& progress) { return render_reference(mesh, map, a.opt, progress); });
  if (!computed) return 130;
  const ReferenceResult& r = *computed;
  out.write([&] { write_vertex_csv(a.output, r.radiance, &r.std_error); });
  if (const int rc = out.commit(); rc != 0) return rc;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!a.quiet) {
    // Noise summary: relative RMS of the standard errors (what `prt compare`
    // cannot resolve below) and the worst vertex.
    double se2 = 0, b2 = 0, worst = 0;
    for (std::size_t v = 0; v < r.radiance.size(); ++v) {
      se2 += double(glm::dot(r.std_error[v], r.std_error[v]));
      b2 += double(glm::dot(r.radiance[v], r.radiance[v]));
      worst = std::max(worst, double(std::max({r.std_error[v].x, r.std_error[v].y, r.std_error[v].z})));
    }
    fmt::print(stderr, "wrote {}: {} vertices, {}{}{}, {} samples/vertex, {:.2f} s\n", a.output, r.radiance.size(),
               transfer_mode_name(a.opt.mode),
               a.opt.mode == TransferMode::Interreflected ? fmt::format(" ({} bounces)", a.opt.bounces) : "",
               a.opt.glossy ? fmt::format(", glossy e {:g} rho_s {:g} from {:g},{:g},{:g}", a.opt.gloss,
                                          a.opt.specular, a.opt.eye.x, a.opt.eye.y, a.opt.eye.z)
                            : "",
               a.opt.samples, secs);
    fmt::print(stderr, "standard error: {:.3g} relative RMS, largest {:.3g}\n", b2 > 0 ? std::sqrt(se2 / b2) : 0.0,
               worst);
  }
  return 0;
}

}  // namespace

Run add_reference(CLI::App& app) {
  auto a = std::make_shared<ReferenceArgs>();
  CLI::App* s = app.add_subcommand(
      "reference", "Ground-truth per-vertex radiance by Monte Carlo against the map itself (no SH), as CSV");
  s->footer(
      "Estimates B = (albedo/pi) integral L(w) V(w) max(n.w,0) dw per vertex (interreflected: plus diffuse\n"
      "bounces; back faces are black) with map importance sampling and cosine sampling combined by MIS.\n"
      "Output: vertex,r,g,b,se_r,se_g,se_b (se: standard error of each value). Use the same mesh options\n"
      "(--weld), --albedo and --rotate as the PRT run you compare against with `prt compare`.\n"
      "Defaults match prt precompute (albedo 0.8, shadowed, 1 bounce). Ctrl-C stops without writing.\n"
      "--material glossy --eye x,y,z adds rho_s x a Phong lobe of exponent --gloss about the eye's mirror direction\n"
      "(map and lobe sampling, MIS; docs/GLOSSY.md): the ground truth of prt relight --eye.\n"
      "--lightmap WxH: at the texels of prt precompute SCENE --lightmap WxH, as an RGBA EXR (A = 1 at covered texels).\n"
      "Lights inside the scene (a glTF's KHR_lights_punctual, --lights FILE.json, --sun auto; docs/LIGHTS.md) are\n"
      "added by next-event estimation at every path vertex: their shadows and, interreflected, their bounce.\n"
      "Example: prt reference cow.off forest.exr --samples 1024 -o cow_ref.csv\n"
      "         prt reference models/room.gltf forest.exr --lightmap 128x128 --mode interreflected -o ref.exr\n"
      "         prt reference models/room.gltf forest.exr --at points.csv -o ref.csv\n"
      "         prt reference models/room.gltf none --lights lights.json --lightmap 64x64 -o lights.exr\n"
      "--material subsurface (--sss NAME, or --sigma-a r,g,b --sigma-s r,g,b [--eta E]; --length-scale mm a unit):\n"
      "the exit radiance L_o of a translucent mesh (the dipole, docs/SUBSURFACE.md), the ground truth of\n"
      "prt precompute --material subsurface: each probe samples the profile by a ray through the mesh\n"
      "along the normal or a tangent and sums the dipole over every surface point it crosses, each with its\n"
      "transmitted irradiance (map and cosine sampling, Fresnel transmittance); --samples iterations of 4\n"
      "probes a channel (default 4096).\n"
      "Shadowed, or interreflected (surfaces hit glow with their own L_o, --bounces hops). The map's light\n"
      "alone: no --lights/--sun, --albedo, --vertex-colors, --at. With --lightmap WxH, at the texels of prt\n"
      "precompute SCENE --lightmap WxH --material subsurface (each at its point on its triangle).\n"
      "         prt reference cow.off forest.exr --material subsurface --sss marble --length-scale 100 -o sss.csv");
  s->add_option("MESH", a->mesh, "Mesh file: OBJ, PLY, OFF, STL, glTF/GLB")->check(path_value())->required();
  s->add_option("ENV,--env", a->env,
                "Lat-long environment map (EXR, HDR, ...); none: no light from afar (the lights alone: --lights)")
      ->check(path_value())
      ->required();
  s->add_option("-o,--output", a->output, "CSV file to write")->check(path_value())->required();
  add_shared(s, SharedOption::Mode, a->mode, "Light paths: unshadowed (no rays), shadowed, or interreflected");
  add_shared(s, SharedOption::Bounces, a->opt.bounces, "Diffuse bounces (interreflected mode)");
  a->albedo_opt = add_shared(s, SharedOption::Albedo, a->albedo, "Diffuse albedo (with --lightmap: replaces the scene's materials)");
  a->lightmap_opt = add_shared(s, SharedOption::Lightmap, a->lightmap,
                                  "WxH: the reference at the texels of prt precompute --lightmap WxH (SCENE: glTF or "
                                  "OBJ with vt), written as an RGBA float EXR in the relit lightmap's layout");
  a->uv_opt = add_shared(s, SharedOption::UvSet, a->uv, "With --lightmap: the UV set (as prt precompute --uv)");
  a->lightmap_uv_opt = add_shared(s, SharedOption::LightmapUv, a->lightmap_uv,
                                  "With --lightmap: the scene's own UVs, or prt's (as prt precompute --lightmap-uv)");
  a->uv_padding_opt = add_shared(s, SharedOption::UvPadding, a->uv_padding,
                                 "With --lightmap-uv auto: texels between charts (as prt precompute --uv-padding)");
  a->pages_opt = add_shared(s, SharedOption::Pages, a->pages,
                            "With --lightmap: its pages (as prt precompute --pages): one EXR per page, "
                            "NAME.1001.exr ...")
                     ->capture_default_str();
  a->texel_opt = add_shared(s, SharedOption::TexelSize, a->texel_size,
                            "With --lightmap-uv auto --pages auto: a texel's edge (as prt precompute --texel-size)");
  s->add_option("--at", a->at,
                "POINTS.csv (header x,y,z,nx,ny,nz): the reference at these points instead of vertices: E(p, n)/pi, "
                "what a white Lambertian surface there reflects (probe volumes, docs/PROBES.md); writes point,r,g,b,...")
      ->check(path_value());
  s->add_flag("--vertex-colors", a->opt.vertex_colors, "Use the mesh's vertex colours as albedo");
  a->samples_opt = s->add_option("-s,--samples", a->opt.samples,
                "Iterations per vertex, each one map-sampled and one cosine-sampled direction (--material "
                "subsurface: iterations of 4 probes a channel, default 4096)")
      ->check(int_range(2, 1 << 24))
      ->capture_default_str();
  add_shared(s, SharedOption::Seed, a->opt.seed, "Random seed (any thread count)");
  add_shared(s, SharedOption::Rotate, a->rotate, "Rotate the lighting");
  add_shared(s, SharedOption::Offset, a->opt.offset, "Ray origin offset along the normal");
  add_shared(s, SharedOption::Material, a->material,
             "diffuse; glossy: also the view-dependent Phong lobe (--eye, --gloss, --specular); subsurface: a "
             "translucent material (--sss or --sigma-a/--sigma-s, --eta, --length-scale)");
  a->glossy_opts.push_back(add_shared(s, SharedOption::Eye, a->eye, "Glossy: the eye point"));
  a->glossy_opts.push_back(add_shared(s, SharedOption::Gloss, a->opt.gloss, "Glossy: the lobe's exponent"));
  a->glossy_opts.push_back(add_shared(s, SharedOption::Specular, a->opt.specular, "Glossy: the lobe's strength"));
  s->add_flag("--weld", a->mesh_opt.weld, "Merge vertices that share a position (as prt precompute --weld)");
  add_shared(s, SharedOption::Threads, a->threads, "Worker threads");
  add_light_options(s, a->light);
  add_subsurface_options(s, a->sss);
  s->add_flag("-q,--quiet", a->quiet, "No progress or summary on stderr");
  return [a] { return run_reference(*a); };
}

}  // namespace prt::cli
