// python/src/bind_render.cpp - prt's Python module: render, a frame as prt
// render draws it, on the process's one OpenGL thread (GlWorker).
#include "module.h"

#include <prt/deform.h>
#include <prt/lightmap.h>
#include <prt/lights.h>
#include <prt/precompute.h>
#include <prt/probe_object.h>
#include <prt/probes.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/scene.h>
#include <prt/transfer_io.h>
#include <prt/wavelet.h>
#include <prt/wavelet_playback.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <thread>

namespace prt::python {
namespace {

// ---- rendering -----------------------------------------------------------------
//
// One OpenGL context for the process: an EGL context is current on one thread
// at a time, so the renderer lives on a thread of its own, made with it on the
// first render() and reused by every later one, whichever Python thread
// calls; calls are served in turn. Stopped at interpreter exit (the renderer
// destroyed on its thread).
class GlWorker {
 public:
  static GlWorker& get() {
    static GlWorker* w = [] {
      started_ = true;
      return new GlWorker();  // lives to the end; atexit stops its thread
    }();
    return *w;
  }
  static bool started() { return started_; }
  // Runs f(renderer) on the GL thread and returns its result, rethrowing its
  // exception; the first call creates the renderer (NoGlContext when there
  // is no OpenGL 4.5: every later call says so again).
  template <typename F>
  auto run(F&& f) -> decltype(f(std::declval<prt::Renderer&>())) {
    using R = decltype(f(std::declval<prt::Renderer&>()));
    std::optional<R> result;
    std::exception_ptr error;
    bool done = false;
    std::mutex m;
    std::condition_variable cv;
    post([&] {
      try {
        if (!renderer_) {
          if (failure_) std::rethrow_exception(failure_);
          try {
            renderer_ = std::make_unique<prt::Renderer>();
          } catch (...) {
            failure_ = std::current_exception();
            throw;
          }
        }
        result.emplace(f(*renderer_));
      } catch (...) {
        error = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(m);
      done = true;
      cv.notify_one();
    });
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return done; });
    if (error) std::rethrow_exception(error);
    return std::move(*result);
  }
  void stop() {
    if (!thread_.joinable()) return;
    post([this] { renderer_.reset(); });
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_one();
    thread_.join();
  }

 private:
  GlWorker() : thread_([this] { loop(); }) {}
  void post(std::function<void()> task) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) throw Error("the renderer has stopped (the interpreter is exiting)");
      tasks_.push_back(std::move(task));
    }
    cv_.notify_one();
  }
  void loop() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stopping_ || !tasks_.empty(); });
        if (tasks_.empty()) return;  // stopping, and nothing left
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::unique_ptr<prt::Renderer> renderer_;
  std::exception_ptr failure_;
  std::thread thread_;  // last: started once the rest is ready
  static inline std::atomic<bool> started_{false};
};

// One render() call: its arguments, as the binding takes them, then what its
// steps work out from them. run() takes the steps in order: check_target (the
// transfer and the Mesh or Scene it is drawn on), check_options,
// check_probes, check_lights, set_view, then draw without the GIL; every
// check comes in the order prt render's options are checked.
struct RenderCall {
  const py::object& transfer;
  const py::object& mesh_arg;
  const py::object& map;
  int width, height;
  const py::object& camera;
  const py::object& fov_arg;  // None: the default camera's (40 degrees, 70 inside a room)
  std::optional<double> fov;
  const py::object& rotate;
  const py::object& exposure;
  const std::string& tone_map;
  bool linear;
  const py::object& shading;
  const py::object& bands_arg;
  double gloss, specular;
  const py::object& diffuse;
  const py::object& deform;
  double amount;
  int terms;
  const std::string& selection;
  bool alpha;
  const py::object& probes;
  const py::object& object;
  const py::object& object_at;
  double object_size;
  const py::object& lights_in;
  const std::string& sun;
  int shadow_map_size;

