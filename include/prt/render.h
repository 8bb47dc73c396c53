// prt/render.h - headless OpenGL 4.5 PRT renderer (EGL, no window, no display).
//
// The classic PRT runtime: every stored vertex's transfer vector lives on the
// GPU (a buffer texture, the layout of prt::Transfer: [row][channel][k]),
// and per frame only the (rotated) lighting coefficients are uploaded. A
// compute pass takes the dot product of the two per vertex, or for analytic
// (unoccluded) vertices evaluates the clamped cosine about the vertex normal
// from the lighting (prt/transfer.h); the mesh is drawn with the result
// interpolated (Gouraud), so pixels at vertices equal prt::relight() of
// those vertices. Glossy transfers (prt/transfer.h, "glossy shading") add a
// second compute pass: each vertex's glossy matrix times the lighting, seen
// along the mirror of the direction to the camera's eye (shaders/glossy.comp.glsl,
// docs/RUNTIME.md "Glossy"). The environment is drawn as background,
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
//
// Errors (prt/error.h). prt::Error is for what the data, the user's values
// and the OpenGL implementation decide: no context, a transfer that does not
// belong to the mesh, a mode the transfer file has no data for, a degenerate
// camera, an image larger than the implementation's limit, an OpenGL error.
// Breaking a method's contract (calling it before what it needs was
// uploaded, or with a value outside its stated range) is a bug of the
// caller: PRT_CHECK throws prt::InternalError. Each method says which.
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/lightmap.h>
#include <prt/lights.h>
#include <prt/probes.h>
#include <prt/mesh.h>
#include <prt/scene.h>
#include <prt/skin.h>
#include <prt/transfer.h>
#include <prt/deform.h>
#include <prt/zh_transfer.h>

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

// The most bands the renderer's lighting block holds (16^2 = 256 vec4s).
inline constexpr int kMaxRenderBands = 16;
// Shadow maps of lights (Renderer::set_lights): texels a side of a point or
// spot light's cube faces; a directional light's map, spanning the whole
// scene, has twice as many. 512: within 0.3% relative RMS of traced shadows
// on the bundled room, the sun 0 (docs/LIGHTS.md "On the GPU"), and a frame
// with 4 moving lights and a turning sun 1.7x the static lightmapped frame
// on llvmpipe (1024: 4.7x); 8192: a 1.5 GiB cube of 32-bit distances.
inline constexpr int kDefaultShadowMapSize = 512, kMaxShadowMapSize = 8192;
// The most lights the GPU's lights pass takes at once (Renderer::set_lights):
// their records (128 bytes each) fill a uniform block of 16 KiB, the least
// any OpenGL 4.5 gives (GL_MAX_UNIFORM_BLOCK_SIZE). prt relight evaluates
// any number on the CPU.
inline constexpr int kMaxGpuLights = 128;
// The most bands of a glossy transfer the renderer takes: prt::kMaxGlossyBands
// (prt/precompute.h, which the runtime does not include; tests/test_render_glossy.cpp
// pins the two equal). The glossy pass keeps bands^2 basis values per invocation.
inline constexpr int kMaxRenderGlossyBands = 12;

// What the mesh shows (prt view's M key, prt render --shading).
enum class Shading {
  Transfer,          // the file's transfer: shadowed, or interreflected (direct + bounces)
  Direct,            // interreflected files only: their shadowed (0-bounce) part
  Unshadowed,        // the analytic clamped-cosine transfer of each vertex normal, (albedo/pi) A_l Y_k(n),
                     // at the file's band count (evaluated in the relighting pass, as analytic vertices are)
  Lambert,           // no PRT: plain diffuse, albedo/pi x the irradiance of the lighting's first 9
                     // coefficients at the normal (Ramamoorthi & Hanrahan's quadratic form n^T M n)
  AmbientOcclusion,  // grey: the file's per-vertex ambient occlusion (files that have it)
  BentNormal,        // 0.5 + 0.5 x the file's bent normal as RGB (files that have it)
  VertexColors,      // linear RGB per vertex from set_vertex_colors (CPU relighting, e.g. wavelets)
  Glossy,            // glossy files only: the transfer's diffuse part plus the view-dependent Phong lobe
                     // (prt::relight_glossy toward the camera's eye; set_glossy), both on the GPU
  Clusters,          // compressed transfers only: each stored vertex coloured by a hash of its cluster (the
                     // glossy matrices' clusters when it has them, else the coefficients'), analytic ones grey
};
// "transfer", "direct", "unshadowed", "lambert", "ao", "bent", "colors", "glossy", "clusters"
std::string_view shading_name(Shading s);
Shading parse_shading(std::string_view name);  // throws prt::Error listing the names

