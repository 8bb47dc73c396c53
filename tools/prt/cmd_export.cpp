// prt export: a mesh and its SH transfer as glTF 2.0 (prt/gltf.h), the
// transfer dense in custom vertex attributes, optionally with colours baked
// under a map (COLOR_0), the scene's lights kept (KHR_lights_punctual).
#include "commands.h"
#include "look.h"
#include "progress_bar.h"
#include "inputs.h"
#include "lightmap_inputs.h"
#include "light_options.h"

#include <prt/compressed_transfer.h>
#include <prt/direct_light.h>
#include <prt/envmap.h>
#include <prt/gltf.h>
#include <prt/io.h>
#include <prt/lightmap.h>
#include <prt/lights.h>
#include <prt/precompute.h>
#include <prt/rotation.h>
#include <prt/sh_convention.h>
#include <prt/probes.h>
#include <prt/scene.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/web_export.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <utility>

namespace prt::cli {

namespace {

struct ExportArgs {
  std::string mesh, transfer, output, bake, rotate;
  std::string probes;    // --probes FILE: the probe volume to export (or as TRANSFER)
  std::string exposure;  // stops or auto; unset: 0 for --bake, auto for --web
  bool quiet = false;
  // --bake-material: how a lightmap's bake is shown ("unlit" or "lit": MOZ_lightmap on the scene's materials).
  std::string bake_material = "unlit";
  const CLI::Option* bake_material_opt = nullptr;
  const CLI::Option *rotate_opt = nullptr, *exposure_opt = nullptr;
  // --web DIR: the relighting page (web_export.h, docs/WEB.md).
  std::string web, env, camera, tone_map = "clamp";
  std::string three;  // --three DIR: the three.js page of a lightmap (docs/WEB.md "The three.js page")
  double fov = 40;
  bool force = false, turn = false;
  std::vector<const CLI::Option*> web_opts;  // --env, --camera, --fov, --tonemap, --turn, --force (--web or --three)
  const CLI::Option* fov_opt = nullptr;       // given: the default camera takes it (else 40, or 70 inside a room)
  // A probe volume (prt precompute --probes): --matrices FILE.bin, their input bands.
  std::string matrices;
  int matrix_bands = 3;
  const CLI::Option* matrix_bands_opt = nullptr;
  LightArgs light;  // --lights, --sun (docs/LIGHTS.md "Export")
  // Every output goes through one Outputs (all or nothing): files added
  // later (a web page beside the model) are staged with the glTF.
};

// The lights the exported scene holds (docs/LIGHTS.md "Export"): the scene's
// own (`scene_lights` when the caller loaded it, else read from MESH) and
// --lights files', as prt relight lights it (command_lights). The page draws
// the sky's PRT alone, so --web refuses them.
std::vector<Light> export_lights(const ExportArgs& a, const std::vector<Light>* scene_lights) {
  std::vector<Light> lights = command_lights(a.light, a.mesh, scene_lights);
  if ((a.web.empty() && a.three.empty()) || lights.empty()) return lights;
  const bool from_files =
      std::any_of(a.light.files.begin(), a.light.files.end(), [](const std::string& f) { return f != "none"; });
  const std::string why = fmt::format(
      "{}: {} {} lit by {}: the page relights the sky's PRT only (lights in the page are not implemented yet); give "
      "--lights none to write the page without them, or export the glTF alone (-o FILE.glb keeps them; docs/LIGHTS.md "
      "\"Export\")",
      a.web.empty() ? "--three" : "--web", a.mesh, from_files ? "with --lights is" : "is", describe_lights(lights));
  if (from_files) throw UsageError(why);
  throw Error(why);
}

// The lights whose direct light a bake adds, as prt relight adds them: the
// scene's `lights` and, with --sun auto, the map's sun, taken out of `env` and
// turned by --rotate with the sky (take_sun). `sun_map` (when given and a sun
// is found): the sun's pixels alone, whose bounce an interreflected transfer
// carries (add_sun_bounce).
std::vector<Light> bake_lights(const ExportArgs& a, std::vector<Light> lights, EnvMap& env,
                               const std::array<double, 3>& euler, std::optional<EnvMap>* sun_map) {
  add_map_sun(a.light, lights, env, sh::rotation_from_euler(euler[0], euler[1], euler[2]), a.quiet, sun_map);
  if (!a.quiet && !lights.empty()) fmt::print(stderr, "baked with {} beside the map\n", describe_lights(lights));
  return lights;
}

// What extras records of the bake's lights ("" without).
std::string bake_lights_note(const std::vector<Light>& lights, bool sun) {
  if (lights.empty()) return {};
  return fmt::format("{}{}: their direct light traced as prt relight does (docs/LIGHTS.md)", describe_lights(lights),
                     sun ? ", the map's sun among them (--sun auto)" : "");
}

// The page's initial state, as prt render takes it: --camera (default:
// prt render's, scene_camera of `mesh`, for a square canvas, which a wider
// one still fits), --fov, --rotate, --exposure (default: auto, for the first
// map), --tonemap.
WebPage web_page(const ExportArgs& a, const std::string& dir, const Mesh& mesh, const std::array<double, 3>& euler,
                 ToneMap tone) {
  WebPage w;
  w.dir = dir;
  w.three = dir == a.three;
  w.force = a.force;
  w.turn = a.turn;
  w.maps = web_maps(a.env, w.initial);
  const std::optional<double> fov = a.fov_opt->count() > 0 ? std::optional<double>(a.fov) : std::nullopt;
  w.camera = scene_camera(mesh, 1.0, fov);
  if (!a.camera.empty()) {
    parse_camera(a.camera, w.camera);
    w.camera.fov_deg = a.fov;
  }
  for (int k = 0; k < 3; ++k) w.rotate[k] = euler[k];
  const std::optional<double> given = exposure_stops(a.exposure.empty() ? "auto" : a.exposure);
  // auto: the page measures its first frame; the map's rule (auto_exposure) is
  // the exposure of a browser that cannot read one back.
  const double exposure = given ? *given : auto_exposure(project(load_envmap(w.initial), 3));
  w.display = {exposure, tone};
  w.auto_exposure = !given;
  return w;
}

// Stages the page (stage_web_page); null when Ctrl-C stopped it (then the
// Outputs' commit says so and exits 130).
std::unique_ptr<StagedPage> stage_page(const ExportArgs& a, const WebPage& w, int bands,
                                       const std::function<void(const std::string&)>& write_model) {
  std::unique_ptr<StagedPage> page;
  try {
    page = stage_web_page(w, bands, write_model, [] { return Outputs::interrupted(); }, a.quiet);
  } catch (const Error&) {
    if (!Outputs::interrupted()) throw;
  }
  if (!a.quiet && page) fmt::print(stderr, "{}: {} maps\n", w.dir, w.maps.size());
  return page;
}

void print_page_written(const std::string& dir, bool three) {
  fmt::print(stderr, "wrote {}/ ({}index.html, model.glb, lighting.json, maps/): serve it with "
                     "python3 -m http.server -d {} and open http://localhost:8000/{}\n",
             dir, three ? "the three.js page: " : "", dir,
             three ? " (three.js comes from unpkg.com unless ?three=URL names a copy)" : "");
}

// --three --probes P: the probe volume whose grid lights the page's moving
// object (checked: a volume of the same scene, 3 bands, and a lightmap of 3
// bands or more: the page relights the probes from the map's SH at the
// lightmap's bands); none without.
std::optional<ProbeTransfer> page_probes(const ExportArgs& a, int lightmap_bands) {
  if (a.probes.empty()) return std::nullopt;
  if (lightmap_bands < 3)
    throw Error(fmt::format("--probes: {} has {} bands; the page relights the probes from the map's first 3 bands, which "
                            "it keeps at the lightmap's: precompute the lightmap with --bands 3 or more", a.transfer,
                            lightmap_bands));
  ProbeTransfer t = read_transfer_as<ProbeTransfer>(a.probes);
  if (load_scene_or_mesh(a.mesh).hash() != t.scene_hash)
    throw Error(a.probes + ": computed for another scene than " + a.mesh + ": rerun prt precompute " + a.mesh + " --probes ...");
  if (t.bands != 3) throw Error(fmt::format("{}: {} bands; three.js's probe grid holds 3 (L2): precompute with --bands 3", a.probes, t.bands));
  return t;
}

// The three.js page's probes (docs/WEB.md "The three.js page"): probes.json
// (probe_engine_json under the first map: the grid's place, each probe's
// state) and probes.bin (each probe's SH transfer matrices from the map's 3
// bands, docs/FORMAT.md "Probe matrices"), which the page relights each frame.
void write_page_probes(const ExportArgs& a, const ProbeTransfer& t, const WebPage& w, const std::array<double, 3>& euler,
                       const std::string& dir) {
  ProbeExportNames names;
  names.scene = std::filesystem::path(a.mesh).filename().string();
  names.probes_file = std::filesystem::path(a.probes).filename().string();
  names.map = std::filesystem::path(w.initial).filename().string();
  names.generator = "prt " PRT_VERSION " (prt export --three)";
  write_text_file(dir + "/probes.json", probe_engine_json(t, load_envmap(w.initial), euler, names));
  int channels = 1;
  const std::vector<float> m = probe_sh_matrices(t, 3, channels);
  write_probe_matrices(dir + "/probes.bin", t, m, 3, channels);
}

// A lightmap (prt precompute SCENE --lightmap): the scene with its
// coefficient textures (write_gltf_lightmap; docs/FORMAT.md "Lightmap export"),
// and the page that relights them (docs/WEB.md "Lightmaps").
int run_export_lightmap(const ExportArgs& a, const LightmapTransfer& lt, const std::array<double, 3>& euler,
                        ToneMap tone) {
  if (!a.bake.empty() && a.output.empty())
    throw UsageError("--bake: a lightmap's baked texture goes into the glTF of --output (the page relights the "
                     "coefficient textures): give --output FILE.glb too");
  const prt::Scene scene = load_lightmap_scene(a.mesh, lt.layout);
  const LightmapTexels texels =
      lightmap_texels(scene, lt.layout, lt.transfer.vertex_colors ? nullptr : &lt.transfer.albedo);
  check_matches(lt, texels, a.transfer);
  if (!a.quiet) fmt::print(stderr, "{}\n{}", describe(scene), describe_transfer(lt));
  GltfLightmapOptions opts;
  opts.moz_lightmap = a.bake_material == "lit";
  opts.transfer_source = std::filesystem::path(a.transfer).filename().string();
  opts.generator = "prt " PRT_VERSION " (prt export)";
  opts.lights = export_lights(a, &scene.lights);
  if (!a.bake.empty() && !a.output.empty()) {
    EnvMap env = load_envmap(a.bake);
    require_finite(env);
    std::optional<EnvMap> sun_map;
    const std::vector<Light> lit = bake_lights(a, opts.lights, env, euler, &sun_map);
    std::vector<glm::dvec3> light = project(env, lt.transfer.bands);
    if (!a.rotate.empty()) rotate_lighting(light, lt.transfer.bands, euler.data());
    const std::optional<double> given = exposure_stops(a.exposure.empty() ? "0" : a.exposure);
    const double fixed = given.value_or(0.0);  // auto: 0 here, then measured over the baked texels below
    bake_lightmap(opts, lt, texels, light, std::filesystem::path(a.bake).filename().string(), euler.data(), fixed);
    // The sun's bounce and the lights' direct light, as prt relight adds them
    // to the texels (the lights traced from the sample points prt precompute
    // used: moved out of geometry first), times the same 2^stops.
    std::vector<glm::vec3> more(opts.baked.size(), glm::vec3(0.0f));
    const LightBounce* bounce = bounce_of(lt.transfer, false);  // then the sun bounces as the lights do
    if (!bounce)
      add_sun_bounce(more, sun_map, lt.transfer, texel_points(texels), sh::Window::None, 0, a.rotate.empty() ? nullptr : euler.data());
    add_texel_lights(more, lit, scene.mesh, texels, bounce);
    const float scale = float(std::exp2(fixed));
    for (std::size_t i = 0; i < more.size(); ++i) opts.baked[i] += more[i] * scale;
    opts.bake.lights = bake_lights_note(lit, lit.size() > opts.lights.size());
    if (!given) {  // auto: prt render's rule over the baked texels, each counted once (frame_exposure)
      const double stops = frame_exposure({reinterpret_cast<const float*>(opts.baked.data()), 3 * opts.baked.size()});
      for (glm::vec3& c : opts.baked) c *= float(std::exp2(stops));
      opts.bake.exposure = stops;
    }
  }
  Outputs out("export");
  if (!a.output.empty()) out.write([&] { write_gltf_lightmap(a.output, scene, lt, texels, opts); });
  // The pages (--web, --three): the scene's own materials (no bake: the page relights).
  std::vector<std::unique_ptr<StagedPage>> pages;
  const std::optional<ProbeTransfer> probes = page_probes(a, lt.transfer.bands);
  GltfLightmapOptions page_opts = opts;
  page_opts.baked.clear();
  page_opts.lights.clear();  // (none: export_lights refuses them with --web and --three)
  for (const std::string* dir : {&a.web, &a.three}) {
    if (dir->empty()) continue;
    WebPage w = web_page(a, *dir, scene.mesh, euler, tone);
    w.lightmap_albedo = lightmap_image(lt.layout, texels.albedo);
    w.lightmap_width = lt.layout.width;
    w.lightmap_height = lt.layout.page_height();
    w.lightmap_pages = lt.layout.pages;
    if (dir == &a.three && probes) w.write_probes = [&](const std::string& d) { write_page_probes(a, *probes, w, euler, d); };
    pages.push_back(stage_page(a, w, lt.transfer.bands,
                               [&](const std::string& path) { write_gltf_lightmap(path, scene, lt, texels, page_opts); }));
    if (!pages.back()) pages.clear();  // Ctrl-C: the Outputs' commit says so
    if (pages.empty()) break;
  }
  if (const int rc = out.commit(); rc != 0) return rc;
  for (auto& p : pages) p->commit();
  if (!a.quiet) {
    const std::size_t stride = lt.transfer.stride();
    if (!a.output.empty())
      fmt::print(stderr, "wrote {}: {} objects, {} coefficient textures{} ({} RGBA8, {} bytes per texel){}{}\n",
                 a.output, scene.objects.size(), (stride + 3) / 4, lt.layout.pages > 1 ? " per page" : "",
                 lightmap_size_text(lt.layout), 4 * ((stride + 3) / 4),
                 opts.baked.empty() ? ""
                 : opts.moz_lightmap ? ", and the baked lightmap (MOZ_lightmap on the scene's materials, TEXCOORD_1)"
                                     : ", and the baked lightmap (unlit, TEXCOORD_1)",
                 opts.lights.empty() ? "" : "; " + describe_lights(opts.lights) + " as KHR_lights_punctual");
    for (const std::string* dir : {&a.web, &a.three})
      if (!pages.empty() && !dir->empty()) print_page_written(*dir, dir == &a.three);
  }
  return 0;
}

// A probe volume (prt precompute SCENE --probes): every probe relit under
// --bake ENV as engines' SH (three.js LightProbe, Unity SphericalHarmonicsL2)
// in a JSON file, and with --matrices its SH transfer matrices in a binary
// file (docs/PROBES.md "Export"). `held`: the volume when TRANSFER was read
// already (to learn its kind); else --probes FILE is read after the checks.
int run_export_probes(const ExportArgs& a, const std::array<double, 3>& euler, ProbeTransfer* held) {
  if (a.light.given())
    throw UsageError("--lights and --sun: a probe volume's JSON holds each probe's SH of the map; lights inside the "
                     "scene are not in it (docs/LIGHTS.md \"Export\")");
  if (!a.web.empty()) throw UsageError("--web shows a mesh's or a lightmap's transfer; a probe volume exports as JSON (-o FILE.json)");
  if (!a.three.empty()) throw UsageError("--three shows a lightmap (prt precompute SCENE --lightmap); a probe volume exports as JSON (-o FILE.json)");
  if (a.bake_material_opt->count() > 0)
    throw UsageError("--bake-material applies to a lightmap's baked texture; a probe volume exports its probes' SH as JSON");
  if (a.bake.empty()) throw UsageError(a.transfer + " is a probe volume: give --bake ENV (the map its probes are relit under) and -o FILE.json");
  std::string ext = std::filesystem::path(a.output).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".json") throw UsageError("--output: " + a.output + ": a probe volume exports as .json");
  if (!a.matrices.empty()) {
    check_not_input("--matrices", a.matrices, {{"SCENE", a.mesh}, {"PROBES", a.transfer}, {"--bake", a.bake}});
    for_path("--matrices", [&] { check_writable(a.matrices); });
  }
  const ProbeTransfer t = held ? std::move(*held) : read_transfer_as<ProbeTransfer>(a.transfer);
  const prt::Scene scene = load_scene_or_mesh(a.mesh);
  if (scene.hash() != t.scene_hash)
    throw Error(a.transfer + ": computed for another scene than " + a.mesh + ": rerun prt precompute " + a.mesh + " --probes ...");
  if (t.bands != 3) throw Error(fmt::format("{}: {} bands; engines' probes hold 3 (L2): precompute with --bands 3", a.transfer, t.bands));
  EnvMap env = load_envmap(a.bake);
  require_finite(env);
  ProbeExportNames names;
  names.scene = std::filesystem::path(a.mesh).filename().string();
  names.probes_file = std::filesystem::path(a.transfer).filename().string();
  names.map = std::filesystem::path(a.bake).filename().string();
  names.generator = "prt " PRT_VERSION " (prt export)";
  const std::string text = probe_engine_json(t, env, euler, names);
  Outputs out("export");
  out.write([&] { write_text_file(a.output, text); });
  if (!a.matrices.empty()) {
    int channels = 1;
    const std::vector<float> m = probe_sh_matrices(t, a.matrix_bands, channels);
    out.write([&] { write_probe_matrices(a.matrices, t, m, a.matrix_bands, channels); });
  }
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet)
    fmt::print(stderr, "wrote {}: {} probes relit under {} (three.js and Unity L2){}\n", a.output, t.probes(), a.bake,
               a.matrices.empty() ? "" : fmt::format("; {}: {} x {} SH matrices", a.matrices, 9, a.matrix_bands * a.matrix_bands));
  return 0;
}