  // check_target: what is drawn (drawn_mesh: the Mesh, or the Scene's mesh).
  bool is_zh = false, is_wavelet = false, is_lightmap = false;
  const prt::LightmapTransfer* lm = nullptr;
  const prt::Scene* world = nullptr;
  const prt::Mesh* drawn_mesh = nullptr;
  const PyTransfer* p = nullptr;
  const PyZhTransfer* z = nullptr;
  const PyWavelet* wt = nullptr;
  std::string source;
  // check_options.
  prt::wavelet::Selection sel{};
  int file_bands = 0, bands = 0;
  bool glossy = false;
  prt::Shading shade{};
  glm::dvec3 rho_d{};
  std::optional<prt::Deform> pose;
  // check_probes.
  std::optional<prt::ProbeTransfer> volume;
  const prt::Mesh* probe_mesh = nullptr;
  prt::ProbeObjectPlacement place;
  // check_lights.
  std::vector<prt::Light> lights;
  bool split_sun = false;
  // set_view.
  prt::Display display;
  bool auto_exposure = false;
  glm::dmat3 R{1.0};
  prt::Camera cam;

  py::array_t<float> run();
  void check_target();
  void check_options();
  void check_probes();
  void check_lights();
  void set_view();
  prt::Image draw(const prt::EnvMap* e, std::vector<float>& coverage);
};

py::array_t<float> RenderCall::run() {
  check_target();
  check_options();
  check_probes();
  check_lights();
  set_view();
  prt::EnvMap loaded;
  const prt::EnvMap* e = &map_argument(map, loaded);
  prt::require_finite(*e);
  prt::Image img;
  std::vector<float> coverage;
  {
    py::gil_scoped_release release;
    img = draw(e, coverage);
  }
  if (!alpha) return copy(img.rgb.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 3});
  std::vector<float> rgba(coverage.size() * 4);
  for (std::size_t i = 0; i < coverage.size(); ++i) {
    std::copy_n(img.rgb.begin() + std::ptrdiff_t(i * 3), 3, rgba.begin() + std::ptrdiff_t(i * 4));
    rgba[i * 4 + 3] = coverage[i];
  }
  return copy(rgba.data(), {py::ssize_t(img.height), py::ssize_t(img.width), 4});
}

// The transfer, of any kind, and the Mesh or Scene it is drawn on, checked
// against each other.
void RenderCall::check_target() {
  is_zh = py::isinstance<PyZhTransfer>(transfer);
  is_wavelet = py::isinstance<PyWavelet>(transfer);
  is_lightmap = py::isinstance<prt::LightmapTransfer>(transfer);
  if (!is_zh && !is_wavelet && !is_lightmap && !py::isinstance<PyTransfer>(transfer))
    throw Error("transfer: expected a Transfer, a WaveletTransfer, a ZhTransfer or a Lightmap (read_transfer, "
                "precompute, compress, read_wavelet, read_zh, fit_zh, read_lightmap, precompute_lightmap)");
  // A lightmap draws its scene; every other transfer its mesh.
  if (is_lightmap ? !py::isinstance<prt::Scene>(mesh_arg) : !py::isinstance<prt::Mesh>(mesh_arg))
    throw Error(is_lightmap ? "mesh: a Lightmap is drawn on its Scene (load_scene), not a " +
                                  std::string(py::str(py::type::of(mesh_arg).attr("__name__")))
                            : "mesh: expected a Mesh (load_mesh, make_mesh), not a " +
                                  std::string(py::str(py::type::of(mesh_arg).attr("__name__"))) +
                                  (py::isinstance<prt::Scene>(mesh_arg) ? " (a Scene goes with its Lightmap)" : ""));
  lm = is_lightmap ? &transfer.cast<const prt::LightmapTransfer&>() : nullptr;
  world = is_lightmap ? &mesh_arg.cast<const prt::Scene&>() : nullptr;
  drawn_mesh = is_lightmap ? &world->mesh : &mesh_arg.cast<const prt::Mesh&>();
  const prt::Mesh& mesh = *drawn_mesh;
  p = is_zh || is_wavelet || is_lightmap ? nullptr : &transfer.cast<const PyTransfer&>();
  z = is_zh ? &transfer.cast<const PyZhTransfer&>() : nullptr;
  wt = is_wavelet ? &transfer.cast<const PyWavelet&>() : nullptr;
  static const std::string lightmap_source = "transfer (the lightmap)";
  source = is_zh ? z->source : is_wavelet ? wt->source : is_lightmap ? lightmap_source : p->source;
  if (is_lightmap) {
    if (lm->layout.scene_hash != world->hash())
      throw Error("transfer: the lightmap was computed for another scene than `mesh` (scene hashes differ)" +
                  (lm->layout.pages > 1 || lm->layout.unwrap_padding >= 0
                       ? "; its atlas (" + prt::lightmap_size_text(lm->layout) + ") is laid out " +
                             (lm->layout.unwrap_padding >= 0 ? "in UVs prt made" : "in UV tiles stacked into one atlas") +
                             ": draw it on lightmap_scene(scene, lightmap), the scene it was laid out in"
                       : std::string()));
  } else if (is_zh)
    prt::check_matches(z->z, mesh, source);
  else if (is_wavelet)
    prt::check_matches(wt->t, mesh, source);
  else
    prt::check_matches(p->t, mesh, source);
}