// From linear HDR to display values in [0, 1] (then sRGB-encoded by the
// window or by write_image): v = tone(2^exposure x linear), per channel.
//   clamp:    min(v, 1)
//   reinhard: v / (1 + v)
//   aces:     Narkowicz's fit of the ACES filmic curve,
//             v (2.51 v + 0.03) / (v (2.43 v + 0.59) + 0.14), clamped to [0, 1]
// Negative values become 0 in every operator.
enum class ToneMap { Clamp, Reinhard, Aces };
std::string_view tone_map_name(ToneMap t);     // "clamp", "reinhard", "aces"
ToneMap parse_tone_map(std::string_view name);  // throws prt::Error listing the names
// The stops an exposure given by a caller may take (prt render, view,
// relight, export and project's --exposure; prt.render, export_gltf,
// export_web): 2^64 either way is far past what takes any map's radiance to
// a displayable picture; beyond it the gain is a number float cannot hold
// (2^128) or a picture of zeros, never a picture.
inline constexpr double kMaxExposureStops = 64;
// The vertical field of view a caller may give, in degrees (--fov).
inline constexpr double kMinFov = 1, kMaxFov = 179;
// --fov's default with --camera, and the default camera's from outside a room
// (scene_camera).
inline constexpr double kDefaultFov = 40;
struct Display {
  double exposure = 0;  // stops
  ToneMap tone_map = ToneMap::Clamp;
};
// The CPU version of the display pass (the same formula as shaders/display.frag.glsl).
float tone_map(float linear, const Display& display);
void tone_map(std::vector<float>& rgb, const Display& display);
// What a frame's values become when written (prt render's files, prt.render's
// arrays): `linear` keeps linear values scaled by 2^exposure (EXR and other
// float formats); otherwise the tone map's display values in [0, 1] (8-bit
// formats, before sRGB encoding).
void finish_frame(std::vector<float>& rgb, const Display& display, bool linear);
// The stops that show the brightest a white Lambertian surface can be under
// this lighting (sh::peak_diffuse_radiance, 3 bands of `light`,
// rotation-invariant) at 1; 0 for lighting nowhere positive. Not what
// --exposure auto chooses (frame_exposure, below): a map's sun sets it, so an
// interior lit through a window by a small part of that sun came out at
// 23/255.
double auto_exposure(const std::vector<glm::dvec3>& light);

// --exposure auto, "exposure from what the frame shows" (prt render, prt view
// at open, prt.render; the web page's first frame, web/prt-viewer.js, with the
// same two constants; prt relight and export --bake over the relit
// vertices): the stops that put the kAutoExposurePercentile-th percentile of
// the shown pixels' largest channel (linear radiance, before exposure and tone
// map; negative values count as 0) at the display value kAutoExposureTarget.
// The largest channel because a pixel clips when any of its channels does;
// a high percentile rather than the maximum so that a few pixels of a sun or
// a specular highlight do not darken the rest, and rather than a mean (a
// log-average key) so that a bright exterior is not pushed into broad
// clipping: with the clamp tone map at most 1 - percentile of the shown
// pixels (1%) clip, whatever the map, and a dark interior lit through a
// window is shown by its own light, not by the map's sun. The same rule as
// prt project --exposure auto's picture. Shown pixels: those with
// coverage >= 0.5 (Renderer::coverage(): the model, not the background);
// every pixel when `coverage` is empty or covers none. Non-finite values are
// skipped. 0 stops where no shown pixel is positive (an all-black frame);
// the result is clamped to +-kMaxExposureStops. rgb: 3 floats a pixel (or a
// vertex), coverage: one a pixel or empty.
inline constexpr double kAutoExposurePercentile = 0.99;
inline constexpr double kAutoExposureTarget = 1.0;
double frame_exposure(std::span<const float> rgb, std::span<const float> coverage = {});

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

