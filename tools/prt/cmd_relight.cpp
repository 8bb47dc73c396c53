// prt relight: CPU relighting of a precomputed mesh under an environment map.
#include "commands.h"
#include "look.h"
#include "progress_bar.h"
#include "inputs.h"
#include "lightmap_inputs.h"
#include "light_options.h"

#include <prt/vertex_csv.h>
#include <prt/color.h>
#include <prt/render.h>
#include <prt/compare.h>
#include <prt/envmap.h>
#include <prt/filter.h>
#include <prt/io.h>
#include <prt/lightmap.h>
#include <prt/lightmap_directional.h>
#include <prt/precompute.h>
#include <prt/probes.h>
#include <prt/scene.h>
#include <prt/mesh.h>
#include <prt/ply.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/wavelet.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>
#include <prt/deform.h>
#include <prt/direct_light.h>
#include <prt/skin.h>

#include <fmt/core.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <utility>

namespace prt::cli {

namespace {

struct RelightArgs {
  std::string mesh, transfer, env, output, rotate, window = "none", selection = "area";
  // Glossy: the eye point, and the lobe's exponent and strength (docs/GLOSSY.md).
  std::string eye;
  GlossyArgs lobe;  // needs --eye
  double window_width = 0;
  // Display output (--tonemap): exposure and tone map as prt render's 8-bit
  // images, then sRGB encoding with --srgb; PLY colours as bytes.
  std::string tonemap;
  std::string exposure = "0";  // stops, or auto (frame_exposure over the relit vertices)
  bool srgb = false;
  const CLI::Option *exposure_opt = nullptr, *srgb_opt = nullptr;
  int terms = 100;
  // A lightmap's file encoding (prt/lightmap_encoding.h); empty: by extension.
  std::string encoding;
  const CLI::Option* encoding_opt = nullptr;
  // --directional PACKING: a directional lightmap's L1 packed for an engine (prt/lightmap_directional.h).
  std::string directional;
  const CLI::Option* directional_opt = nullptr;
  bool direct = false, quiet = false;
  std::vector<const CLI::Option*> sh_only, wavelet_only;  // to refuse those the file's basis does not take
  std::string at;  // --at POINTS.csv: query points of a probe volume
  std::string deform;  // --deform bend:ANGLE|twist:ANGLE: a procedural pose of MESH (zh files)
  bool dynamic_ao = false;  // --dynamic-ao (zh files): scale by the pose's dynamic AO over the rest pose's
  const CLI::Option* dynamic_ao_opt = nullptr;
  // --time SECONDS [--animation N]: MESH (a skinned glTF) posed by its skin at that time (zh files).
  double time = 0;
  int animation = 0;
  const CLI::Option *time_opt = nullptr, *animation_opt = nullptr;
  LightArgs light;  // --lights, --sun (docs/LIGHTS.md)
};

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The lights SCENE is lit with beside ENV's PRT: the scene's and --lights
// files', and with --sun auto the map's sun, taken out of `env` here and
// turned by --rotate with the sky (the scene's lights stay where they are);
// `sun_map` as add_map_sun.
std::vector<Light> relight_lights(const RelightArgs& a, EnvMap& env, const double euler[3],
                                  const std::vector<Light>* scene_lights = nullptr,
                                  std::optional<EnvMap>* sun_map = nullptr) {
  std::vector<Light> lights = command_lights(a.light, a.mesh, scene_lights);
  add_map_sun(a.light, lights, env, sh::rotation_from_euler(euler[0], euler[1], euler[2]), a.quiet, sun_map);
  if (!a.quiet && !lights.empty()) fmt::print(stderr, "lit by {} beside the map\n", describe_lights(lights));
  return lights;
}

// Every vertex's albedo as `albedo(v)` gives it.
template <typename F>
std::vector<glm::vec3> albedo_of(std::size_t n, F albedo) {
  std::vector<glm::vec3> out(n);
  for (std::size_t v = 0; v < n; ++v) out[v] = albedo(v);
  return out;
}

// Writes the result through Outputs: all of it, or (failure, Ctrl-C)
// nothing. Returns the exit status. `rgb` is taken by value (callers move
// it in) and turned into display values in place: one copy of the colours.
// With --tonemap the radiance becomes display values first (and the PLY's
// colours bytes).
// --exposure auto: prt render's rule (frame_exposure) with no frame: over the
// relit vertices (or points), each counted once.
int write_output(const RelightArgs& a, const std::string& ext, const Mesh& mesh, std::vector<glm::vec3> rgb) {
  const bool display = !a.tonemap.empty();
  const std::optional<double> given = exposure_stops(a.exposure);
  const double stops = !display ? 0.0
                       : given  ? *given
                                : frame_exposure({reinterpret_cast<const float*>(rgb.data()), 3 * rgb.size()});
  if (display) {
    const Display d{stops, parse_tone_map(a.tonemap)};
    for (glm::vec3& c : rgb)
      for (int k = 0; k < 3; ++k) c[k] = a.srgb ? srgb_encode(tone_map(c[k], d)) : tone_map(c[k], d);
  }
  const std::string comment =
      display ? fmt::format("prt relight: display colours: exposure {:g}, tone map {}, {}", stops, a.tonemap,
                            a.srgb ? "sRGB-encoded" : "linear")
              : std::string("prt relight: linear radiance per vertex");
  Outputs out("relight");
  out.write([&] {
    if (ext == ".ply")
      write_ply(a.output, mesh, rgb, display ? PlyColors::Bytes : PlyColors::Float, comment);
    else
      write_vertex_csv(a.output, rgb, nullptr);
  });
  return out.commit();
}

// Float overflow of map x transfer: the inputs are named (the output is not
// at fault). `largest(v)` is the largest |coefficient| of vertex v's transfer.
template <typename Largest>
void check_relit(const std::vector<glm::vec3>& rgb, const RelightArgs& a, const EnvMap& env, Largest largest) {
  for (std::size_t v = 0; v < rgb.size(); ++v)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(rgb[v][c]))
        throw Error(fmt::format("relit radiance of vertex {} is {} ({} channel): the values of {} (max {}) times the "
                                "transfer of {} (largest coefficient of that vertex {}) overflow float (largest {}); "
                                "scale the map down",
                                v, show_number(rgb[v][c]), "rgb"[c], a.env, show_number(env.stats.max), a.transfer,
                                show_number(largest(v)), show_number(std::numeric_limits<float>::max())));
}

// A wavelet transfer: per-frame lighting (resample, Haar, K terms) and the sparse sum.
int run_wavelet(const RelightArgs& a, const std::string& ext, const double euler[3], const WaveletTransfer& t) {
  for (const CLI::Option* o : a.sh_only)
    if (o->count() > 0)
      throw Error(o->get_name() + " applies to SH transfers; " + a.transfer +
                  " holds a wavelet transfer (use --terms and --selection to control its lighting approximation)");
  const wavelet::Selection selection = for_option("--selection", [&] { return wavelet::parse_selection(a.selection); });
  const Mesh mesh = load_mesh(a.mesh);
  check_matches(t, mesh, a.transfer);
  EnvMap env = load_envmap(a.env);
  require_finite(env);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n{}", describe(mesh), describe(env), describe_transfer(t));
  const std::vector<Light> lights = relight_lights(a, env, euler);

  auto t0 = std::chrono::steady_clock::now();
  wavelet::FrameLighting lighting(env, t.cube_res);
  const double setup_ms = ms_since(t0);
  t0 = std::chrono::steady_clock::now();
  lighting.update(sh::rotation_from_euler(euler[0], euler[1], euler[2]), a.terms, selection);
  const double light_ms = ms_since(t0);
  t0 = std::chrono::steady_clock::now();
  std::vector<glm::vec3> rgb;
  wavelet_relight(t, lighting.coefficients().data(), lighting.terms(), rgb);
  const double relight_ms = ms_since(t0);
  check_relit(rgb, a, env, [&](std::size_t v) { return double(t.vertex_scale[v]) * 32767.0; });
  add_direct_light(rgb, lights, mesh, mesh.positions, mesh.normals,
             albedo_of(rgb.size(), [&](std::size_t v) { return t.vertex_colors ? t.vertex_albedo[v] : t.albedo; }));
  const std::size_t written = rgb.size();
  if (const int rc = write_output(a, ext, mesh, std::move(rgb)); rc != 0) return rc;
  if (!a.quiet)
    fmt::print(stderr,
               "relight: {:.3f} ms per frame (lighting {:.3f} ms: resample, Haar, {} of {} terms by {}; transfer "
               "{:.3f} ms); map setup {:.1f} ms\nwrote {} ({} vertices)\n",
               light_ms + relight_ms, light_ms, lighting.terms().size(), t.coeff_count(),
               wavelet::selection_name(selection), relight_ms, setup_ms, a.output, written);
  return 0;
}

// A local deformable transfer (prt precompute --basis zh): MESH is a pose of
// the rest mesh (same vertices and triangles); each vertex's lobes are turned
// into its posed frame, then relit as an SH transfer (docs/LDPRT.md).
int run_zh(const RelightArgs& a, const std::string& ext, const std::array<double, 3>& euler, const ZhTransfer& z) {
  for (const CLI::Option* o : a.wavelet_only)
    if (o->count() > 0) throw UsageError(o->get_name() + " applies to wavelet transfers; " + a.transfer + " holds lobes");
  if (a.direct) throw UsageError("--direct: " + a.transfer + " holds lobes of one transfer (no direct part)");
  if (!a.eye.empty()) throw UsageError("--eye: " + a.transfer + " is diffuse (lobes of a diffuse transfer)");
  const sh::Window window = for_option("--window", [&] { return sh::parse_window(a.window); });
  const Deform deform = a.deform.empty() ? Deform{} : parse_deform(a.deform);
  const bool timed = a.time_opt->count() > 0;
  if (a.animation_opt->count() > 0 && !timed)
    throw UsageError("--animation picks the animation that --time samples: give --time SECONDS too");
  if (timed && !a.deform.empty())
    throw UsageError("--time and --deform: give one pose, the skin's at a time (--time) or a procedural one "
                     "(--deform)");
  // --time: MESH's own skin (glTF) poses it, from the rest mesh load_mesh
  // reads (the one the transfer was computed on; prt/skin.h).
  const Mesh posed = [&] {
    if (!timed) return deform_mesh(load_mesh(a.mesh), deform);
    const Mesh rest = load_mesh(a.mesh);
    const Skin skin = load_skin(a.mesh, rest);
    return skin_mesh(rest, skin, joint_matrices(skin, a.time, a.animation));
  }();
  check_pose(z, posed, a.transfer);
  if (a.dynamic_ao && z.rest_ao.empty())
    throw Error(a.transfer + ": --dynamic-ao: it holds no rest occlusion; compute it with prt precompute --basis zh "
                "--dynamic-ao");
  EnvMap env = load_envmap(a.env);
  require_finite(env);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n{}", describe(posed), describe(env), describe_transfer(z));
  const std::vector<Light> lights = relight_lights(a, env, euler.data());
  auto t0 = std::chrono::steady_clock::now();
  PoseReport report;
  const Transfer t = posed_as_transfer(z, posed, &report);
  const double pose_ms = ms_since(t0);
  t0 = std::chrono::steady_clock::now();
  std::vector<glm::dvec3> light = project(env, t.bands);
  const double project_ms = ms_since(t0);
  t0 = std::chrono::steady_clock::now();
  sh::apply_window(std::span<glm::dvec3>(light), window, a.window_width > 0 ? a.window_width : t.bands);
  if (!a.rotate.empty()) rotate_lighting(light, t.bands, euler.data());
  std::vector<glm::vec3> rgb = relight(t, posed, light);
  const double frame_ms = ms_since(t0);
  double ao_ms = 0;
  if (a.dynamic_ao) {
    t0 = std::chrono::steady_clock::now();
    std::vector<float> f;
    try {
      f = dynamic_ao_factor(z, posed);
    } catch (const Error& e) {
      throw Error(a.transfer + ": --dynamic-ao: " + e.what());
    }
    for (std::size_t v = 0; v < rgb.size(); ++v) rgb[v] *= f[v];
    ao_ms = ms_since(t0);
  }
  check_relit(rgb, a, env, [&](std::size_t v) {
    double m = 0;
    for (double x : vertex_transfer(t, posed, v)) m = std::max(m, std::abs(x));
    return m;
  });
  add_direct_light(rgb, lights, posed, posed.positions, posed.normals,
             albedo_of(rgb.size(), [&](std::size_t v) { return vertex_albedo(t, posed, v); }));
  if (!a.quiet && report.no_frame > 0)
    fmt::print(stderr, "{} vertices have no frame in this pose (no normal: only zero-area triangles around them): "
                       "their transfer is zero\n", report.no_frame);
  const std::size_t written = rgb.size();
  if (const int rc = write_output(a, ext, posed, std::move(rgb)); rc != 0) return rc;
  if (!a.quiet)
    fmt::print(stderr, "relight: pose {:.3f} ms ({} lobes turned into each vertex's posed frame), {:.3f} ms per frame "
                       "(window, rotation, transfer; projection {:.1f} ms once){}\nwrote {} ({} vertices)\n",
               pose_ms, z.lobes, frame_ms, project_ms,
               a.dynamic_ao ? fmt::format(", dynamic AO {:.1f} ms", ao_ms) : std::string(), a.output, written);
  return 0;
}

// A lightmap's relit atlas is an EXR, KTX2 or PNG in an encoding
// (lightmap_output_encoding; one file per page, page_path), checked before any work.
void check_lightmap_output(const RelightArgs& a, const std::string&, const LightmapLayout& layout) {
  lightmap_output_encoding(a.output, a.encoding);
  if (!a.tonemap.empty())
    throw UsageError("--tonemap: a lightmap is written as linear radiance (float or half EXR, half or ASTC HDR KTX2, "
                     "RGBM or RGBD PNG)");
  for (int p = 0; p < layout.pages; ++p) {
    const std::string path = page_path(a.output, p, layout.pages);
    check_not_input("--output", path, {{"SCENE", a.mesh}, {"TRANSFER", a.transfer}, {"ENV", a.env}});
    for_path("--output", [&] { check_writable(path); });
  }
}

// The files write_lightmap_pages writes for `path`: itself, or the first
// page's and the last's ("lm.1001.exr ... lm.1003.exr").
std::string written_pages(const std::string& path, const LightmapLayout& layout) {
  if (layout.pages == 1) return path;
  return page_path(path, 0, layout.pages) + " ... " + page_path(path, layout.pages - 1, layout.pages);
}

// Writes the relit texels as RGBA float EXRs in the lightmap's layout, one
// per page (write_lightmap_pages), and unless quiet prints `timing` and the
// files written. Returns the exit status.
int write_relit_lightmap(const RelightArgs& a, const LightmapLayout& layout, const std::vector<glm::vec3>& rgb,
                         const std::string& timing) {
  Outputs out("relight");
  const LightmapEncoding encoding = lightmap_output_encoding(a.output, a.encoding);
  const auto t0 = std::chrono::steady_clock::now();
  const EncodedPages done = write_encoded_lightmap_pages(out, a.output, layout, lightmap_rgba(layout, rgb), encoding);
  const double encode_ms = ms_since(t0);  // encoding, decoding for the error, writing the temporaries
  if (const int rc = out.commit(); rc != 0) return rc;
  if (a.quiet) return 0;
  fmt::print(stderr, "relight: {}\nwrote {} ({} RGBA {}, {} covered texels; encoded and written in {:.1f} ms)\n",
             timing, written_pages(a.output, layout), lightmap_size_text(layout), encoding_name(encoding),
             layout.texels.size(), encode_ms);
  if (encoding != LightmapEncoding::Float)
    fmt::print(stderr, "encoding {}: relative RMS error {:.3g}, max error {:.3g} ({:.3g} of the peak {:.4g}) over the "
               "covered texels; {} texels clamped (largest value {:.4g})\n", encoding_name(encoding),
               done.error.relative_rms, done.error.max_abs, done.error.peak > 0 ? done.error.max_abs / done.error.peak : 0.0,
               done.error.peak, done.report.clamped_texels, done.report.largest);
  return 0;
}

// A wavelet lightmap: the texels' wavelet relighting with K terms (as per vertex).
int run_wavelet_lightmap(const RelightArgs& a, const std::string& ext, const std::array<double, 3>& euler,
                         const WaveletLightmap& wl) {
  check_lightmap_output(a, ext, wl.layout);
  for (const CLI::Option* o : a.sh_only)
    if (o->count() > 0)
      throw UsageError(o->get_name() + " applies to SH transfers; " + a.transfer + " is a wavelet lightmap (--terms, "
                       "--selection)");
  const wavelet::Selection selection = for_option("--selection", [&] { return wavelet::parse_selection(a.selection); });
  const prt::Scene scene = load_lightmap_scene(a.mesh, wl.layout);
  const LightmapTexels texels = lightmap_texels(scene, wl.layout);
  if (texels.layout.scene_hash != wl.layout.scene_hash || texels.layout.texels != wl.layout.texels)
    throw Error(a.transfer + ": was computed for another scene or atlas (scene hash, covered texels differ)");
  EnvMap env = load_envmap(a.env);
  require_finite(env);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n{}", describe(scene), describe(env), describe_transfer(wl.transfer));
  const std::vector<Light> lights = relight_lights(a, env, euler.data(), &scene.lights);
  const auto t0 = std::chrono::steady_clock::now();
  wavelet::FrameLighting lighting(env, wl.transfer.cube_res);
  lighting.update(sh::rotation_from_euler(euler[0], euler[1], euler[2]), a.terms, selection);
  std::vector<glm::vec3> rgb;
  wavelet_relight(wl.transfer, lighting.coefficients().data(), lighting.terms(), rgb);
  const double ms = ms_since(t0);
  check_relit(rgb, a, env, [&](std::size_t v) { return double(wl.transfer.vertex_scale[v]) * 32767.0; });
  add_texel_lights(rgb, lights, scene.mesh, texels);
  return write_relit_lightmap(a, wl.layout, rgb,
                              fmt::format("{:.3f} ms ({} of {} terms)", ms, lighting.terms().size(),
                                          wl.transfer.coeff_count()));
}

// --directional PACKING, checked before any work: a lightmap with
// directional rows, an .exr (and its companion PNG) to write per page.
DirectionalPacking check_directional(const RelightArgs& a, const std::string& ext, const LightmapTransfer& lt) {
  const DirectionalPacking packing =
      for_option("--directional", [&] { return parse_directional_packing(a.directional); });
  if (!lt.transfer.glossy || lt.transfer.glossy_rows != kDirectionalRows)
    throw UsageError("--directional: " + a.transfer + " has no directional rows: precompute it with --directional "
                     "(prt precompute SCENE --lightmap WxH --directional)");
  if (a.encoding_opt->count() > 0)
    throw UsageError(std::string("--encoding: --directional ") + directional_packing_name(packing) +
                     " sets the files' encoding (docs/LIGHTMAPS.md \"Directional lightmaps\")");
  if (a.direct)
    throw UsageError("--direct: the directional rows hold the whole light of the file's mode, not its direct part");
  if (ext != ".exr") throw UsageError("--output: " + a.output + ": --directional writes an .exr (the float layers)");
  if (!a.tonemap.empty()) throw UsageError("--tonemap: a directional lightmap is written as linear values");
  std::vector<std::string> paths;
  for (int page = 0; page < lt.layout.pages; ++page) {
    paths.push_back(page_path(a.output, page, lt.layout.pages));
    if (packing == DirectionalPacking::MonoSh || packing == DirectionalPacking::Dominant)
      paths.push_back(directional_companion_path(paths.back()));
  }
  for (const std::string& path : paths) {
    check_not_input("--output", path, {{"SCENE", a.mesh}, {"TRANSFER", a.transfer}, {"ENV", a.env}});
    for_path("--output", [&] { check_writable(path); });
  }
  return packing;
}

// Rows [first, first + rows) of every layer: one page of a lightmap's
// stacked layers.
DirectionalImages directional_rows(const DirectionalImages& images, int first, int rows) {
  DirectionalImages out{images.packing, {}};
  for (const RgbaImage& layer : images.layers) {
    RgbaImage page;
    page.width = layer.width;
    page.height = rows;
    page.has_alpha = layer.has_alpha;
    const std::size_t row = 4 * std::size_t(layer.width);
    page.rgba.assign(layer.rgba.begin() + std::ptrdiff_t(std::size_t(first) * row),
                     layer.rgba.begin() + std::ptrdiff_t(std::size_t(first + rows) * row));
    out.layers.push_back(std::move(page));
  }
  return out;
}

// Writes `images` (the layout's pages stacked) as one set of files per page
// (page_path: lm.1001.exr and lm.1001-dir.png, ...) through `out`; returns
// the paths written.
std::vector<std::string> write_directional_pages(Outputs& out, const std::string& path, const LightmapLayout& layout,
                                                 const DirectionalImages& images) {
  std::vector<std::string> written;
  for (int page = 0; page < layout.pages; ++page) {
    const DirectionalImages one = layout.pages == 1 ? images
                                                    : directional_rows(images, page * layout.page_height(),
                                                                       layout.page_height());
    out.write([&] {
      for (std::string& f : write_directional(page_path(path, page, layout.pages), one)) written.push_back(std::move(f));
    });
  }
  return written;
}

// The files write_directional_pages wrote, read back and their pages stacked
// again, as a GPU samples them.
DirectionalImages read_directional_pages(const std::string& path, const LightmapLayout& layout,
                                         DirectionalPacking packing) {
  DirectionalImages all{packing, {}};
  for (int page = 0; page < layout.pages; ++page) {
    DirectionalImages one = read_directional(page_path(path, page, layout.pages), packing, layout.page_height());
    if (all.layers.empty()) {
      all.layers = std::move(one.layers);
      continue;
    }
    for (std::size_t i = 0; i < all.layers.size(); ++i) {
      all.layers[i].height += one.layers[i].height;
      all.layers[i].rgba.insert(all.layers[i].rgba.end(), one.layers[i].rgba.begin(), one.layers[i].rgba.end());
    }
  }
  return all;
}

// How far prt's L1 at the texels' normals is from the diffuse lightmap's
// E/pi (its exit radiance over the albedo), over the covered texels with an
// albedo: what the L1's cosine leaves out (bands 2 and 4, ...).
double l1_against_diffuse(const LightmapTransfer& lt, const LightmapTexels& texels, const std::vector<glm::dvec3>& light,
                          const std::vector<L1Radiance>& l1) {
  const std::vector<glm::vec3> exit = relight(lt.transfer, texel_points(texels), light);
  double e2 = 0, r2 = 0;
  for (std::size_t i = 0; i < l1.size(); ++i) {
    const glm::vec3 l = l1_irradiance_over_pi(l1[i], glm::normalize(texels.normals[i]));
    for (int c = 0; c < 3; ++c) {
      if (!(texels.albedo[i][c] > 0)) continue;
      const double want = double(exit[i][c]) / double(texels.albedo[i][c]);
      e2 += (double(l[c]) - want) * (double(l[c]) - want);
      r2 += want * want;
    }
  }
  return r2 > 0 ? std::sqrt(e2 / r2) : 0.0;
}

// --directional: the texels' L1 incident radiance under ENV (rotated,
// windowed) and the lights' direct light, packed for an engine instead of
// the diffuse atlas (docs/LIGHTMAPS.md "Directional lightmaps").
int run_directional_lightmap(const RelightArgs& a, const std::string& ext, const std::array<double, 3>& euler,
                             const LightmapTransfer& lt) {
  const DirectionalPacking packing = check_directional(a, ext, lt);
  const sh::Window window = for_option("--window", [&] { return sh::parse_window(a.window); });
  const prt::Scene scene = load_lightmap_scene(a.mesh, lt.layout);
  LightmapTexels texels = lightmap_texels(scene, lt.layout, lt.transfer.vertex_colors ? nullptr : &lt.transfer.albedo);
  check_matches(lt, texels, a.transfer);
  EnvMap env = load_envmap(a.env);
  require_finite(env);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n", describe(scene), describe(env));
  const std::vector<Light> lights = relight_lights(a, env, euler.data(), &scene.lights);
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<glm::dvec3> light = project(env, lt.transfer.bands);
  sh::apply_window(std::span<glm::dvec3>(light), window, a.window_width > 0 ? a.window_width : lt.transfer.bands);
  if (!a.rotate.empty()) rotate_lighting(light, lt.transfer.bands, euler.data());
  std::vector<L1Radiance> l1 = relight_directional(lt, texels, light);
  const double frame_ms = ms_since(t0);
  const double truncation = a.quiet ? 0.0 : l1_against_diffuse(lt, texels, light, l1);
  if (!lights.empty()) {  // at the points precompute traced from, as add_texel_lights
    LightmapTexels moved = texels;
    move_texels_out_of_geometry(scene.mesh, moved);
    const std::vector<L1Radiance> direct = DirectLight(scene.mesh).incident_l1(lights, moved.positions, moved.normals);
    for (std::size_t i = 0; i < l1.size(); ++i)
      for (std::size_t k = 0; k < 4; ++k) l1[i][k] += direct[i][k];
  }
  EncodeReport report;
  const DirectionalImages images = pack_directional(lt.layout, l1, texels.normals, packing, &report);
  Outputs out("relight");
  const std::vector<std::string> written = write_directional_pages(out, a.output, lt.layout, images);
  if (const int rc = out.commit(); rc != 0) return rc;
  if (a.quiet) return 0;
  const DirectionalImages stored = read_directional_pages(a.output, lt.layout, packing);
  const EncodingError at_normal = directional_decode_error(stored, lt.layout, l1, texels.normals, 0.0);
  const EncodingError tilted = directional_decode_error(stored, lt.layout, l1, texels.normals, kDirectionalTilt);
  const std::string files = written.size() == 1   ? written[0]
                            : written.size() == 2 ? written[0] + " and " + written[1]
                                                  : fmt::format("{} ... {} ({} files)", written.front(), written.back(),
                                                                written.size());
  fmt::print(stderr, "relight: {:.3f} ms (projection, rotation, {} texels' L1)\nwrote {} ({} {}, {} covered texels; {} "
             "texels past the packing's range)\n", frame_ms, l1.size(), files, lightmap_size_text(lt.layout),
             directional_packing_name(packing), lt.layout.texels.size(), report.clamped_texels);
  fmt::print(stderr, "decoded as the engine does, against prt's L1 (E/pi, peak {:.4g}): relative RMS {:.3g} at the "
             "texels' normals, {:.3g} at normals tilted {:g} degrees\n", at_normal.peak, at_normal.relative_rms,
             tilted.relative_rms, kDirectionalTilt);
  fmt::print(stderr, "prt's L1 at the texels' normals against the diffuse lightmap (E/pi, ENV's light): relative RMS "
             "{:.3g} (the cosine's bands past 1)\n", truncation);
  return 0;
}

// A lightmap transfer (prt precompute --lightmap): an RGBA float EXR of the
// atlas, A = 1 at covered texels, gutters dilated (docs/LIGHTMAPS.md).
int run_lightmap(const RelightArgs& a, const std::string& ext, const std::array<double, 3>& euler,
                 const LightmapTransfer& lt) {
  check_lightmap_output(a, ext, lt.layout);
  for (const CLI::Option* o : a.sh_only)
    if (o->count() > 0 && o->get_name() != "--window" && o->get_name() != "--window-width" && o->get_name() != "--direct")
      throw UsageError(o->get_name() + " does not apply to a lightmap (diffuse: no eye, no lobe)");
  for (const CLI::Option* o : a.wavelet_only)
    if (o->count() > 0) throw UsageError(o->get_name() + " applies to wavelet transfers; " + a.transfer + " is an SH lightmap");
  const sh::Window window = for_option("--window", [&] { return sh::parse_window(a.window); });
  const prt::Scene scene = load_lightmap_scene(a.mesh, lt.layout);
  const LightmapTexels texels =
      lightmap_texels(scene, lt.layout, lt.transfer.vertex_colors ? nullptr : &lt.transfer.albedo);
  check_matches(lt, texels, a.transfer);
  if (a.direct) check_direct(lt.transfer, a.transfer, "--direct");
  EnvMap env = load_envmap(a.env);
  require_finite(env);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n", describe(scene), describe(env));
  std::optional<EnvMap> sun_map;
  const std::vector<Light> lights = relight_lights(a, env, euler.data(), &scene.lights, &sun_map);
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<glm::dvec3> light = project(env, lt.transfer.bands);
  sh::apply_window(std::span<glm::dvec3>(light), window, a.window_width > 0 ? a.window_width : lt.transfer.bands);
  if (!a.rotate.empty()) rotate_lighting(light, lt.transfer.bands, euler.data());
  const Mesh points = texel_points(texels);
  std::vector<glm::vec3> rgb = a.direct ? relight_direct(lt.transfer, points, light) : relight(lt.transfer, points, light);
  // With a light-bounce operator the sun bounces as the lights do (add_texel_lights).
  const LightBounce* bounce = bounce_of(lt.transfer, a.direct);
  if (!a.direct && !bounce)
    add_sun_bounce(rgb, sun_map, lt.transfer, points, window, a.window_width, a.rotate.empty() ? nullptr : euler.data());
  const double frame_ms = ms_since(t0);
  check_relit(rgb, a, env, [&](std::size_t v) {
    double m = 0;
    for (double x : vertex_transfer(lt.transfer, points, v, a.direct)) m = std::max(m, std::abs(x));
    return m;
  });
  const double lights_ms = add_texel_lights(rgb, lights, scene.mesh, texels, bounce);
  return write_relit_lightmap(
      a, lt.layout, rgb,
      fmt::format("{:.3f} ms (projection, rotation, {} texels){}", frame_ms, rgb.size(),
                  lights.empty() ? std::string() : fmt::format("; lights' direct light {:.1f} ms", lights_ms)));
}

// A probe volume (prt precompute SCENE --probes): E(p, n)/pi at each query
// point from the probes interpolated there (docs/PROBES.md).
int run_probes(const RelightArgs& a, const std::string& ext, const std::array<double, 3>& euler,
               const ProbeTransfer& t) {
  if (a.at.empty())
    throw UsageError(a.transfer + " is a probe volume: give --at POINTS.csv (x,y,z,nx,ny,nz per line) and -o OUT.csv");
  if (ext != ".csv") throw UsageError("--output: " + a.output + ": a probe volume's queries are written as .csv (point,r,g,b)");
  for (const auto* list : {&a.sh_only, &a.wavelet_only})
    for (const CLI::Option* o : *list)
      if (o->count() > 0) throw UsageError(o->get_name() + " does not apply to a probe volume");
  if (!a.tonemap.empty()) throw UsageError("--tonemap: a probe volume's queries are written as linear radiance");
  check_not_input("--output", a.output, {{"SCENE", a.mesh}, {"PROBES", a.transfer}, {"ENV", a.env}, {"--at", a.at}});
  for_path("--output", [&] { check_writable(a.output); });
  const auto t0 = std::chrono::steady_clock::now();
  const prt::Scene scene = load_scene_or_mesh(a.mesh);
  if (scene.hash() != t.scene_hash)
    throw Error(a.transfer + ": computed for another scene than " + a.mesh + " (its geometry or UVs differ): rerun "
                "prt precompute " + a.mesh + " --probes ...");
  const QueryPoints q = read_points_csv(a.at);
  EnvMap env = load_envmap(a.env);
  require_finite(env);
  const std::vector<Light> lights = relight_lights(a, env, euler.data(), &scene.lights);
  if (!a.quiet && !lights.empty())
    fmt::print(stderr, "the lights' direct light at the points; their light off the surfaces at the probes comes from "
                       "the scene's light-bounce operator (prt precompute --light-bounce --probes), which prt render "
                       "--probes --object applies (docs/LIGHTS.md \"Bounce\")\n");
  ProbeRelighter relighter(t, env);
  relighter.set_rotation(sh::rotation_from_euler(euler[0], euler[1], euler[2]));
  const double t_light = ms_since(t0);
  // The probes the queries need, relit once each.
  const std::vector<std::uint32_t> slots = t.stored_slots();
  // Weights: trilinear x visibility traced from each point to its 8 probes.
  const ProbeOcclusion occlusion(scene.mesh, t.grid);
  const ProbeVisibility visible = [&](const glm::dvec3& probe, const glm::dvec3& p) { return occlusion(probe, p); };
  std::vector<ProbeWeights> weights(q.positions.size());
  tbb::parallel_for(std::size_t(0), q.positions.size(),
                    [&](std::size_t i) { weights[i] = probe_weights(t, slots, q.positions[i], q.normals[i], visible); });
  std::vector<std::uint32_t> need;
  for (const ProbeWeights& w : weights)
    for (int c = 0; c < w.count; ++c) need.push_back(w.probe[std::size_t(c)]);
  std::sort(need.begin(), need.end());
  need.erase(std::unique(need.begin(), need.end()), need.end());
  std::vector<glm::vec3> sh;
  relighter.relight(need, sh);
  const int nc = t.bands * t.bands;
  std::vector<glm::vec3> rgb(q.positions.size());
  std::vector<glm::vec3> mix(std::size_t(nc), glm::vec3(0.0f));
  for (std::size_t i = 0; i < q.positions.size(); ++i) {
    std::fill(mix.begin(), mix.end(), glm::vec3(0.0f));
    for (int c = 0; c < weights[i].count; ++c) {
      const float w = weights[i].weight[std::size_t(c)];
      if (w == 0) continue;
      const std::size_t at = std::size_t(std::lower_bound(need.begin(), need.end(), weights[i].probe[std::size_t(c)]) - need.begin());
      for (int k = 0; k < nc; ++k) mix[std::size_t(k)] += w * sh[at * std::size_t(nc) + std::size_t(k)];
    }
    rgb[i] = glm::vec3(lambert_from_sh(mix, t.bands, q.normals[i]));
  }
  // The lights at the points themselves (a white surface facing the normal):
  // traced there, not interpolated from the probes.
  if (!lights.empty()) {
    const std::vector<glm::vec3> pos(q.positions.begin(), q.positions.end()), nrm(q.normals.begin(), q.normals.end());
    add_direct_light(rgb, lights, scene.mesh, pos, nrm, std::vector<glm::vec3>(pos.size(), glm::vec3(1.0f)));
  }
  Outputs out("relight");
  out.write([&] { write_vertex_csv(a.output, rgb, nullptr, CsvKey::Point); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet)
    fmt::print(stderr, "wrote {}: {} points from {} of {} probes ({} bands, {}), lighting {:.1f} ms, {:.1f} ms in all\n",
               a.output, rgb.size(), need.size(), t.probes(), t.bands, transfer_mode_name(t.mode), t_light, ms_since(t0));
  return 0;
}

void check_vertex_output(const RelightArgs& a, const std::string& ext);
int run_sh(const RelightArgs& a, const std::string& ext, const std::array<double, 3>& euler, AnyTransfer loaded);

int run_relight(const RelightArgs& a) {
  const std::array<double, 3> euler = rotate_degrees(a.rotate);
  std::string ext = std::filesystem::path(a.output).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  for (const CLI::Option* o : {a.exposure_opt, a.srgb_opt})
    if (o->count() > 0 && a.tonemap.empty())
      throw UsageError(o->get_name() + " is for display colours: give --tonemap clamp, reinhard or aces too (without "
                       "it the output is linear radiance)");
  if (ext != ".ply" && ext != ".csv" && ext != ".exr" && ext != ".png" && ext != ".ktx2")
    throw UsageError("--output: " + a.output + ": expected a .ply or .csv file (a lightmap: .exr, .ktx2, .png)");
  // The file says which kind it holds; each kind's relighting takes the
  // options that apply to it.
  AnyTransfer any = read_transfer_file(a.transfer);
  require_support(kind_of(any), Consumer::Relight, a.transfer);
  const bool zh = kind_of(any) == TransferKind::ZH;
  if (a.dynamic_ao_opt->count() > 0 && !zh)
    throw UsageError("--dynamic-ao: " + a.transfer + " is not a --basis zh transfer (dynamic ambient occlusion "
                     "restores the distant occlusion a deforming mesh's local lobes cannot follow)");
  if (!a.deform.empty() && !zh)
    throw UsageError("--deform: " + a.transfer + " holds a transfer baked for one pose, which cannot follow a "
                     "deformation: compute one that can with prt precompute --basis zh (docs/LDPRT.md)");
  if (a.time_opt->count() > 0 && !zh)
    throw UsageError("--time: " + a.transfer + " holds a transfer baked for one pose, which cannot follow a skin's "
                     "animation: compute one that can with prt precompute --basis zh (docs/LDPRT.md)");
  const bool lightmap = kind_of(any) == TransferKind::Lightmap || kind_of(any) == TransferKind::WaveletLightmap;
  if (!a.directional.empty() && kind_of(any) != TransferKind::Lightmap)
    throw UsageError("--directional packs a directional SH lightmap's L1 (prt precompute --lightmap WxH "
                     "--directional): " + a.transfer + " is not an SH lightmap");
  if (a.encoding_opt->count() > 0 && !lightmap)
    throw UsageError("--encoding applies to a lightmap's relit atlas: " + a.transfer + " is not a lightmap");
  if (!a.at.empty() && kind_of(any) != TransferKind::Probes)
    throw UsageError("--at gives query points of a probe volume: " + a.transfer + " is not one");
  return dispatch(
      // (run_sh takes the variant itself: the scene it loads keeps it.)
      any, [&](const Transfer&) { return run_sh(a, ext, euler, std::move(any)); },
      [&](const CompressedTransfer&) { return run_sh(a, ext, euler, std::move(any)); },
      [&](const WaveletTransfer& t) {
        check_vertex_output(a, ext);
        return run_wavelet(a, ext, euler.data(), t);
      },
      [&](const ZhTransfer& z) {
        check_vertex_output(a, ext);
        return run_zh(a, ext, euler, z);
      },
      [&](const LightmapTransfer& l) {
        return a.directional.empty() ? run_lightmap(a, ext, euler, l) : run_directional_lightmap(a, ext, euler, l);
      },
      [&](const WaveletLightmap& w) { return run_wavelet_lightmap(a, ext, euler, w); },
      [&](const ProbeTransfer& p) { return run_probes(a, ext, euler, p); });
}

// Per-vertex output: PLY or CSV, checked before any work.
void check_vertex_output(const RelightArgs& a, const std::string& ext) {
  if (ext != ".ply" && ext != ".csv") throw UsageError("--output: " + a.output + ": expected a .ply or .csv file");
  check_not_input("--output", a.output, {{"MESH", a.mesh}, {"TRANSFER", a.transfer}, {"ENV", a.env}});
  for_path("--output", [&] { check_writable(a.output); });
}

// An SH transfer, compressed or not (its glossy part seen from --eye).
int run_sh(const RelightArgs& a, const std::string& ext, const std::array<double, 3>& euler, AnyTransfer loaded) {
  check_vertex_output(a, ext);
  for (const CLI::Option* o : a.wavelet_only)
    if (o->count() > 0)
      throw Error(o->get_name() + " applies to wavelet transfers; " + a.transfer +
                  " holds an SH transfer, whose band count is fixed when it is computed (prt precompute --bands), "
                  "or run prt precompute --basis wavelet");
  const sh::Window window = for_option("--window", [&] { return sh::parse_window(a.window); });

  const bool glossy = !a.eye.empty();
  for (const CLI::Option* o : a.lobe.options)
    if (o->count() > 0 && !glossy)
      throw UsageError(o->get_name() + " shapes the glossy part, which needs --eye x,y,z (the point the vertices are "
                       "seen from)");
  if (glossy && a.direct) throw UsageError("--direct and --eye: the glossy part has no direct-only form");
  GlossyShading shading;
  if (glossy) {
    double e[3];
    parse_triple(a.eye, "--eye", e);
    shading.eye = {e[0], e[1], e[2]};
    shading.gloss = a.lobe.gloss;
    shading.specular = a.lobe.specular;
    shading.diffuse = parse_diffuse(a.lobe.diffuse);
  }

  Scene scene = load_scene(a.mesh, std::move(loaded), a.transfer, a.env, Consumer::Relight, 0, "relight");
  const CompressedTransfer* c = scene.get<CompressedTransfer>();
  const Mesh& mesh = scene.mesh;
  const Transfer& t = c ? c->transfer : *scene.get<Transfer>();
  EnvMap& env = scene.env;
  if (a.direct) check_direct(t, a.transfer, "--direct");
  if (a.direct && c)
    throw Error(a.transfer + ": --direct: a compressed transfer keeps no direct part (prt compress drops it); relight "
                "the uncompressed file");
  if (glossy)
    if (auto p = glossy_shading_problem(t, shading); !p.empty()) throw Error(a.transfer + ": " + p);
  if (!glossy && t.glossy && !a.quiet)
    fmt::print(stderr, "{} holds glossy matrices: give --eye x,y,z (and --gloss, --specular) for the view-dependent "
                       "part; writing the diffuse part only\n", a.transfer);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n", describe(mesh), describe(env));
  std::optional<EnvMap> sun_map;
  const std::vector<Light> lights = relight_lights(a, env, euler.data(), nullptr, c ? nullptr : &sun_map);
  check_translucent_lights(t, !lights.empty(), a.transfer);
  if (c && a.light.sun_auto() && t.mode == TransferMode::Interreflected && !a.quiet)
    fmt::print(stderr, "--sun auto: {} is compressed and keeps no direct part: the sun's bounce is left out (its "
                       "direct light is traced)\n", a.transfer);

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<glm::dvec3> light = project(env, t.bands);
  const double project_ms = ms_since(t0);
  const auto t1 = std::chrono::steady_clock::now();
  sh::apply_window(std::span<glm::dvec3>(light), window, a.window_width > 0 ? a.window_width : t.bands);
  if (!a.rotate.empty()) rotate_lighting(light, t.bands, euler.data());
  std::vector<glm::vec3> rgb = c ? (glossy ? relight_glossy(*c, mesh, light, shading) : relight(*c, mesh, light))
                                     : glossy   ? relight_glossy(t, mesh, light, shading)
                                     : a.direct ? relight_direct(t, mesh, light)
                                                : relight(t, mesh, light);
  // With a light-bounce operator the sun bounces as the lights do (add_direct_light).
  const LightBounce* bounce = c ? nullptr : bounce_of(t, a.direct);
  if (!a.direct && !bounce)
    add_sun_bounce(rgb, sun_map, t, mesh, window, a.window_width, a.rotate.empty() ? nullptr : euler.data());
  const double frame_ms = ms_since(t1);
  check_relit(rgb, a, env, [&](std::size_t v) {
    double m = 0;
    if (c && !c->transfer.is_analytic(v)) {
      std::vector<float> row(c->coeffs.dim);
      c->coeffs.reconstruct(c->transfer.slots.empty() ? v : c->transfer.slots[v], row.data());
      for (float x : row) m = std::max(m, double(std::abs(x)));
      return m;
    }
    for (double x : vertex_transfer(c ? c->transfer : t, mesh, v, a.direct)) m = std::max(m, std::abs(x));
    return m;
  });
  std::optional<GlossyLobe> lobe;
  if (glossy) lobe = GlossyLobe{shading.eye, shading.gloss, shading.specular};
  const double lights_ms = add_direct_light(rgb, lights, mesh, mesh.positions, mesh.normals, albedo_of(rgb.size(), [&](std::size_t v) {
    // The diffuse albedo the transfer's relighting used (--diffuse replaces it for a glossy file).
    return glossy && shading.diffuse.x >= 0 ? glm::vec3(shading.diffuse) : vertex_albedo(t, mesh, v);
  }), lobe, bounce);
  const std::size_t written = rgb.size();
  if (const int rc = write_output(a, ext, mesh, std::move(rgb)); rc != 0) return rc;
  if (!a.quiet)
    fmt::print(stderr, "relight: {:.3f} ms per frame (window, rotation and transfer; projection {:.1f} ms once){}\n"
                       "wrote {} ({} vertices)\n",
               frame_ms, project_ms,
               lights.empty() ? std::string() : fmt::format("; lights' direct light {:.1f} ms", lights_ms), a.output,
               written);
  return 0;
}

}  // namespace

Run add_relight(CLI::App& app) {
  auto a = std::make_shared<RelightArgs>();
  CLI::App* s = app.add_subcommand("relight", "Outgoing radiance of every vertex under an environment map (CPU)");
  s->footer(
      "Radiance is in the map's units: albedo 1, unshadowed, under a constant map of 1 gives exactly 1.\n"
      "The basis comes from the transfer file: SH files take --window/--window-width/--direct, wavelet files\n"
      "(prt precompute --basis wavelet) take --terms/--selection. For an SH file of any band count (1 to 64)\n"
      "the lighting is projected and rotated (--rotate) to 1e-12 in double (prt verify --bands-max 64); the\n"
      "transfer itself is stored in float.\n"
      "A glossy file (prt precompute --material glossy) takes --eye x,y,z: each vertex's radiance toward that point,\n"
      "diffuse plus a Phong lobe of exponent --gloss and strength --specular (docs/GLOSSY.md).\n"
      "PLY output is float colours (linear radiance, which many viewers cannot show); --tonemap aces --srgb\n"
      "writes 8-bit display colours any viewer shows (--exposure first, in stops).\n"
      "Example: prt relight bunny.off bunny.prt envmaps/forest.exr --rotate 90,0,0 -o bunny.ply\n"
      "         prt relight bunny.off bunny.prt envmaps/forest.exr -o view.ply --tonemap aces --srgb --exposure -1\n"
      "         prt relight bunny.off glossy.prt envmaps/forest.exr --eye 0,0.1,0.4 --gloss 16 -o g.csv\n"
      "         prt relight bunny.off bunny.wlt envmaps/forest.exr --terms 200 -o bunny.csv\n"
      "         prt relight tube-bent.obj tube-zh.prt envmaps/forest.exr -o bent.ply   (a pose of a --basis zh mesh)\n"
      "         prt relight models/tube-skinned.gltf tube-zh.prt envmaps/forest.exr --time 1 -o bent.ply   (its skin)\n"
      "         prt relight models/room.gltf room.prt envmaps/forest.exr --rotate 90,0,0 -o lightmap.exr\n"
      "         prt relight pages.glb pages.prt envmaps/forest.exr -o lm.exr   (3 pages: lm.1001.exr ... lm.1003.exr)\n"
      "         prt relight models/room.gltf room.prt envmaps/forest.exr -o lm.png --encoding rgbm   (or lm.ktx2: half)\n"
      "         prt relight models/room.gltf room.prt envmaps/forest.exr -o lm.ktx2 --encoding astc-hdr\n"
      "         prt relight models/room.gltf room-probes.prt envmaps/forest.exr --at points.csv -o light.csv");
  s->add_option("MESH", a->mesh,
                "The mesh (or, for a lightmap, the scene) the transfer was computed for; for a --basis zh transfer, any "
                "pose of it (the same vertices and triangles)")->check(path_value())
      ->required();
  s->add_option("TRANSFER", a->transfer, "Transfer file from prt precompute")->check(path_value())->required();
  s->add_option("ENV", a->env, "Environment map")->check(path_value())->required();
  s->add_option("-o,--output", a->output,
                "Output: .ply (mesh with float vertex colours) or .csv (vertex,r,g,b); a lightmap: .exr (RGBA float "
                "atlas, A = 1 where a triangle covers the texel; a lightmap of many pages (prt precompute --pages): "
                "one EXR per page, UDIM tile 1001 + page before the extension or in place of <UDIM>, as "
                "lm.1001.exr, lm.1002.exr ...; .ktx2: half floats or ASTC HDR blocks; .png: 8-bit RGBM or RGBD, see "
                "--encoding)")
      ->check(path_value())
      ->required();
  a->encoding_opt =
      s->add_option("--encoding", a->encoding,
                    "A lightmap's file encoding: float (.exr, the default), half (.exr or .ktx2, the default for "
                    ".ktx2), rgbm or rgbd (8-bit .png, linear, the multiplier in A: RGBM c = C x A x 6, RGBD c = C / "
                    "A, with C and A in [0, 1]), astc-hdr (.ktx2: ASTC HDR 4x4 blocks, 1 byte a texel, for GPUs with "
                    "ASTC HDR); prints the error it adds (docs/LIGHTMAPS.md \"Encodings for engines\")")
          ->check(CLI::IsMember({"float", "half", "rgbm", "rgbd", "astc-hdr"}));
  a->directional_opt = s->add_option(
      "--directional", a->directional,
      "A directional lightmap (prt precompute --lightmap WxH --directional): write the texels' L1 incident light for "
      "normal maps instead of the diffuse atlas, packed as godot (Godot 4's SH lightmap: four half layers stacked in "
      "one EXR), monosh (Bakery's MonoSH: L0 in the EXR, the direction in OUT-dir.png), dominant (Unity's "
      "directional mode: the colour in the EXR, direction and rebalancing in OUT-dir.png) or sh (prt's four float "
      "coefficients, stacked); prints the decode's error (docs/LIGHTMAPS.md \"Directional lightmaps\")")
                           ->check(CLI::IsMember({"godot", "monosh", "dominant", "sh"}));
  add_shared(s, SharedOption::Rotate, a->rotate, "Rotate the lighting");
  a->sh_only.push_back(add_shared(s, SharedOption::Window, a->window, "SH: window against ringing"));
  a->sh_only.push_back(add_shared(s, SharedOption::WindowWidth, a->window_width, "SH: window width in bands"));
  a->sh_only.push_back(s->add_flag("--direct", a->direct,
                                   "SH, interreflected files: use the direct (shadowed) part only (refused for other "
                                   "files)"));
  a->wavelet_only.push_back(add_shared(s, SharedOption::Terms, a->terms, "Wavelet: lighting terms K kept per frame"));
  a->wavelet_only.push_back(
      add_shared(s, SharedOption::Selection, a->selection,
                 "Wavelet: which K terms: area (|c| x support area, Ng et al.'s choice) or magnitude (|c|)"));
  a->dynamic_ao_opt = s->add_flag(
      "--dynamic-ao", a->dynamic_ao,
      "Zonal-harmonic files computed with --dynamic-ao: scale each vertex by the pose's dynamic ambient occlusion over the "
      "rest pose's (Bunnell 2005): the distant occluders a bend brings or takes away, which the lobes cannot follow");
  add_shared(s, SharedOption::Deform, a->deform,
             "Zonal-harmonic files (prt precompute --basis zh): pose MESH procedurally first: bend (its y extent "
             "bent into an arc of ANGLE degrees towards +x) or twist (about y); the PLY output is then the posed mesh "
             "(prt/deform.h)");
  a->time_opt = add_shared(s, SharedOption::Time, a->time,
                           "Zonal-harmonic files: pose MESH, a skinned glTF, by its skin at this time of its "
                           "animation; the PLY output is then the posed mesh (prt/skin.h)");
  a->animation_opt = add_shared(s, SharedOption::Animation, a->animation, "With --time: which of the file's animations");
  add_shared(s, SharedOption::Eye, a->eye, "Glossy files: the eye point the radiance is seen from");
  add_glossy_options(s, a->lobe);
  for (const CLI::Option* o : a->lobe.options) a->sh_only.push_back(o);
  a->sh_only.push_back(s->get_option("--eye"));
  add_shared(s, SharedOption::Tonemap, a->tonemap,
             "Display colours instead of radiance: exposure, then the tone map to [0, 1] (as prt render's 8-bit "
             "images); a PLY then has 8-bit colours");
  a->exposure_opt = add_shared(s, SharedOption::Exposure, a->exposure,
                               "With --tonemap: scale by 2^stops first; auto: prt render's rule with no frame: the 99th "
                               "percentile of the relit vertices' largest channel at 1 (each vertex counted once)");
  a->srgb_opt = s->add_flag("--srgb", a->srgb,
                            "With --tonemap: sRGB-encode the display values (what mesh viewers expect of 8-bit "
                            "vertex colours)");
  s->add_option("--at", a->at,
                "A probe volume (prt precompute --probes): the query points, a CSV with header x,y,z,nx,ny,nz; "
                "writes point,r,g,b: E(p, n)/pi from the probes interpolated at p (docs/PROBES.md)")
      ->check(path_value());
  add_light_options(s, a->light);
  s->add_flag("-q,--quiet", a->quiet, "No summary on stderr");
  return [a] { return run_relight(*a); };
}

}  // namespace prt::cli