// The wavelet terms, the bands, the size, the shading, a glossy transfer's
// lobe and a zonal-harmonic transfer's pose.
void RenderCall::check_options() {
  // The wavelet terms: a wavelet transfer's (relit on the CPU each frame, drawn as vertex colours).
  if (!is_wavelet && (terms != 100 || selection != "area"))
    throw Error(std::string(terms != 100 ? "terms" : "selection") + ": applies to a wavelet transfer");
  if (is_wavelet && !bands_arg.is_none()) throw Error("bands: a wavelet transfer has no SH bands to limit");
  check_terms(terms);
  sel = [&] {
    try {
      return prt::wavelet::parse_selection(selection);
    } catch (const Error& e) {
      throw Error(std::string("selection: ") + e.what());
    }
  }();
  // A wavelet transfer's SH lighting is Lambert's (3 bands), as prt render.
  file_bands = is_zh ? z->z.bands : is_wavelet ? 3 : is_lightmap ? lm->transfer.bands : p->t.bands;
  glossy = p != nullptr && p->t.glossy;
  if (file_bands > prt::kMaxRenderBands)
    throw Error(source + ": " + std::to_string(file_bands) + " bands; the renderer draws at most " +
                std::to_string(prt::kMaxRenderBands));
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw Error("width, height: 1 to 16384 pixels each, got " + std::to_string(width) + " x " +
                std::to_string(height));
  fov = prt::python::fov_arg(fov_arg);
  bands = bands_arg.is_none() ? file_bands : int_arg(bands_arg, "bands");
  if (bands < 1 || bands > file_bands)
    throw Error("bands: 1 to the transfer's " + std::to_string(file_bands) + ", got " + std::to_string(bands));
  // The shading: the renderer's default for the file (glossy: the lobe too), or the one named.
  shade = [&] {
    if (shading.is_none()) return glossy ? prt::Shading::Glossy : prt::Shading::Transfer;
    prt::Shading sh;
    try {
      sh = prt::parse_shading(shading.cast<std::string>());
    } catch (const Error& e) {
      throw Error(std::string("shading: ") + e.what());
    }
    if ((is_wavelet || is_zh) && sh != prt::Shading::Transfer && sh != prt::Shading::Lambert)
      throw Error("shading: a " + std::string(is_wavelet ? "wavelet" : "zonal-harmonic") +
                  " transfer shows 'transfer' or 'lambert'");
    if (is_lightmap && sh != prt::Shading::Transfer && sh != prt::Shading::Direct)
      throw Error("shading: a lightmap shows 'transfer' or (interreflected) 'direct'");
    return sh;
  }();
  if (!glossy && (gloss != 16.0 || specular != 0.5 || !diffuse.is_none()))
    throw Error(source + ": gloss, specular and diffuse need a glossy transfer (precompute(material='glossy'))");
  rho_d = diffuse.is_none() ? glm::dvec3(-1.0) : diffuse_arg(diffuse);
  if (!deform.is_none()) {
    if (!is_zh) throw Error(source + ": deform needs a zonal-harmonic transfer (fit_zh; docs/LDPRT.md)");
    pose = prt::parse_deform(deform.cast<std::string>());
    if (!std::isfinite(amount)) throw Error("amount: must be finite (0: the rest pose, 1: the whole angle)");
  }
}

