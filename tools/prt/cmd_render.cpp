// prt render: headless OpenGL rendering of a precomputed mesh under an
// environment map (prt::Renderer, EGL, no display needed).
#include "commands.h"
#include "look.h"
#include "probe_object_options.h"
#include "progress_bar.h"
#include "inputs.h"
#include "light_options.h"

#include <prt/envmap.h>
#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/wavelet_playback.h>
#include <prt/deform.h>
#include <prt/skin.h>

#include <fmt/core.h>
#include <glm/trigonometric.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <sstream>

namespace prt::cli {

namespace {

struct RenderArgs {
  std::string mesh, transfer, env, output, camera, rotate;
  int width = 512, height = 512, frames = 1;
  double fov = 40, spin = 0;
  bool frames_given = false, spin_given = false, quiet = false, alpha = false;
  ProbeObjectArgs probe;  // --probes FILE --object MESH (docs/PROBES.md "Rendering")
  std::vector<const CLI::Option*> probe_opts;
  LookArgs look;
  GlossyArgs lobe;  // glossy files only
  std::string deform;  // --deform bend:ANGLE|twist:ANGLE (zonal-harmonic files)
  // A skinned glTF MESH with a zonal-harmonic file: the time (of one frame,
  // or the first of --frames) and the animation.
  double time = 0;
  int animation = 0;
  const CLI::Option* time_opt = nullptr;
  const CLI::Option* animation_opt = nullptr;
  const CLI::Option* fov_opt = nullptr;  // given: the default camera takes it (else 40, or 70 inside a room)
  LightArgs light;                       // --lights, --sun (docs/LIGHTS.md)
  std::vector<std::string> light_paths;  // --light-path INDEX:x,y,z;...
  int shadow_size = kDefaultShadowMapSize;
};

// OUT.png, frame 3 -> OUT_0003.png
std::string frame_path(const std::string& out, int frame) {
  const std::filesystem::path p(out);
  return (p.parent_path() / (p.stem().string() + fmt::format("_{:04d}", frame) + p.extension().string())).string();
}

// What run_render's phases share: the scene and what the options make of it.
struct RenderJob {
  Scene scene;
  bool zh = false, wavelet = false, glossy = false;
  Deform deform;
  std::optional<Skin> skin;  // a skinned glTF with a zonal-harmonic file: its animation, skinned on the GPU
  double duration = 0;       // the animation's loop, seconds
  glm::dvec3 diffuse{0.0};   // --diffuse (glossy files)
  Look look;
  Camera cam;
  // The renderer, made once the scene is checked; it and what draws with it
  // (below) are destroyed before the members above.
  std::optional<Renderer> renderer;
  std::optional<WaveletPlayback> playback;  // a wavelet transfer's relighting
  std::optional<ProbeObject> probe_object;  // --probes --object, lit by the probe volume
  // Lights inside the scene (docs/LIGHTS.md "On the GPU"), the map as
  // loaded for the background when --sun auto took the sun out of
  // scene.env, and a lightmap's points for the lights.
  RenderLights lights;
  std::optional<EnvMap> background;
  std::optional<LightmapTexels> light_points;
};

// The lights: read, the sun split off, checked against the kind drawn; a
// lightmap's texels moved out of geometry as prt precompute moved them (the
// points prt relight lights), before the upload frees the scene.
void prepare_lights(const RenderArgs& a, RenderJob& j) {
  if (a.light.sun_auto()) j.background = j.scene.env;
  const std::vector<Light>* own = j.scene.world ? &j.scene.world->lights : nullptr;
  j.lights = render_lights(a.light, a.light_paths, j.scene.env, a.mesh, own, a.quiet);
  check_translucent_lights(j.scene.header, !j.lights.empty(), a.transfer);
  if (j.lights.empty()) {
    j.background.reset();
    return;
  }
  j.light_points = renderer_light_points(j.scene);
}

// The options that need no file: --probes with --object, --rotate (returned,
// in degrees), --output's type and that it is none of the inputs, --alpha.
std::array<double, 3> check_render_options(const RenderArgs& a) {
  for (const CLI::Option* o : a.probe_opts)
    if (o->count() > 0 && (a.probe.probes.empty() || a.probe.object.empty()))
      throw UsageError("--probes FILE and --object MESH go together (" + o->get_name() + " was given)");
  std::array<double, 3> euler = rotate_degrees(a.rotate);
  if (const std::string problem = image_output_type_problem(a.output); !problem.empty())
    throw UsageError("--output: " + problem);
  if (a.alpha && image_output_type_problem(a.output).empty()) {
    std::string ext = std::filesystem::path(a.output).extension().string();
    for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    if (ext != ".exr") throw UsageError("--alpha: " + a.output + ": an image with alpha is written as EXR (.exr)");
  }
  for (int f = 0; f < (a.frames_given ? a.frames : 1); ++f)
    check_not_input("--output", a.frames_given ? frame_path(a.output, f) : a.output,
                    {{"MESH", a.mesh},
                     {"TRANSFER", a.transfer},
                     {"ENV", a.env},
                     {"--probes", a.probe.probes},
                     {"--object", a.probe.object}});
  for_path("--output", [&] { check_image_output(a.output); });
  return euler;
}

// What the loaded scene takes of the options: --deform and a skin need a
// zonal-harmonic file, the glossy options a glossy one; the look.
void check_render_scene(const RenderArgs& a, RenderJob& j) {
  j.zh = j.scene.kind() == TransferKind::ZH;
  const bool zh = j.zh;
  if (!a.deform.empty() && !zh)
    throw Error(a.transfer + ": --deform needs a transfer that can follow a deformation (prt precompute --basis zh; "
                "docs/LDPRT.md); this one is baked for one pose");
  j.deform = a.deform.empty() ? Deform{} : parse_deform(a.deform);
  // A skinned glTF with a zonal-harmonic file: its animation, skinned on the GPU.
  j.skin = zh ? load_mesh_skin(a.mesh, j.scene.mesh) : std::nullopt;
  check_skin_options(j.skin, zh, !a.deform.empty(), {a.time_opt, a.animation_opt}, a.mesh, a.transfer);
  j.duration = j.skin ? animation_duration(*j.skin, a.animation) : 0.0;
  if (zh && a.look.shading_option->count() > 0 && a.look.shading != "transfer" && a.look.shading != "lambert")
    throw Error(a.transfer + ": --shading " + a.look.shading + ": a zonal-harmonic transfer shows transfer or lambert");
  const Transfer& t = j.scene.header;
  j.wavelet = j.scene.kind() == TransferKind::Wavelet;
  j.glossy = !j.wavelet && t.glossy;
  if (a.lobe.given() && !j.glossy) {
    for (const CLI::Option* o : a.lobe.options)
      if (o->count() > 0)
        // An option that does not fit the file: the file's mismatch (exit 1, naming it).
        throw Error(a.transfer + ": " + o->get_name() +
                    " needs a glossy transfer (prt precompute --material glossy); this one has no glossy matrices");
  }
  j.diffuse = parse_diffuse(a.lobe.diffuse);
  j.look = parse_look(a.look, j.wavelet ? 0 : t.bands, j.wavelet, j.glossy);
}

// The camera: scene_camera (prt/render.h: from outside, or inside a mesh
// that encloses its centre). A deforming mesh is framed in its rest and its
// most deformed pose; a skinned one in its rest and poses over its
// animation's loop (the same camera at every --time).
void frame_render_camera(const RenderArgs& a, RenderJob& j) {
  const Mesh& mesh = j.scene.mesh;
  Mesh framed;
  if (j.zh && j.deform.kind != Deform::Kind::None) {
    framed.positions = mesh.positions;
    const Mesh posed = deform_mesh(mesh, j.deform);
    framed.positions.insert(framed.positions.end(), posed.positions.begin(), posed.positions.end());
  }
  if (j.skin) framed.positions = animation_extent(mesh, *j.skin, a.animation);
  const std::optional<double> fov = a.fov_opt->count() > 0 ? std::optional<double>(a.fov) : std::nullopt;
  j.cam = scene_camera(framed.positions.empty() ? mesh : framed, double(a.width) / a.height, fov);
  if (!a.camera.empty()) {
    parse_camera(a.camera, j.cam);
    j.cam.fov_deg = a.fov;
  }
}

// The environment and the transfer to the renderer, with the shading the
// look asks for (refused, naming the file, when the file lacks what it needs).
void upload_render_scene(const RenderArgs& a, RenderJob& j) {
  Renderer& renderer = *j.renderer;
  const Transfer& t = j.scene.header;  // the SH header fields (the arrays go to the renderer)
  const Look& look = j.look;
  renderer.set_environment(j.background ? *j.background : j.scene.env);
  renderer.set_shadow_map_size(a.shadow_size);
  if (j.wavelet) {
    upload(renderer, j.scene, a.transfer);
    j.playback.emplace(*j.scene.wavelet(), j.scene.env);
    if (look.shading != Shading::Transfer && look.shading != Shading::Lambert)
      throw Error("--shading " + std::string(shading_name(look.shading)) +
                  ": a wavelet transfer shows transfer (the wavelet relighting) or lambert");
  } else {
    if (look.shading == Shading::Direct) check_direct(t, a.transfer, "--shading direct");
    if (look.shading == Shading::Glossy && !j.glossy)
      throw Error(a.transfer + ": --shading glossy needs a glossy transfer (prt precompute --material glossy)");
    upload(renderer, j.scene, a.transfer);
    if (j.light_points) {  // after the scene's upload, which clears what a previous scene had
      renderer.set_light_points(j.light_points->positions, j.light_points->normals, j.light_points->albedo);
      j.light_points.reset();
    }
    if (j.skin) renderer.set_skin(*j.skin);
    release_uploaded(j.scene);  // the renderer has them: `t` keeps the header fields
    renderer.set_band_limit(look.bands);
    try {  // refused (exit 1) when the file lacks what the shading needs: name it
      renderer.set_shading(look.shading);
    } catch (const Error& e) {
      throw Error(a.transfer + ": " + e.what());
    }
    if (j.glossy) {  // the file's rules for --diffuse (an interreflected file takes its own albedo or 0)
      try {
        renderer.set_glossy(a.lobe.gloss, a.lobe.specular, j.diffuse);
      } catch (const Error& e) {
        throw Error(a.transfer + ": " + e.what());
      }
    }
  }
}

// The lighting (SH of the map, exposure, window) and the frames, rotated by
// `euler` then --spin, staged and written; returns the exit code.
int render_frames(const RenderArgs& a, RenderJob& j, const std::array<double, 3>& euler) {
  Renderer& renderer = *j.renderer;
  const Transfer& t = j.scene.header;
  const EnvMap& env = j.scene.env;
  const bool wavelet = j.wavelet;
  Look& look = j.look;
  // SH: project once; each frame only rotates the coefficients. Wavelet: each
  // frame resamples the rotated map (no cheap rotation in that basis). Lambert
  // needs 3 bands of SH lighting in both.
  const int sh_bands = wavelet ? 3 : t.bands;
  std::vector<glm::dvec3> light = project(env, sh_bands);
  light = windowed_lighting(std::move(light), wavelet ? sh_bands : look.bands, look.window);
  std::vector<glm::dvec3> rotated(light.size());
  const glm::dmat3 base = sh::rotation_from_euler(euler[0], euler[1], euler[2]);
  sh::Rotation rotation(sh_bands, base);
  const double spin = a.spin_given ? a.spin : (a.frames > 1 ? 360.0 / a.frames : 0.0);

  // The frames are staged (Outputs): a failed write or Ctrl-C between frames
  // leaves none of them, and the old files.
  Outputs out("render");
  double render_seconds = 0, cpu_ms = 0;
  int maps_drawn = 0;  // shadow maps redrawn (only what moved)
  int width = 0, height = 0;
  {
    ProgressBar bar(a.quiet || a.frames == 1);
    const Progress progress = bar.callback();
    for (int f = 0; f < a.frames; ++f) {
      if (!progress(std::size_t(f), std::size_t(a.frames), "frames")) break;  // Ctrl-C: commit() says so
      const glm::dmat3 R = sh::rotation_axis_angle({0, 1, 0}, glm::radians(spin * f)) * base;
      const auto t0 = std::chrono::steady_clock::now();
      rotation.set(R);
      rotation.apply(light, rotated);
      renderer.set_lighting(rotated);
      renderer.set_environment_rotation(R);
      if (!j.lights.empty()) renderer.set_lights(j.lights.at(double(f) / a.frames, R));
      if (j.probe_object) j.probe_object->frame(renderer, R, double(f) / a.frames);
      // The deformation: the whole angle in one frame; over several, from
      // the rest pose to the whole angle and back.
      if (j.zh && j.deform.kind != Deform::Kind::None)
        renderer.set_pose(j.deform, a.frames > 1 ? 0.5 * (1.0 - std::cos(2.0 * M_PI * f / a.frames)) : 1.0);
      // The skin: --time, and over several frames one loop from there.
      if (j.skin) renderer.set_pose(joint_matrices(*j.skin, a.time + j.duration * f / a.frames, a.animation));
      if (wavelet && look.shading == Shading::Transfer) {
        cpu_ms += j.playback->frame(renderer, R, look.terms, look.selection);  // drawn as vertex colours
      } else if (wavelet) {
        renderer.set_shading(Shading::Lambert);
      }
      Image img = renderer.render(j.cam, a.width, a.height);
      maps_drawn += renderer.shadow_maps_drawn();
      render_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      width = img.width;
      height = img.height;
      const bool measure = look.auto_exposure && f == 0;
      const std::vector<float> alpha = a.alpha || measure ? renderer.coverage() : std::vector<float>{};
      if (measure) {  // --exposure auto: from the first frame, kept for the sequence (frame_exposure)
        look.display.exposure = frame_exposure(img.rgb, alpha);
        if (!a.quiet) fmt::print(stderr, "--exposure auto: {:+.2f} stops\n", look.display.exposure);
      }
      out.write([&] {
        write_frame(a.frames_given ? frame_path(a.output, f) : a.output, std::move(img), look.display,
                    a.alpha ? &alpha : nullptr);
      });
    }
    if (!Outputs::interrupted()) progress(std::size_t(a.frames), std::size_t(a.frames), "frames");
  }
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet) {
    if (a.frames_given)
      fmt::print(stderr, "wrote {} frames {} to {} ({}x{})\n", a.frames, frame_path(a.output, 0),
                 frame_path(a.output, a.frames - 1), width, height);
    else
      fmt::print(stderr, "wrote {} ({}x{})\n", a.output, width, height);
    fmt::print(stderr, "{} frame(s), {:.2f} ms per frame (rotate, upload, draw, read back)\n", a.frames,
               1e3 * render_seconds / a.frames);
    if (!j.lights.empty())
      fmt::print(stderr, "lights: {} shadow map(s) of {} texels a side redrawn over {} frame(s) (only what moved)\n",
                 maps_drawn, a.shadow_size, a.frames);
    if (!j.lights.empty() && j.probe_object)
      fmt::print(stderr, "{}\n",
                 j.renderer->probe_object_lights_bounce()
                     ? "the probe-lit object: the lights' direct light, and their light off the scene's surfaces at "
                       "its probes (the transfer's light-bounce probe rows)"
                     : "the probe-lit object: the lights' direct light alone (its probes take the lights' light off "
                       "the surfaces from a transfer precomputed with --light-bounce --probes of the volume's grid; "
                       "docs/LIGHTS.md \"Bounce\")");
    if (wavelet && look.shading == Shading::Transfer)
      fmt::print(stderr, "wavelet relighting on the CPU: {:.2f} ms per frame (K = {}, {} selection, cube {}^2 x 6)\n",
                 cpu_ms / a.frames, look.terms, wavelet::selection_name(look.selection), j.scene.wavelet()->cube_res);
  }
  return 0;
}

int run_render(const RenderArgs& a) {
  const std::array<double, 3> euler = check_render_options(a);
  RenderJob j;
  j.scene = load_scene(a.mesh, a.transfer, a.env, Consumer::Render, kMaxRenderBands, "render");
  check_render_scene(a, j);
  frame_render_camera(a, j);
  prepare_lights(a, j);

  Renderer& renderer = j.renderer.emplace();
  if (!a.quiet)
    fmt::print(stderr, "{}\n{}\nOpenGL: {}\n", j.scene.world ? describe(*j.scene.world) : describe(j.scene.mesh),
               describe(j.scene.env), renderer.device());
  if (j.skin && !a.quiet)
    fmt::print(stderr, "skinned on the GPU: {} joints, {}\n", j.skin->joint_count,
               j.skin->animations.empty()
                   ? std::string("no animation (the rest pose)")
                   : fmt::format("animation {} '{}' ({:g} s loop)", a.animation,
                                 j.skin->animations[std::size_t(a.animation)].name, j.duration));
  upload_render_scene(a, j);

  // --probes --object: an object lit by the probe volume, on a path through it.
  if (!a.probe.probes.empty()) {
    j.probe_object.emplace(load_probe_object(a.probe, a.mesh, j.scene.env, renderer));
    if (!a.quiet) fmt::print(stderr, "{}\n", j.probe_object->describe());
  }
  return render_frames(a, j, euler);
}

}  // namespace