// The camera prt render and prt view use when none is given: a three-quarter
// view from above, the eye in the direction (sin(az) cos(el), sin(el),
// cos(az) cos(el)) from the model (az = 35, el = 20 degrees: from +Z, turned
// toward +X and raised), up = +Y, at the smallest distance at which every
// vertex projects inside the image (aspect = width / height) with a 5%
// margin on each side, the target moved across the view so that the model's
// image is centred. Tighter than the bounding sphere: the model fills the
// frame in its wider direction.
Camera framing_camera(const Mesh& mesh, double fov_deg = 40.0, double aspect = 1.0, double azimuth_deg = 35.0,
                      double elevation_deg = 20.0);

// Whether `mesh` encloses the centre c of its bounding box, as a room does:
// of 256 directions spread evenly over the sphere, at least 70% first meet
// a triangle's front (counter-clockwise) side, and in the scene's shell: at
// least 3/4 of the way from c to the bounding box. A model over a ground
// plane meets the ground so in at most half (objects near c do not count);
// a closed model meets its own back faces. False for a mesh without
// triangles. Rays are traced on the CPU against every triangle (no
// acceleration): skipped, false, unless at least half the mesh's area faces c.
bool encloses_centre(const Mesh& mesh);

// The camera prt render, prt view and prt export --web use when none is
// given (docs/RUNTIME.md, "The default camera"). Outside (encloses_centre
// false): framing_camera(mesh, fov, aspect), fov default 40 degrees. Inside:
// the eye within the mesh, looking at c with a wide view (fov default 70
// degrees): toward the openings (the mean of the directions whose rays from
// c leave the mesh, made horizontal; -Z where none leave), turned and raised
// as framing_camera turns and raises its eye from +Z (35 and 20 degrees);
// at 3/4 of the distance from c to the nearest surface seen from c within
// about 11.5 degrees of the horizontal (and of the surface behind the eye),
// so that orbiting the eye about c keeps it inside. up = +Y.
Camera scene_camera(const Mesh& mesh, double aspect, std::optional<double> fov_deg = std::nullopt);