// An object lit by a probe volume, drawn with the mesh or scene (prt render --probes --object).
void RenderCall::check_probes() {
  const prt::Mesh& mesh = *drawn_mesh;
  if (probes.is_none() != object.is_none()) throw Error("probes and object go together (a volume and the Mesh it lights)");
  if (probes.is_none() && (!object_at.is_none() || object_size != 0.0))
    throw Error(std::string(object_at.is_none() ? "object_size" : "object_at") + ": applies to a probe-lit object (probes=, object=)");
  if (!probes.is_none()) {
    if (!py::isinstance<prt::ProbeTransfer>(probes))
      throw Error("probes: expected a ProbeVolume (read_probes, precompute_probes)");
    if (!py::isinstance<prt::Mesh>(object)) throw Error("object: expected a Mesh (load_mesh, make_mesh)");
    volume = probes.cast<const prt::ProbeTransfer&>();
    probe_mesh = &object.cast<const prt::Mesh&>();
    // The volume's scene hash covers the scene's UV sets, which a Mesh lacks: a Mesh read from a
    // file is checked against the scene in that file, as prt render --probes checks MESH (a glTF's
    // scene and mesh readers may differ in a position's last bit, so not the mesh's own hash).
    const auto matches = [&] {
      if (world) return world->hash() == volume->scene_hash;
      if (prt::make_scene(mesh.positions, mesh.triangles, {}, {}, {}, {}, mesh.normals).hash() == volume->scene_hash)
        return true;
      std::error_code ec;
      if (mesh.source.empty() || !std::filesystem::is_regular_file(mesh.source, ec)) return false;
      const prt::Scene from_file = prt::load_scene_or_mesh(mesh.source);
      return from_file.mesh.vertex_count() == mesh.vertex_count() && from_file.hash() == volume->scene_hash;
    };
    if (!matches())
      throw Error("probes: computed for another scene than the one drawn (scene hashes differ; pass the Scene or "
                  "Mesh the volume was computed for)");
    if (!std::isfinite(object_size) || object_size < 0)
      throw Error("object_size: the object's bounding-box diagonal in scene units, > 0 (0: twice the probe spacing)");
    place.size = object_size;
    if (!object_at.is_none()) {
      const DArray at = real_array<double>(object_at, "object_at");
      if (at.ndim() != 1 || at.shape(0) != 3) throw Error("object_at: 3 numbers x, y, z, got shape " + shape_text(at));
      place.at = glm::dvec3(at.at(0), at.at(1), at.at(2));
    }
  }
}

// Lights inside the scene (prt render --lights, --sun; docs/LIGHTS.md "prt
// render and prt view"), checked before any OpenGL is needed. lights= is the
// whole list, as in the other calls that take it: a Scene's own lights are
// not added unless passed (Scene.lights), unlike the command.
void RenderCall::check_lights() {
  lights = lights_arg(lights_in);
  split_sun = sun_arg(sun);
  if (shadow_map_size < 16 || shadow_map_size > prt::kMaxShadowMapSize)
    throw Error("shadow_map_size: 16 to " + std::to_string(prt::kMaxShadowMapSize) +
                " texels a side of a cube face (a sun's map has twice as many), got " +
                std::to_string(shadow_map_size));
}