// A mesh's SH transfer `t` (checked against `mesh`; `compressed`: the rows a
// compressed file reconstructs) as glTF, its rows dense in vertex attributes,
// and the page that relights them.
int export_mesh(const ExportArgs& a, const Mesh& mesh, const Transfer& t, bool compressed,
                const std::array<double, 3>& euler, ToneMap tone) {
  if (!a.quiet) {
    fmt::print(stderr, "{}\n", describe(mesh));
    if (compressed)
      fmt::print(stderr, "{} is compressed: exporting its decompressed rows (prt::decompress)\n", a.transfer);
    if (t.glossy)
      fmt::print(stderr,
                 "{} holds glossy matrices: exporting its diffuse transfer only (glTF attributes hold one row per "
                 "vertex; the view-dependent part needs prt relight/render --eye)\n",
                 a.transfer);
  }

  GltfOptions opts;
  opts.transfer_source = std::filesystem::path(a.transfer).filename().string();
  opts.generator = "prt " PRT_VERSION " (prt export)";
  opts.lights = export_lights(a, nullptr);
  if (!a.bake.empty()) {
    EnvMap env = load_envmap(a.bake);
    require_finite(env);
    // As prt relight: a compressed file keeps no direct part, so the sun's
    // bounce is left out there (its direct light is traced).
    std::optional<EnvMap> sun_map;
    const std::vector<Light> lit = bake_lights(a, opts.lights, env, euler, compressed ? nullptr : &sun_map);
    check_translucent_lights(t, !lit.empty(), a.transfer);
    if (compressed && a.light.sun_auto() && t.mode == TransferMode::Interreflected && !a.quiet)
      fmt::print(stderr, "--sun auto: {} is compressed and keeps no direct part: the sun's bounce is left out (its "
                         "direct light is traced)\n", a.transfer);
    std::vector<glm::dvec3> light = project(env, t.bands);
    if (!a.rotate.empty()) rotate_lighting(light, t.bands, euler.data());
    std::vector<glm::vec3> rgb = relight(t, mesh, light);
    const LightBounce* bounce = compressed ? nullptr : bounce_of(t, false);  // then the sun bounces as the lights do
    if (!bounce) add_sun_bounce(rgb, sun_map, t, mesh, sh::Window::None, 0, a.rotate.empty() ? nullptr : euler.data());
    std::vector<glm::vec3> albedo(rgb.size());
    // The albedo relight's lights use (a glossy file's: its diffuse one).
    for (std::size_t v = 0; v < albedo.size(); ++v) albedo[v] = vertex_albedo(t, mesh, v);
    add_direct_light(rgb, lit, mesh, mesh.positions, mesh.normals, albedo, std::nullopt, bounce);
    opts.bake.lights = bake_lights_note(lit, lit.size() > opts.lights.size());
    const std::optional<double> given = exposure_stops(a.exposure.empty() ? "0" : a.exposure);
    // auto: prt render's rule over the relit vertices, each counted once (frame_exposure).
    const Display clamp{given ? *given : frame_exposure({reinterpret_cast<const float*>(rgb.data()), 3 * rgb.size()}),
                        ToneMap::Clamp};
    opts.colors.resize(rgb.size());
    for (std::size_t v = 0; v < rgb.size(); ++v)
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(rgb[v][c]))
          throw Error(fmt::format("relit radiance of vertex {} is {} ({} channel): the values of {} (max {}) times "
                                  "the transfer of {} overflow float; scale the map down",
                                  v, show_number(rgb[v][c]), "rgb"[c], a.bake, show_number(env.stats.max),
                                  a.transfer));
        opts.colors[v][c] = tone_map(rgb[v][c], clamp);
      }
    opts.bake.map = std::filesystem::path(a.bake).filename().string();
    for (int k = 0; k < 3; ++k) opts.bake.rotate[k] = euler[k];
    opts.bake.exposure = clamp.exposure;
  }

  // One Outputs for the glTF and the page: a failure or Ctrl-C leaves neither.
  Outputs out("export");
  if (!a.output.empty()) out.write([&] { write_gltf(a.output, mesh, t, opts); });
  std::unique_ptr<StagedPage> page;
  if (!a.web.empty())
    page = stage_page(a, web_page(a, a.web, mesh, euler, tone), t.bands,
                      [&](const std::string& path) { write_gltf(path, mesh, t, opts); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (page) page->commit();
  if (!a.quiet) {
    if (!a.output.empty())
      fmt::print(stderr, "wrote {} ({} vertices, {} triangles, {} transfer attributes{}{})\n", a.output,
                 mesh.vertex_count(), mesh.triangles.size(), gltf_transfer_attribute_count(t.bands, t.channels),
                 opts.colors.empty() ? "" : ", COLOR_0",
                 opts.lights.empty() ? "" : "; " + describe_lights(opts.lights) + " as KHR_lights_punctual");
    if (page) print_page_written(a.web, false);
  }
  return 0;
}

UsageError not_gltf(const std::string& output) {
  return UsageError("--output: " + output + ": expected a .glb (binary glTF) or .gltf (JSON glTF) file");
}

// --bake-material lit needs texels (a lightmap): a vertex bake is COLOR_0.
void check_no_bake_material(const ExportArgs& a) {
  if (a.bake_material != "unlit")
    throw UsageError("--bake-material " + a.bake_material + ": " + a.transfer +
                     " is a vertex transfer (its bake is COLOR_0, unlit); lit applies to a lightmap (prt precompute "
                     "SCENE --lightmap)");
}

// The options of a glTF export (-o FILE.glb|.gltf, --bake, --web), checked
// before anything is read: usage errors (exit 2) and outputs that cannot be
// written.
void check_gltf_options(const ExportArgs& a, bool gltf) {
  if (!a.matrices.empty() || a.matrix_bands_opt->count() > 0)
    throw UsageError("--matrices and --matrix-bands apply to a probe volume (prt precompute --probes)");
  if (!a.output.empty() && !gltf) throw not_gltf(a.output);
  for (const CLI::Option* o : {a.rotate_opt, a.exposure_opt})
    if (o->count() > 0 && a.bake.empty() && a.web.empty() && a.three.empty())
      throw UsageError(o->get_name() + " applies to the baked colours and the web page: give --bake ENV or --web DIR too");
  for (const CLI::Option* o : a.web_opts)
    if (o->count() > 0 && a.web.empty() && a.three.empty())
      throw UsageError(o->get_name() + " applies to the web page: give --web DIR (or --three DIR) too");
  if (a.bake_material_opt->count() > 0 && a.bake.empty())
    throw UsageError("--bake-material applies to a lightmap's baked texture: give --bake ENV too");
  if (a.light.sun_opt->count() > 0 && a.bake.empty())
    throw UsageError("--sun applies to the baked colours (the map's sun traced as a light): give --bake ENV too");
  if (!a.output.empty()) {
    check_not_input("--output", a.output, {{"MESH", a.mesh}, {"TRANSFER", a.transfer}, {"--bake", a.bake}});
    for_path("--output", [&] { check_writable(a.output); });
  }
  if (!a.web.empty()) {
    check_not_input("--web", a.web, {{"MESH", a.mesh}, {"TRANSFER", a.transfer}, {"--bake", a.bake}, {"--env", a.env}});
    check_web_dir(a.web, a.force);
  }
  if (!a.three.empty()) {
    check_not_input("--three", a.three, {{"MESH", a.mesh}, {"TRANSFER", a.transfer}, {"--bake", a.bake}, {"--env", a.env}});
    check_web_dir(a.three, a.force);
  }
}

int run_export(const ExportArgs& args) {
  ExportArgs a = args;  // --probes FILE becomes the transfer
  check_distinct_outputs({{"--output", a.output}, {"--web", a.web}, {"--three", a.three}, {"--matrices", a.matrices}});
  if (!a.probes.empty() && a.three.empty()) {
    if (!a.transfer.empty() && a.transfer != a.probes)
      throw UsageError("--probes " + a.probes + " exports a probe volume as JSON; " + a.transfer +
                       " is exported in its own run (prt export SCENE " + a.transfer + " -o FILE.glb)");
    a.transfer = a.probes;
    if (a.output.empty()) throw UsageError("--probes: give -o FILE.json (and --bake ENV)");
    check_not_input("--output", a.output, {{"SCENE", a.mesh}, {"--probes", a.probes}, {"--bake", a.bake}});
    return run_export_probes(a, rotate_degrees(a.rotate), nullptr);
  }
  if (a.transfer.empty()) throw UsageError("give TRANSFER (a file from prt precompute or prt compress) or --probes FILE");
  if (a.output.empty() && a.web.empty() && a.three.empty())
    throw UsageError("give --output FILE.glb|.gltf, --web DIR, --three DIR, or more than one");
  std::string ext = std::filesystem::path(a.output).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  const bool gltf = ext == ".glb" || ext == ".gltf";
  // -o FILE.json without --web: a probe volume given as TRANSFER, its
  // probes' SH as JSON (as with --probes FILE); any other kind is refused.
  const bool probe_json = ext == ".json" && a.web.empty() && a.three.empty();
  if (probe_json) {
    AnyTransfer any = read_transfer_file(a.transfer);
    ProbeTransfer* p = std::get_if<ProbeTransfer>(&any);
    if (!p) throw not_gltf(a.output);
    check_not_input("--output", a.output, {{"SCENE", a.mesh}, {"PROBES", a.transfer}, {"--bake", a.bake}});
    return run_export_probes(a, rotate_degrees(a.rotate), p);
  }
  check_gltf_options(a, gltf);
  AnyTransfer any = read_transfer_file(a.transfer);
  // The page, the glTF and its baked colours each take the kinds the table
  // says (prt/transfer_file.h); the others are refused with its sentence.
  if (!a.web.empty() || !a.three.empty()) require_support(kind_of(any), Consumer::ExportWeb, a.transfer);
  if (gltf) require_support(kind_of(any), Consumer::ExportGlb, a.transfer);
  if (!a.bake.empty()) require_support(kind_of(any), Consumer::ExportBake, a.transfer);
  const std::array<double, 3> euler = rotate_degrees(a.rotate);
  const ToneMap tone = parse_tone_map(a.tone_map);  // checked while parsing

  // The three.js page relights a lightmap only (three's lightMap).
  if (!a.three.empty() && !std::holds_alternative<LightmapTransfer>(any))
    throw Error("--three: " + a.transfer + " is a vertex transfer; the three.js page relights a lightmap (prt precompute "
                "SCENE --lightmap) into three's lightMap: give --web DIR for a vertex transfer's page");
  const auto refused = [](const auto&) -> int {
    PRT_CHECK(false && "refused above by the kind table (Consumer::ExportGlb, ExportBake, ExportWeb)");
    return 1;
  };
  return dispatch(
      any,
      [&](const Transfer& t) {
        check_no_bake_material(a);
        const Mesh mesh = load_mesh(a.mesh);
        check_matches(t, mesh, a.transfer);
        return export_mesh(a, mesh, t, false, euler, tone);
      },
      [&](const CompressedTransfer& c) {  // exported as the rows it reconstructs
        check_no_bake_material(a);
        const Mesh mesh = load_mesh(a.mesh);
        check_matches(c, mesh, a.transfer);
        return export_mesh(a, mesh, decompress(c), true, euler, tone);
      },
      [&](const LightmapTransfer& l) { return run_export_lightmap(a, l, euler, tone); },
      [&](const WaveletTransfer& w) { return refused(w); }, [&](const ZhTransfer& z) { return refused(z); },
      [&](const WaveletLightmap& w) { return refused(w); },
      [&](const ProbeTransfer& p) { return refused(p); });  // (its JSON: above)
}

}  // namespace