Run add_render(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  CLI::App* s = app.add_subcommand("render", "Render a precomputed mesh under an environment map (headless OpenGL)");
  s->footer(
      "Per-vertex PRT shading on the GPU (OpenGL 4.5 through EGL, no display needed; Mesa llvmpipe works).\n"
      "Without --camera: a three-quarter view from above (from +Z turned 35 degrees toward +X, 20 degrees up)\n"
      "that frames every vertex with a 5% margin; for a scene that encloses its centre (a room: most rays from\n"
      "the centre of its bounds meet a wall's front), the eye inside, looking across the room toward its openings\n"
      "(windows), 70 degrees wide unless --fov (docs/RUNTIME.md, \"The default camera\"). Without --exposure (auto): from what the first frame shows,\n"
      "the 99th percentile of the model's pixels (linear, their largest channel; not the background) at 1, kept\n"
      "for every frame of a sequence: at most 1% of the model clips, and an interior shows by its own light.\n"
      "The environment is drawn as background; lighting and background turn together with --rotate/--spin.\n"
      "SH transfers are relit on the GPU; wavelet transfers (prt precompute --basis wavelet) on the CPU each\n"
      "frame (rotated map resampled into the cube, K Haar terms, --terms/--selection), then drawn.\n"
      "Glossy files (prt precompute --material glossy) show --shading glossy by default: the diffuse transfer plus\n"
      "a Phong lobe (--gloss, --specular, --diffuse) seen from the camera's eye, both on the GPU.\n"
      "EXR output keeps linear floats (times 2^exposure); PNG and other 8-bit formats get the tone map\n"
      "(--tonemap, default clamp) and sRGB encoding.\n"
      "Zonal-harmonic files (prt precompute --basis zh) follow a deformation: --deform bend:ANGLE or twist:ANGLE,\n"
      "or when MESH is a skinned glTF its animation, skinned on the GPU: one frame at --time (default 0), --frames N\n"
      "one loop from there.\n"
      "Example: prt render bunny.off bunny.prt envmaps/forest.exr -o bunny.png --frames 36 --spin 10\n"
      "         prt render models/tube.obj tube-zh.prt envmaps/forest.exr --deform bend:120 --frames 48 -o tube.png\n"
      "         prt render models/tube-skinned.gltf zh.prt envmaps/forest.exr --frames 48 --spin 0 -o tube.png");
  s->add_option("MESH", a->mesh, "The mesh the transfer was computed for")->check(path_value())->required();
  s->add_option("TRANSFER", a->transfer, "Transfer file from prt precompute")->check(path_value())->required();
  s->add_option("ENV", a->env, "Environment map (lat-long or cube)")->check(path_value())->required();
  s->add_option("-o,--output", a->output, "Output image (.png, .exr, ...); with --frames, OUT_0000.ext, ...")
      ->check(path_value())
      ->required();
  a->probe_opts.push_back(s->add_option("--probes", a->probe.probes,
                                       "A probe volume of SCENE (prt precompute SCENE --probes): light --object with it")
                              ->check(path_value()));
  a->probe_opts.push_back(s->add_option("--object", a->probe.object,
                                       "With --probes: a mesh lit by the probes, moving on a circle through the volume "
                                       "(one turn over the frames; docs/PROBES.md)")->check(path_value()));
  a->probe_opts.push_back(add_shared(s, SharedOption::ObjectSize, a->probe.size,
                                     "With --object: its bounding box's diagonal (default twice the smallest probe spacing)"));
  a->probe_opts.push_back(add_shared(s, SharedOption::ObjectAt, a->probe.at, "With --object: a fixed position instead of the path"));
  add_shared(s, SharedOption::Width, a->width, "Image width");
  add_shared(s, SharedOption::Height, a->height, "Image height");
  add_shared(s, SharedOption::Camera, a->camera, "Camera; default: the framing camera (below)");
  a->fov_opt = add_shared(s, SharedOption::Fov, a->fov, "Vertical field of view (default 40, or 70 for the camera inside a room)");
  add_shared(s, SharedOption::Rotate, a->rotate, "Rotate the lighting");
  add_shared(s, SharedOption::Frames, a->frames, "Render K frames, spinning the environment about +Y")
      ->each([a](const std::string&) { a->frames_given = true; });
  s->add_option("--spin", a->spin, "Degrees about +Y per frame (default 360 / frames)")
      ->check(finite_number())
      ->each([a](const std::string&) { a->spin_given = true; });
  add_shared(s, SharedOption::Deform, a->deform,
             "Zonal-harmonic files (prt precompute --basis zh): deform the mesh on the GPU, bend (its y extent bent "
             "into an arc of ANGLE degrees towards +x) or twist (about y); with --frames, from the rest pose to the "
             "whole angle and back while the environment turns (prt/deform.h, docs/LDPRT.md)");
  a->time_opt = add_shared(s, SharedOption::Time, a->time,
                           "Zonal-harmonic files of a skinned glTF MESH: its pose at this time of the animation; with "
                           "--frames the first frame's, the frames then one loop (prt/skin.h)");
  a->animation_opt = add_shared(s, SharedOption::Animation, a->animation,
                                "A skinned glTF MESH: which of the file's animations");
  add_look_options(s, a->look);
  add_glossy_options(s, a->lobe);
  add_light_options(s, a->light);
  s->add_option("--light-path", a->light_paths,
                "INDEX:x,y,z;x,y,z;...: light INDEX (as listed on stderr) goes round this closed path once over the "
                "frames; repeatable")
      ->check([](const std::string& v) -> std::string {
        try {
          parse_light_path(v);
          return {};
        } catch (const Error& e) {  // CLI11 names the option: the reason after it
          const std::string m = e.what(), lead = "--light-path: ";
          return m.rfind(lead, 0) == 0 ? m.substr(lead.size()) : m;
        }
      });
  add_shared(s, SharedOption::ShadowMapSize, a->shadow_size, "Lights' shadow maps");
  s->add_flag("--alpha", a->alpha,
              "Write RGBA (EXR only): A = 1 where the model covers the pixel, 0 where the background shows");
  s->add_flag("-q,--quiet", a->quiet, "No summary on stderr");
  return [a] { return run_render(*a); };
}

}  // namespace prt::cli