// The display (tone map, exposure), the lighting's rotation and the camera.
void RenderCall::set_view() {
  const prt::Mesh& mesh = *drawn_mesh;
  try {
    display.tone_map = prt::parse_tone_map(tone_map);
  } catch (const Error& e) {
    throw Error(std::string("tone_map: ") + e.what());
  }
  auto_exposure = py::isinstance<py::str>(exposure) && exposure.cast<std::string>() == "auto";
  if (!auto_exposure) display.exposure = exposure_arg(exposure);
  R = rotate.is_none() ? glm::dmat3(1.0) : to_rotation(rotate, "rotate");
  std::optional<prt::Mesh> framed;
  if (pose && pose->kind != prt::Deform::Kind::None) {  // framed at rest and at its most deformed, as prt render
    framed.emplace();
    framed->positions = mesh.positions;
    const prt::Mesh posed = prt::deform_mesh(mesh, *pose);
    framed->positions.insert(framed->positions.end(), posed.positions.begin(), posed.positions.end());
  }
  // prt render's default camera: scene_camera, from outside or inside a room.
  cam = prt::scene_camera(framed ? *framed : mesh, double(width) / height, fov);
  if (!camera.is_none()) {
    py::object eye, target, up;
    if (py::isinstance<py::dict>(camera)) {
      const py::dict d = camera.cast<py::dict>();
      for (const auto& [k, v] : d) {
        const std::string key = py::str(k);
        if (key == "eye") eye = py::reinterpret_borrow<py::object>(v);
        else if (key == "target") target = py::reinterpret_borrow<py::object>(v);
        else if (key == "up") up = py::reinterpret_borrow<py::object>(v);
        else throw Error("camera: unknown key '" + key + "' (eye, target, up)");
      }
      if (!eye || !target) throw Error("camera: a dict needs 'eye' and 'target' (and 'up', default +Y)");
    } else {
      const DArray c = real_array<double>(camera, "camera");
      if (!(c.ndim() == 2 && (c.shape(0) == 2 || c.shape(0) == 3) && c.shape(1) == 3))
        throw Error("camera: expected (eye, target) or (eye, target, up), 3 numbers each, or a dict; got shape " +
                    shape_text(c));
      cam.eye = {c.at(0, 0), c.at(0, 1), c.at(0, 2)};
      cam.target = {c.at(1, 0), c.at(1, 1), c.at(1, 2)};
      cam.up = c.shape(0) == 3 ? glm::dvec3(c.at(2, 0), c.at(2, 1), c.at(2, 2)) : glm::dvec3(0, 1, 0);
    }
    const auto point = [](const py::object& o, const char* what) {
      const DArray a = real_array<double>(o, what);
      if (a.ndim() != 1 || a.shape(0) != 3) throw Error(std::string(what) + ": 3 numbers, got shape " + shape_text(a));
      return glm::dvec3(a.at(0), a.at(1), a.at(2));
    };
    if (eye) {
      cam.eye = point(eye, "camera eye");
      cam.target = point(target, "camera target");
      cam.up = up ? point(up, "camera up") : glm::dvec3(0, 1, 0);
    }
    cam.fov_deg = fov.value_or(prt::kDefaultFov);
  }
}