// A linear RGB float image, row 0 at the top (what write_image takes).
struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // width * height * 3
  glm::vec3 at(int x, int y) const {
    const std::size_t i = (std::size_t(y) * width + x) * 3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

// Thrown when no OpenGL 4.5 core context can be had: EGL missing or refusing,
// or only an older context. Every other failure of the runtime (a shader that
// does not compile or link, a bad input) is a plain prt::Error, so a caller
// (or a test) can tell "no GL here" from "GL here, and something is broken".
class NoGlContext : public Error {
 public:
  using Error::Error;
};

class Renderer {
 public:
  // Creates the headless context. Throws prt::NoGlContext("no OpenGL 4.5
  // context: ... (EGL error 0x...)") when EGL or OpenGL 4.5 core is not
  // available; prt::Error when the context works but its programs do not
  // build.
  Renderer();
  // Uses the OpenGL context current on the calling thread (it must be 4.5
  // core; throws prt::NoGlContext otherwise). It is not destroyed with the Renderer.
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

  // Uploads positions, normals, triangle indices and the transfer: the rows of
  // its stored vertices, and for a transfer with analytic vertices their
  // slots (any band count up to kMaxRenderBands, 1 or 3 channels).
  // Throws prt::Error when the transfer was not computed for this mesh
  // (vertex count, mesh hash) or its arrays are inconsistent, for glossy
  // matrices of more than kMaxRenderGlossyBands bands, and for an array
  // beyond this OpenGL's limits that cannot be split, before uploading it:
  // the message names the limit (GL_MAX_TEXTURE_BUFFER_SIZE, ...), what
  // needed it, the bytes and the limit's value (docs/RUNTIME.md "Limits";
  // per-vertex buffers are bound in runs of vertices, so the vertex count
  // meets no such limit).
  void set_mesh(const Mesh& mesh, const Transfer& transfer);
  // Uploads a compressed transfer (prt/compressed_transfer.h; docs/RUNTIME.md
  // "Compressed transfer"): per stored row only its cluster index and N
  // weights (16-bit weights as 16-bit integers), per vertex a slot when some
  // are analytic, and for a glossy transfer the analytic vertices' hemisphere
  // matrices. set_lighting then computes the per-cluster products on the CPU
  // (cluster_lighting, glossy_cluster_lighting: what prt::relight uses) and
  // uploads them; the passes combine each row's weights with them, so
  // vertex_radiance is relight(c) / relight_glossy(c) up to float rounding.
  // Shadings: Transfer, Glossy (glossy transfers), Unshadowed, Lambert, AO
  // and BentNormal when the transfer has them, and Clusters; not Direct
  // (compression drops the direct part). The errors of the overload above,
  // and prt::Error with compressed_transfer_problem's message.
  void set_mesh(const Mesh& mesh, const CompressedTransfer& transfer);
  // Uploads the mesh alone, with no SH transfer (e.g. for wavelet relighting
  // on the CPU): Shading::VertexColors (after set_vertex_colors) and Lambert
  // (albedo: `albedo`, or the mesh's colours when vertex_colors) are available.
  void set_mesh(const Mesh& mesh, const glm::vec3& albedo, bool vertex_colors = false);
  // Local deformable PRT (prt/zh_transfer.h; docs/RUNTIME.md, "Deforming
  // meshes"): uploads the rest mesh and its lobes (analytic vertices as one
  // lobe along the normal); each frame a compute pass poses every vertex,
  // builds its posed frame, turns its lobes into it and relights them
  // (shaders/zh.comp.glsl), and the mesh is drawn at the posed positions.
  // The pose is the rest pose until set_pose. Shadings: Transfer and
  // Lambert. Throws prt::Error when z was not computed for `rest`
  // (check_matches), or its bands exceed kMaxRenderBands.
  void set_mesh(const Mesh& rest, const ZhTransfer& z);
  // The pose of the next frames: a bend or twist of the rest pose at
  // `amount` of its angle (prt/deform.h's deform_mesh, computed on the GPU
  // each frame), or given per vertex (positions and normals, e.g. a pose
  // read from a file or skinned on the CPU). Contract (prt::InternalError):
  // a zonal-harmonic mesh is uploaded; one position and normal per vertex.
  void set_pose(const Deform& deform, double amount = 1.0);
  void set_pose(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals);
  // A skinned mesh (prt/skin.h): uploads the skin of the zonal-harmonic mesh
  // (each vertex's four joints and weights, once), replacing any earlier one;
  // the pose stays what it was until set_pose of joint matrices. set_mesh
  // drops it. Throws prt::Error when the skin is not of this mesh (another
  // vertex count), has no joints, or a vertex gives a weight other than 0 to a
  // joint the skin does not have (load_skin's skins never do), and when this
  // OpenGL cannot bind the skinned pass's buffers (the message names
  // GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS, below the pass's 10, or
  // GL_MAX_SHADER_STORAGE_BLOCK_SIZE for the joint matrices; skin_mesh on the
  // CPU and set_pose of arrays remain). Contract (prt::InternalError): a
  // zonal-harmonic mesh is uploaded.
  void set_skin(const Skin& skin);
  // The pose of the next frames, skinned on the GPU each frame from the rest
  // pose (only these matrices are uploaded): one matrix per joint of the
  // skin, joint_matrices(skin, time, animation)'s, blended per vertex as
  // skin_mesh blends them (the position M p, the normal by M's cofactor), so
  // posed_positions and vertex_radiance are skin_mesh's pose up to float
  // rounding. Until another set_pose. Contract (prt::InternalError): a skin
  // is uploaded and one matrix is given per joint.
  void set_pose(std::span<const glm::mat4> joint_matrices);
  // The posed positions of the last frame drawn (or relit by vertex_radiance).
  std::vector<glm::vec3> posed_positions() const;
  // Uploads a scene and its SH lightmap (prt/lightmap.h; docs/RUNTIME.md
  // "Lightmaps"), replacing any mesh: each frame the covered texels are
  // relit on the GPU (their rows dotted with the lighting of set_lighting,
  // analytic texels' rows evaluated here once) into a lightmap image with
  // dilated gutters, and the scene is drawn sampling it bilinearly at its
  // lightmap UVs; with set_lightmap_detail (the default) each fragment takes
  // its material's albedo (base colour factor x texture at TEXCOORD_0) in
  // place of its texel's (a lightmap computed with one albedo for all,
  // --albedo, keeps it: detail changes nothing there). Shadings: Transfer, and Direct for an
  // interreflected lightmap. Throws prt::Error when the lightmap was not
  // computed for `scene` (check_matches) or its rows exceed this OpenGL's
  // storage block size.
  void set_scene(const Scene& scene, const LightmapTransfer& lightmap);
  void set_lightmap_detail(bool on);
  // true (the default): every frame relights the lightmap. false: a frame
  // relights it only when something changed: the lighting, band limit or
  // shading (the sky's part), the lights (their direct light and bounce
  // added again to the sky's radiance as it was), or a bounce still
  // catching up (set_light_bounce_budget); a frame where nothing changed
  // only draws (a static lightmap, what an engine without PRT draws: the
  // baseline of the lightmapped frame's cost, bench/lightmap_figures.cpp).
  void set_lightmap_relight(bool on);
  // The lights' bounce (a transfer with a light-bounce operator,
  // docs/LIGHTS.md "Bounce"): its direct light is evaluated when the lights
  // change and its B bounces brought up to date by at most `work` units a
  // frame (an entry of the operator's rows or a patch's member; 0, the
  // default: all of them in the frame). With a budget the bounce catches up
  // with a moving light over a few frames, bounce 1 swept whole before bounce
  // 2, ..., as Enlighten converges over frames; light_bounce_done() says when
  // the frame drawn has the B bounces of the lights as they are.
  void set_light_bounce_budget(std::uint64_t work);
  bool light_bounce_done() const;
  bool has_light_bounce() const;  // the drawn transfer has a light-bounce operator
  // The covered texels' radiance of the last frame drawn (set_scene only),
  // in texel order: relight_lightmap's up to float rounding.
  std::vector<glm::vec3> lightmap_radiance() const;
  // Lights inside the scene (prt/lights.h; docs/LIGHTS.md "On the GPU"):
  // every frame, each light's direct light albedo / pi x E_l max(n.l, 0) V is
  // added at the shaded points, as prt relight adds it: the mesh's vertices
  // (the Transfer, Direct and Glossy shadings of an SH or compressed
  // transfer, Glossy with each light's Phong lobe toward the eye; the posed
  // vertices of a zonal-harmonic mesh, whose maps are then redrawn every
  // frame; VertexColors, e.g. a wavelet transfer's), a lightmap's texels at
  // the points of set_light_points. V comes from shadow maps: a
  // cube per point or spot light, a square fitted to the mesh's bounding
  // sphere per directional light, each redrawn only when its light moves.
  // An empty span removes them. Throws prt::Error for a light check_light
  // refuses or more than kMaxGpuLights.
  void set_lights(std::span<const Light> lights);
  // A lightmap's points for the lights, in texel order: the texels' sample
  // points moved out of geometry as prt precompute moved them
  // (prt::move_texels_out_of_geometry: ray tracing, the caller's), their
  // normals and albedo. Needed before a lightmap's frame with lights.
  void set_light_points(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                        std::span<const glm::vec3> albedo);
  // Shadow maps' size, texels a side: 16 to kMaxShadowMapSize
  // (kDefaultShadowMapSize until set).
  void set_shadow_map_size(int size);
  // Shadow maps the last frame redrew (a cube counts once): what moved.
  int shadow_maps_drawn() const;
  // An object lit by a probe volume (prt/probes.h; docs/PROBES.md
  // "Rendering"), drawn after the scene or mesh: each frame, per vertex on
  // the GPU, E/pi from the relit probes interpolated at its world position
  // (the model matrix of set_probe_object_model) with trilinear weights
  // times the probes' depth-moment visibility (prt::probe_weights without a
  // tracer), times `albedo`. Takes 3-band volumes; set_probe_lighting gives
  // the relit probes (ProbeRelighter::relight: 9 per probe) and must be
  // called before a frame. Throws prt::Error on another band count or
  // buffers past this OpenGL's limits.
  void set_probe_object(const Mesh& object, const ProbeTransfer& probes, const glm::vec3& albedo);
  void set_probe_lighting(std::span<const glm::vec3> probe_sh);
  void set_probe_object_model(const glm::mat4& model);
  // The object's vertices' radiance of the last frame drawn.
  std::vector<glm::vec3> probe_object_radiance() const;
  // With lights and a transfer whose light-bounce operator has probe rows
  // for the probe volume's grid (prt precompute --lightmap WxH --light-bounce
  // --probes NXxNYxNZ; LightBounce::ProbeRows), the object's probes add the
  // lights' light leaving the scene's surfaces (their direct light and its
  // bounces as the frame has them) to the relit SH: true when they do.
  bool probe_object_lights_bounce() const;
  // Those probes' SH of the lights' light, 9 a probe (read back; empty when
  // probe_object_lights_bounce() is false).
  std::vector<glm::vec3> probe_lights_sh() const;
  void clear_probe_object();
  void clear_mesh();
  int bands() const;  // of the uploaded SH transfer; 0 without one
  // Bytes of transfer data on the GPU: the stored rows of the transfer and
  // its direct part (each channel padded to a multiple of 4 coefficients),
  // and 4 bytes of slot per vertex when some vertices are analytic. When
  // those slots would cost more than the analytic rows they spare, set_mesh
  // evaluates the analytic rows on the CPU and uploads every vertex's row,
  // without slots. Glossy transfers add their matrices, one row per vertex
  // (analytic vertices' hemisphere matrices evaluated by set_mesh; see
  // docs/RUNTIME.md, "Glossy"): glossy_stride() floats padded to a multiple
  // of 4 (per channel when interreflected). Compressed transfers: their
  // rows' words (4 bytes of cluster index, then the weights: 2 or 4 bytes
  // each, padded to 4 bytes a row), the slots, the analytic vertices' glossy
  // rows and the per-cluster product buffers (16 bytes per product).
  // Normals, positions and colours are not counted (every shading mode has them).
  std::size_t transfer_bytes() const;

  // The lighting of the next frames: RGB coefficients, at least bands()^2
  // (at least 1 without an SH transfer; extra ones are ignored). Only these
  // bands()^2 vec4s go to the GPU (and for Lambert, three 4x4 matrices from
  // the first 9). Contract (prt::InternalError): a mesh is uploaded and
  // enough coefficients are given (project() the map at bands() bands).
  void set_lighting(std::span<const glm::dvec3> coeffs);

  // Shades with the first bands^2 coefficients only (1 <= bands <= bands();
  // truncation, live: no re-upload). Reset to bands() by set_mesh.
  // Contract (prt::InternalError): an SH transfer is uploaded and bands is in
  // that range; check a user's band count against bands() first.
  void set_band_limit(int bands);
  int band_limit() const;

  // What the mesh shows (default Transfer, Glossy for a glossy transfer;
  // set_mesh resets it). has_shading says whether the uploaded mesh and
  // transfer support a mode: Glossy needs glossy matrices, Direct needs
  // an interreflected transfer (never a compressed one), AmbientOcclusion
  // and BentNormal a file that has them, VertexColors a set_vertex_colors
  // call, Clusters a compressed transfer. set_shading throws
  // prt::Error for a mode the transfer file has no data for (Direct of a
  // transfer that is not interreflected, AmbientOcclusion or BentNormal of a
  // file without them: "shading 'ao' is unavailable: ..."). Contract
  // (prt::InternalError): a mesh is uploaded; an SH transfer for every mode
  // but Lambert and VertexColors; colours for VertexColors.
  bool has_shading(Shading s) const;
  void set_shading(Shading s);
  Shading shading() const;
  // Per-vertex linear RGB for Shading::VertexColors (one per mesh vertex);
  // uploaded at once (the whole array crosses the bus: meant for per-frame
  // CPU relighting). Contract (prt::InternalError): a mesh is uploaded and
  // colors has one entry per vertex.
  void set_vertex_colors(std::span<const glm::vec3> colors);

  // The Phong lobe of Shading::Glossy, live (no re-upload; set_mesh resets
  // it to GlossyShading's defaults: e 16, rho_s 0.5, the transfer's own
  // albedo): exponent e (gloss), strength rho_s (specular) and diffuse albedo
  // rho_d per channel (negative: the transfer's own), as prt::GlossyShading.
  // The eye point is the camera's (Camera::eye) at each frame. Throws
  // prt::Error with glossy_shading_problem's message for values it refuses
  // (e outside [0, 4096], rho_s outside [0, 1], a rho_d the transfer cannot
  // take). Contract (prt::InternalError): a glossy transfer is uploaded.
  void set_glossy(double gloss, double specular, const glm::dvec3& diffuse = glm::dvec3(-1.0));

  // Runs the relighting pass of the current shading (Transfer, Direct,
  // Unshadowed or Glossy) for eye point `eye` and reads back the per-vertex
  // radiance the mesh is drawn with: linear RGB, one per vertex, what
  // prt::relight (relight_glossy at that eye) computes, plus the lights'
  // direct light (set_lights). For tests and tools.
  // Contract (prt::InternalError): a transfer and lighting are uploaded and
  // the shading is one of those four. In Shading::Clusters: the cluster
  // colours the mesh is drawn with (no lighting needed); in
  // Shading::VertexColors: the colours of set_vertex_colors plus the
  // lights' direct light (a mesh and colours uploaded).
  std::vector<glm::vec3> vertex_radiance(const glm::dvec3& eye);

  // Background: a lat-long or cube map (uploaded once as a float texture),
  // drawn behind the mesh with the rotation of set_environment_rotation.
  // Without one the background is black. Contract (prt::InternalError): the
  // map is consistent (its size matches its pixels, as load_envmap's are).
  void set_environment(const EnvMap& map);
  void clear_environment();
  void set_environment_rotation(const glm::dmat3& R);

  // Renders a frame. Throws prt::Error for a size larger than the OpenGL
  // implementation's renderbuffer limit, and for a degenerate camera (field
  // of view outside (0, 180), eye equal to target, up parallel to the view
  // direction, non-finite values). Contract (prt::InternalError): width and
  // height are positive, and the mesh's shading has what it needs (lighting
  // for Transfer, Direct, Unshadowed and Lambert, colours for VertexColors).
  // Linear HDR values, or with `display` the display values of the same
  // frame (exposure and tone map applied on the GPU, in [0, 1], before sRGB
  // encoding).
  Image render(const Camera& camera, int width, int height, const Display* display = nullptr);
  // The coverage of the last frame drawn (render, draw_only or present), read
  // from its depth buffer: 1 where the mesh, scene or probe-lit object covers
  // the pixel's centre, 0 where the background (or black) shows; width x
  // height values, row 0 at the top (the alpha of prt render --alpha and
  // prt.render(alpha=True)). Contract (prt::InternalError): a frame was drawn.
  std::vector<float> coverage() const;
  // Draws the frame and waits for the GPU, without reading it back (timing).
  // The errors and contract of render().
  void draw_only(const Camera& camera, int width, int height);

  // Draws the frame render() would draw (width x height) and runs the
  // display pass (exposure, tone map) into the current context's default
  // framebuffer, scaled to window_width x window_height. The caller swaps
  // buffers. The window receives sRGB-encoded values either way: by the
  // framebuffer when it is sRGB-capable (returns true), else by the display
  // shader (returns false). The errors and contract of render().
  bool present(const Camera& camera, int width, int height, int window_width, int window_height,
               const Display& display = {});
  // What present() left in the default framebuffer's back buffer (before the
  // swap): width x height 8-bit sRGB codes, row 0 at the top, as the window
  // shows them.
  std::vector<unsigned char> read_presented(int width, int height);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace prt