Run add_export(CLI::App& app) {
  auto a = std::make_shared<ExportArgs>();
  CLI::App* s = app.add_subcommand("export", "Write a mesh and its SH transfer as glTF 2.0 (.glb or .gltf)");
  s->footer(
      "The transfer is written dense (every vertex, analytic ones evaluated) as custom vertex attributes\n"
      "_PRT_T0, _PRT_T1, ... (VEC4 float: coefficient j of the row [channel][k] in attribute j/4, component\n"
      "j%4), beside POSITION, NORMAL and the indices; asset.extras.prt describes them (docs/FORMAT.md,\n"
      "\"glTF export\").\n"
      "Relighting: radiance[c] = dot(row[c], L[c]), L[c] from prt project (prt's SH convention); a 1-channel\n"
      "row serves R, G and B.\n"
      ".glb is binary; .gltf is JSON with the buffer embedded (base64), one file either way.\n"
      "Compressed files (prt compress) are exported decompressed; glossy files as their diffuse part;\n"
      "wavelet files are refused.\n"
      "A lightmap (prt precompute SCENE --lightmap) is exported as the scene, one node per object, its lightmap\n"
      "UVs as TEXCOORD_1 and its transfer as 8-bit coefficient textures with a scale and bias per coefficient\n"
      "(docs/FORMAT.md, \"Lightmap export\"); --bake adds the baked lightmap; --web relights it per pixel.\n"
      "A lightmap of many pages (--pages) is written as pages: each page's images at a page's size, and each\n"
      "object a primitive per page, its TEXCOORD_1 in that page's [0, 1].\n"
      "A probe volume (prt precompute SCENE --probes), given as TRANSFER or --probes FILE, is exported relit\n"
      "under --bake ENV as JSON: each probe's\n"
      "three.js LightProbe and Unity SphericalHarmonicsL2 arrays; --matrices adds its SH matrices (docs/PROBES.md).\n"
      "--bake ENV adds COLOR_0: the radiance prt relight gives under ENV (--rotate), times 2^--exposure,\n"
      "clamped to [0, 1], linear (not sRGB-encoded), as glTF requires.\n"
      "The scene's lights (a glTF's KHR_lights_punctual, plus --lights FILE.json; --lights none drops the scene's)\n"
      "are written as KHR_lights_punctual, a node each, and --bake adds their direct light as prt relight does\n"
      "(--sun auto: the map's sun too); the page cannot draw lights yet and refuses them (docs/LIGHTS.md).\n"
      "--web DIR writes a static page (index.html, its scripts, model.glb, lighting.json: every\n"
      "bundled map's SH lighting at the transfer's bands, maps/*.rgb16f backgrounds) that relights the model in\n"
      "WebGL2 as prt render draws it; --env, --camera, --fov, --rotate, --exposure, --tonemap set its first frame\n"
      "(without --camera, prt render's default camera: inside a scene that encloses its centre, a room, the eye\n"
      "inside; docs/RUNTIME.md, \"The default camera\").\n"
      "--three DIR (a lightmap) writes the same files with a three.js page: GLTFLoader, MeshPhysicalMaterial, the\n"
      "lightmap relit each frame into their lightMap; it loads three.js from unpkg.com (?three=URL: a copy);\n"
      "--probes P.prt adds a sphere moving through the probe grid, the probes relit each frame (probes.bin).\n"
      "Example: prt export bunny.off bunny.prt -o bunny.glb\n"
      "         prt export bunny.off bunny.prt --web bunny-web --env forest && python3 -m http.server -d bunny-web\n"
      "         prt export bunny.off bunny.prt -o bunny.gltf --bake envmaps/forest.exr --rotate 90,0,0 --exposure -1\n"
      "         prt export room.gltf room.prt -o room.glb --web room-web --camera 1.7,1.7,1.8,-0.6,0.6,-0.9,0,1,0\n"
      "         prt export room.gltf room.prt --three room-three\n"
      "         prt export room.gltf --probes room-probes.prt --bake forest.exr -o probes.json --matrices probes.bin");
  s->add_option("MESH", a->mesh, "The mesh the transfer was computed for")->check(path_value())->required();
  s->add_option("TRANSFER", a->transfer, "SH transfer file from prt precompute (or prt compress); a probe volume may "
                                         "come here or as --probes")->check(path_value());
  s->add_option("--probes", a->probes, "A probe volume (prt precompute SCENE --probes) to export relit under --bake ENV "
                                       "as JSON (-o FILE.json); with --three, the grid that lights the page's moving object")
      ->check(path_value());
  s->add_option("-o,--output", a->output, "Output: .glb (binary glTF) or .gltf (JSON glTF, buffer embedded)")
      ->check(path_value());
  s->add_option("--bake", a->bake, "Environment map: also write COLOR_0, the relit colour under it")
      ->check(path_value());
  a->bake_material_opt =
      s->add_option("--bake-material", a->bake_material,
                    "With --bake of a lightmap: unlit (default; an sRGB PNG of the radiance under KHR_materials_unlit) or "
                    "lit (the scene's PBR materials with the irradiance as MOZ_lightmap, three.js's lightMap; "
                    "docs/FORMAT.md \"Lightmap export\")")
          ->check(CLI::IsMember({"unlit", "lit"}));
  a->rotate_opt = add_shared(s, SharedOption::Rotate, a->rotate, "With --bake or --web: rotate the lighting");
  a->exposure_opt = add_shared(s, SharedOption::Exposure, a->exposure,
                               "With --bake: scale the radiance by 2^stops before clamping (default 0); with --web: "
                               "the initial exposure (default auto); auto: prt render's rule (the 99th percentile of the "
                               "model's largest channel at 1) over the baked vertices or texels, and on the page from "
                               "its first frame");
  s->add_option("--web", a->web, "Also (or instead) write the relighting web page into this directory (docs/WEB.md)")
      ->check(path_value());
  s->add_option("--three", a->three,
                "A lightmap: also (or instead) write the three.js page into this directory: three's GLTFLoader and "
                "standard materials, the lightmap relit each frame into their lightMap (docs/WEB.md \"The three.js "
                "page\"); takes --web's options")
      ->check(path_value());
  a->web_opts.push_back(
      s->add_option("--env", a->env, "With --web or --three: the map shown first (a file, or a bundled map's name)")
          ->check(path_value()));
  a->web_opts.push_back(
      add_shared(s, SharedOption::Camera, a->camera, "With --web or --three: initial camera (as prt render)"));
  a->fov_opt = add_shared(s, SharedOption::Fov, a->fov,
                          "With --web or --three: vertical field of view (default 40, or 70 for the camera inside a room)");
  a->web_opts.push_back(a->fov_opt);
  a->web_opts.push_back(
      add_shared(s, SharedOption::Tonemap, a->tone_map, "With --web: initial tone map (the three.js page draws clamp)"));
  a->web_opts.push_back(s->add_flag("--turn", a->turn, "With --web or --three: start with the environment turning"));
  a->web_opts.push_back(s->add_flag("--force", a->force, "With --web or --three: replace an existing non-empty directory"));
  s->add_option("--matrices", a->matrices,
                "A probe volume: also write every probe's SH transfer matrix (its light from the map's first "
                "--matrix-bands bands) as a binary file (docs/FORMAT.md \"Probe matrices\")")->check(path_value());
  a->matrix_bands_opt = s->add_option("--matrix-bands", a->matrix_bands, "With --matrices: the map's bands the matrices take")
                            ->check(int_range(1, kMaxProbeMatrixBands))
                            ->capture_default_str();
  add_light_options(s, a->light);
  s->add_flag("-q,--quiet", a->quiet, "No summary on stderr");
  return [a] { return run_export(*a); };
}

}  // namespace prt::cli