// Without the GIL: the lights (the map's sun split off), the lighting (the
// map's SH, band-limited and turned), the frame drawn on the GL thread, then
// finished for display.
prt::Image RenderCall::draw(const prt::EnvMap* e, std::vector<float>& coverage) {
  const prt::Mesh& mesh = *drawn_mesh;
  // sun='auto', as prt render --sun auto (render_lights in
  // tools/prt/light_options.cpp): the sun split off in the map's frame and
  // turned as the sky is (RenderLights::at), last among the lights; the sky
  // is what the transfer, the wavelet playback and the probes are lit by,
  // the map as given stays the background.
  std::vector<prt::Light> frame_lights = lights;
  prt::EnvMap sky;
  const prt::EnvMap* lit = e;
  if (split_sun) {
    sky = *e;
    if (std::optional<prt::Light> s = take_sun(sky, glm::dmat3(1.0))) {
      s->direction = glm::normalize(R * s->direction);
      frame_lights.push_back(std::move(*s));
      lit = &sky;
    }
  }
  // A lightmap's points for the lights: its texels moved out of geometry as
  // prt precompute moved them (the points prt relight lights;
  // renderer_light_points in tools/prt/light_options.cpp).
  std::optional<prt::LightmapTexels> light_points;
  if (is_lightmap && !frame_lights.empty()) {
    light_points = prt::lightmap_texels(*world, lm->layout, lm->transfer.vertex_colors ? nullptr : &lm->transfer.albedo);
    prt::move_texels_out_of_geometry(world->mesh, *light_points);
  }
  std::vector<glm::dvec3> light, rotated;
  light = prt::project(*lit, file_bands);
  std::fill(light.begin() + std::ptrdiff_t(std::size_t(bands) * bands), light.end(), glm::dvec3(0.0));
  rotated.resize(light.size());
  prt::sh::Rotation(file_bands, R).apply(light, rotated);
  prt::Image img = GlWorker::get().run([&](prt::Renderer& r) {
    // No lights of an earlier call: their shadow maps are dropped too (drawn
    // afresh for this frame, as prt render's first frame draws them; a map
    // is otherwise kept while its light stays put, whatever mesh follows).
    r.set_lights({});
    r.set_shadow_map_size(shadow_map_size);
    r.set_environment(*e);
    r.clear_probe_object();
    // The probe-lit object, as prt render's first frame (t = 0 of its path, or at object_at).
    std::optional<prt::ProbeObject> probe_object;
    const auto frame = [&] {
      if (volume) {
        try {
          probe_object.emplace(*volume, *probe_mesh, *lit, r, place);
        } catch (const prt::NoGlContext&) {
          throw;
        } catch (const Error& x) {
          throw Error(std::string("probes: ") + x.what());
        }
        probe_object->frame(r, R, 0.0);
      }
      prt::Image out = r.render(cam, width, height);
      if (alpha || auto_exposure) coverage = r.coverage();
      r.clear_probe_object();
      return out;
    };
    if (is_wavelet) {  // as prt render: the CPU's relighting drawn as vertex colours, or Lambert
      r.set_mesh(mesh, wt->t.albedo, wt->t.vertex_colors);
      r.set_lighting(rotated);
      r.set_environment_rotation(R);
      if (!frame_lights.empty()) r.set_lights(frame_lights);
      if (shade == prt::Shading::Transfer) {
        prt::WaveletPlayback playback(wt->t, *lit);
        playback.frame(r, R, terms, sel);
      } else {
        r.set_shading(prt::Shading::Lambert);
      }
      return frame();
    }
    try {
      if (is_lightmap)
        r.set_scene(*world, *lm);
      else if (is_zh)
        r.set_mesh(mesh, z->z);
      else if (p->compressed)
        r.set_mesh(mesh, *p->compressed);
      else
        r.set_mesh(mesh, p->t);
      r.set_band_limit(bands);
      r.set_shading(shade);
      if (glossy) r.set_glossy(gloss, specular, rho_d);
    } catch (const prt::NoGlContext&) {
      throw;
    } catch (const Error& x) {
      throw Error(source + ": " + x.what());
    }
    if (light_points)  // after the scene's upload, which clears what an earlier one had
      r.set_light_points(light_points->positions, light_points->normals, light_points->albedo);
    if (pose) r.set_pose(*pose, amount);
    r.set_lighting(rotated);
    r.set_environment_rotation(R);
    if (!frame_lights.empty()) r.set_lights(frame_lights);
    return frame();
  });
  // exposure="auto": prt render's rule, from this frame (frame_exposure).
  if (auto_exposure) display.exposure = prt::frame_exposure(img.rgb, coverage);
  prt::finish_frame(img.rgb, display, linear);
  return img;
}

}  // namespace

void stop_renderer() {
  if (!GlWorker::started()) return;
  py::gil_scoped_release release;
  GlWorker::get().stop();
}

// render.
void bind_render(py::module_& m) {
  // ---- rendering (prt/render.h; docs/RUNTIME.md) ----
  m.def(
      "render",
      [](const py::object& transfer, const py::object& mesh_arg, const py::object& map, int width, int height,
         const py::object& camera, const py::object& fov, const py::object& rotate, const py::object& exposure,
         const std::string& tone_map, bool linear, const py::object& shading, const py::object& bands_arg,
         double gloss, double specular, const py::object& diffuse, const py::object& deform, double amount, int terms,
         const std::string& selection, bool alpha, const py::object& probes, const py::object& object,
         const py::object& object_at, double object_size, const py::object& lights, const std::string& sun,
         int shadow_map_size) {
        RenderCall call{transfer, mesh_arg, map, width, height, camera, fov, {}, rotate, exposure, tone_map, linear,
                        shading, bands_arg, gloss, specular, diffuse, deform, amount, terms, selection, alpha, probes,
                        object, object_at, object_size, lights, sun, shadow_map_size};
        return call.run();
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("map"), py::kw_only(), py::arg("width") = 512,
      py::arg("height") = 512, py::arg("camera") = py::none(), py::arg("fov") = py::none(), py::arg("rotate") = py::none(),
      py::arg("exposure") = "auto", py::arg("tone_map") = "clamp", py::arg("linear") = false,
      py::arg("shading") = py::none(), py::arg("bands") = py::none(), py::arg("gloss") = 16.0,
      py::arg("specular") = 0.5, py::arg("diffuse") = py::none(), py::arg("deform") = py::none(),
      py::arg("amount") = 1.0, py::arg("terms") = 100, py::arg("selection") = "area", py::arg("alpha") = false,
      py::arg("probes") = py::none(), py::arg("object") = py::none(), py::arg("object_at") = py::none(),
      py::arg("object_size") = 0.0, py::arg("lights") = py::none(), py::arg("sun") = "none",
      py::arg("shadow_map_size") = prt::kDefaultShadowMapSize,
      "A frame as prt render draws it, headless (OpenGL 4.5 through EGL; one context per process, made on the "
      "first call on a thread of its own and reused): float32 (height, width, 3), row 0 at the top. The map is "
      "the background and the lighting (an EnvMap, a file name or an (H, W, 3) array), turned by rotate (a 3x3 "
      "matrix or yaw, pitch, roll degrees). camera: None (prt render's default camera: a three-quarter view from above that "
      "frames every vertex, or from inside a room that encloses its centre), (eye, target[, up]) or a dict; fov: "
      "vertical degrees (None: 40, or 70 inside a room). exposure: stops or 'auto' (prt "
      "render's rule: the 99th percentile of the model's pixels in this frame, their largest channel, at 1). Values: the tone map's display values in "
      "[0, 1] (tone_map 'clamp', 'reinhard' or 'aces'; sRGB-encode them to show), or with linear=True the linear "
      "radiance times 2^exposure (what prt render writes to EXR). shading: the renderer's ('transfer', 'direct', "
      "'unshadowed', 'lambert', 'ao', 'bent', 'glossy', 'clusters'; default 'glossy' for a glossy transfer, "
      "else 'transfer'); bands: a band limit; gloss, specular, diffuse: a glossy transfer's lobe; deform "
      "('bend:ANGLE' or 'twist:ANGLE') and amount: a zonal-harmonic transfer's pose; terms and selection: a "
      "wavelet transfer's (relit on the CPU each frame, as prt render --terms --selection). A Lightmap draws its "
      "Scene (mesh=the Scene, lightmap_scene(scene, lightmap) for UVs prt made or many pages; shading 'transfer' or "
      "'direct'). probes (a ProbeVolume of the scene drawn) and object "
      "(a Mesh): an object lit by the volume, as prt render --probes --object: object_size its bounding-box diagonal "
      "(0: twice the probe spacing), object_at its centre (None: the start of prt render's path). alpha=True: "
      "(height, width, 4), A = 1 where the model covers the pixel, 0 where the background shows (prt render "
      "--alpha). lights: a list of Light (None: none), each one's direct light drawn beside the map's PRT with shadow "
      "maps, as prt render --lights (docs/LIGHTS.md); only these: a glTF's own lights (Scene.lights) are added by "
      "passing them too. sun: 'none' (the map as it is) or 'auto': the map's sun split off (split_sun), the rest "
      "lighting the transfer and the sun drawn as a directional light turned by rotate, the map as given the "
      "background (prt render --sun auto). shadow_map_size: the lights' shadow maps, 16 to 8192 texels a side of a "
      "cube face (a sun's map has twice as many) [--shadow-map-size]. Raises prt.Error where no OpenGL 4.5 context "
      "can be had.");
}

}  // namespace prt::python
