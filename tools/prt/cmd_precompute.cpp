// prt precompute: mesh -> per-vertex SH or wavelet transfer file.
#include "commands.h"
#include "progress_bar.h"
#include "lightmap_inputs.h"
#include "subsurface_options.h"

#include <prt/lightmap.h>
#include <prt/envmap.h>
#include <prt/ply.h>
#include <prt/gpu_tracer.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/subsurface_scatter.h>
#include <prt/mpi.h>
#include <prt/io.h>
#include <prt/mesh.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>
#include <prt/tuning.h>
#include <prt/unwrap.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh.h>
#include <prt/zh_transfer.h>
#include <prt/dynamic_ao.h>

#include <fmt/core.h>

#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>
#include <sys/resource.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <unistd.h>
#include <vector>

namespace prt::cli {

namespace {

// --subdivide-max-vertices: a mesh's vertex indices are 32-bit (make_mesh refuses more vertices).
constexpr std::uint64_t kMaxSubdivideVertices = std::numeric_limits<std::uint32_t>::max();

struct PrecomputeArgs {
  std::string mesh, output, mode = "shadowed", albedo = "0.8,0.8,0.8", basis = "sh", material = "diffuse";
  TransferOptions opt;
  WaveletOptions wopt;
  MeshOptions mesh_opt;
  bool quiet = false;
  std::string memory_limit;  // --memory-limit SIZE (memory_size_value); "" the default
  const CLI::Option* memory_limit_opt = nullptr;
  // --lightmap WxH: SCENE's texels (docs/LIGHTMAPS.md); --uv N: its UV set (-1: TEXCOORD_1 when present, else 0).
  std::string lightmap;
  int uv = -1;
  // --lightmap-uv auto: lightmap UVs made by prt (prt/unwrap.h) at --uv-padding; "scene": the scene's own.
  std::string lightmap_uv = "scene";
  int uv_padding = 2;
  const CLI::Option *lightmap_uv_opt = nullptr, *uv_padding_opt = nullptr;
  // --pages N|auto: a lightmap of many pages (UV tiles); --texel-size: the density --pages auto fills them at.
  std::string pages = "1";
  double texel_size = 0;
  const CLI::Option *pages_opt = nullptr, *texel_opt = nullptr;
  // --probes NXxNYxNZ: a probe volume over SCENE (docs/PROBES.md).
  std::string probes;
  ProbeOptions popt;
  const CLI::Option *probes_opt = nullptr, *probe_cube_opt = nullptr, *bounce_bands_opt = nullptr;
  // Extra maps of a lightmap (RGBA EXR in its layout): ambient occlusion, bent normals, obscurance.
  std::string ao_map, bent_map, obscurance_map;
  double obscurance = 0;
  const CLI::Option *lightmap_opt = nullptr, *uv_opt = nullptr, *albedo_opt = nullptr, *vertex_colors_opt = nullptr,
                    *weld_opt = nullptr, *directional_opt = nullptr;
  // --compress KxN: write the transfer compressed by clustered PCA (prt compress).
  std::string compress;
  int compress_weights = 16;
  const CLI::Option* compress_weights_opt = nullptr;
  // Options given on the command line (to refuse those the basis does not take).
  std::vector<const CLI::Option*> sh_only, wavelet_only;
  // --basis zh: lobes per vertex (docs/LDPRT.md).
  int lobes = 4;
  bool dynamic_ao = false;  // also store the rest pose's dynamic ambient occlusion (prt relight --dynamic-ao)
  std::string tangent = "uv";  // the tangent of each vertex frame: uv (where the mesh has UVs) or edge
  const CLI::Option *lobes_opt = nullptr, *dynamic_ao_opt = nullptr, *tangent_opt = nullptr;
  // --target-error: the error target, its map and reference cache; bands,
  // samples and bounces given on the command line are the most it may choose.
  double target_error = 0;
  std::string env, cache;
  const CLI::Option *light_bounce_opt = nullptr, *bounce_patch_opt = nullptr, *bounce_ratio_opt = nullptr,
                    *bounce_clusters_opt = nullptr;
  const CLI::Option *bands_opt = nullptr, *samples_opt = nullptr, *bounces_opt = nullptr, *mode_opt = nullptr,
                    *target_opt = nullptr, *env_opt = nullptr, *cache_opt = nullptr, *tolerance_opt = nullptr,
                    *material_opt = nullptr;
  // --adaptive [TOL]: adaptive sample points (docs/PRECOMPUTE.md); "" not given, "default" without a value.
  std::string adaptive;
  AdaptiveOptions aopt;
  bool adaptive_any = false;  // --adaptive-any: a TOL above max_adaptive_tolerance
  const CLI::Option *adaptive_opt = nullptr, *verify_opt = nullptr, *adaptive_any_opt = nullptr;
  // --subdivide TOL: refine a coarse mesh where its transfer changes (docs/PRECOMPUTE.md, "Subdividing coarse
  // meshes"); --subdivided-mesh: where the refined mesh goes ("" the output's name with .ply).
  SubdivideOptions sopt;
  std::string subdivide;  // --subdivide [TOL]: "" not given or no value (TOL = --target-error / 2)
  std::string subdivided_mesh;
  const CLI::Option *subdivide_opt = nullptr, *subdivide_max_opt = nullptr, *subdivided_mesh_opt = nullptr;
  SubsurfaceArgs sss;  // --material subsurface's material and length scale
  // --device cpu|gpu: Embree on the CPU's threads, or the rays in OpenGL compute shaders
  // (docs/PRECOMPUTE.md "On the GPU").
  std::string device = "cpu";
  const CLI::Option* device_opt = nullptr;
};

// --device gpu: the mesh's flat BVH and the GL tracer, made before the work
// and set as the options' tracer (SH and wavelet); nothing for --device cpu.
std::unique_ptr<PointTracer> make_device(PrecomputeArgs& a, const Mesh& mesh, bool quiet) {
  if (a.device != "gpu") return nullptr;
  const auto t0 = std::chrono::steady_clock::now();
  const FlatBvh bvh = build_flat_bvh(mesh);
  const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::unique_ptr<PointTracer> tracer = make_gl_point_tracer(bvh);
  if (!quiet)
    fmt::print(stderr, "device: {}; BVH of {} triangles: {} nodes, depth {}, built in {:.2f} s\n", tracer->name(),
               bvh.triangle_ids.size(), bvh.nodes.size(), bvh.depth, build_s);
  a.opt.tracer = tracer.get();
  a.wopt.tracer = tracer.get();
  return tracer;
}

// The kind of transfer a run makes (the kind table's --device gpu column).
TransferKind made_kind(const PrecomputeArgs& a) {
  const bool wavelet = a.basis == "wavelet";
  if (a.probes_opt->count() > 0 && !a.opt.light_bounce) return TransferKind::Probes;
  if (a.lightmap_opt->count() > 0) return wavelet ? TransferKind::WaveletLightmap : TransferKind::Lightmap;
  if (wavelet) return TransferKind::Wavelet;
  if (a.basis == "zh") return TransferKind::ZH;
  return a.compress.empty() ? TransferKind::SH : TransferKind::Compressed;
}

// --device gpu, checked before any work: the kinds the GPU does not make
// are refused with the kind table's sentence (prt/transfer_file.h,
// Consumer::GpuPrecompute), what else it does not trace by name
// (docs/PRECOMPUTE.md "On the GPU").
void check_device(const PrecomputeArgs& a) {
  if (a.device != "gpu") return;
  const auto no = [](const std::string& what) {
    throw UsageError("--device gpu: " + what + " (precompute it with --device cpu, the default)");
  };
  if (const Support& s = support(made_kind(a), Consumer::GpuPrecompute); !s.works)
    throw UsageError(std::string(s.why));
  if (a.material == "subsurface")
    no("--material subsurface: the light entering the surface is gathered from sample points the CPU traces");
  if (a.subdivide_opt->count() > 0)
    no("--subdivide traces each round's refined mesh, whose triangles are not the GPU's BVH (the input's)");
  if (mpi::launched() && mpi::world().size() > 1) no("under mpirun (one process drives the GPU)");
}

// The rays' rate of a --device run: about `points` x samples rays (half the
// 2 x samples directions lie above a point's horizon; a wavelet transfer's
// half of the cube's 6 r^2 texels), or `points` x `per_point` where given
// (a probe's base rays).
void print_rays(const PrecomputeArgs& a, std::size_t points, double seconds, double per_point = 0) {
  const bool wavelet = a.basis == "wavelet";
  if (a.quiet || a.device_opt->count() == 0) return;
  if (per_point == 0 && !wavelet && a.opt.mode == TransferMode::Unshadowed) return;
  if (per_point == 0) per_point = wavelet ? 3.0 * a.wopt.cube_res * a.wopt.cube_res : double(a.opt.samples);
  const double rays = double(points) * per_point;
  fmt::print(stderr, "rays ({}): about {:.3g} in {:.2f} s, {:.3g} rays/s (the whole precompute's time)\n", a.device,
             rays, seconds, rays / std::max(seconds, 1e-9));
}

// --compress KxN into o; "" or what is wrong with `text`.
std::string compress_problem(const std::string& text, CompressOptions& o) {
  const std::size_t x = text.find('x');
  const auto digits = [](const std::string& s) {
    return !s.empty() && s.size() <= 9 && s.find_first_not_of("0123456789") == std::string::npos;
  };
  if (x == std::string::npos || !digits(text.substr(0, x)) || !digits(text.substr(x + 1)))
    return "expected KxN, clusters x principal vectors (e.g. 128x8), got " + show_text(text);
  o.clusters = std::stoi(text.substr(0, x));
  o.vectors = std::stoi(text.substr(x + 1));
  if (o.clusters < 1 || o.clusters > kMaxClusters || o.vectors > kMaxVectors)
    return fmt::format("K must be 1 to {} and N 0 to {}, got {}", kMaxClusters, kMaxVectors, show_text(text));
  return {};
}

// --compress's validator (checked while parsing: '' was taken as not given).
CLI::Validator compress_value() {
  return CLI::Validator(
      [](std::string& text) {
        CompressOptions o;
        return compress_problem(text, o);
      },
      "KxN");
}

// --compress KxN into o (checked while parsing).
void parse_compress(const std::string& text, CompressOptions& o) {
  if (const std::string problem = compress_problem(text, o); !problem.empty())
    throw UsageError("--compress: " + problem);
}

// Returns the heap's free pages to the system (glibc keeps what loading the
// mesh freed: 2 GB of a 10M-vertex PLY), so that the memory limit's plan,
// which starts from the resident memory, counts only what is in use.
void release_free_memory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

// This process's place in an mpirun job (prt/mpi.h): rank 0 of 1 alone.
const Communicator& job() { return mpi::launched() ? mpi::world() : single_process(); }
bool is_root() { return job().rank() == 0; }

// Test hook (tests/mpi): with PRT_TEST_FAIL_RANK=R in the environment, rank R
// fails once its mesh is read, as a rank with a bad disk or too little
// memory would, while the others go on to their first exchange.
void test_fail_rank() {
  const char* r = std::getenv("PRT_TEST_FAIL_RANK");
  if (r && *r && std::atoi(r) == job().rank())
    throw Error(fmt::format("rank {} of {} fails (PRT_TEST_FAIL_RANK)", job().rank(), job().size()));
}

// The progress of an mpirun job: rank 0's share, which the others keep pace
// with (equal ranges), its phase named so.
Progress job_progress(const Progress& p) {
  if (job().size() == 1) return p;
  return [p, label = std::make_shared<std::string>(), n = job().size()](std::size_t done, std::size_t total,
                                                                        const char* phase) {
    *label = fmt::format("{} (rank 0's share of {})", phase, n);
    return p(done, total, label->c_str());
  };
}

// --memory-limit: bytes; the default shares 80% of the machine among the
// job's processes on it.
std::size_t memory_limit(const PrecomputeArgs& a) {
  return a.memory_limit.empty() ? default_memory_limit(mpi::launched() ? mpi::local_size() : 1)
                                : parse_memory_size(a.memory_limit);
}

// --light-bounce and --bounce-patch (docs/LIGHTS.md "Bounce"): the
// interreflected pass's gather of every point, kept in one process.
void check_light_bounce(const PrecomputeArgs& a) {
  for (const CLI::Option* o : {a.bounce_patch_opt, a.bounce_ratio_opt, a.bounce_clusters_opt})
    if (o->count() > 0 && !a.opt.light_bounce)
      throw UsageError(o->get_name() + " shapes the --light-bounce operator's patches; give --light-bounce too");
  if (!a.opt.light_bounce) return;
  if (a.mode != "interreflected" || a.opt.bounces < 1)
    throw UsageError("--light-bounce keeps the interreflected pass's gather: give --mode interreflected (and --bounces "
                     "1 or more)");
  if (a.material == "glossy")
    throw UsageError("--light-bounce: the lights bounce off diffuse surfaces; a glossy transfer keeps no operator");
  if (a.basis == "zh")
    throw UsageError("--light-bounce does not go with --basis zh: a deforming mesh's gather changes with its pose");
  const std::pair<const CLI::Option*, const char*> refused[] = {
      {a.adaptive_opt, "--adaptive (interpolated points have no gather row to keep)"},
      {a.target_opt, "--target-error (it chooses the bounces by the sky's error; give --bounces)"},
  };
  for (const auto& [o, why] : refused)
    if (o->count() > 0) throw UsageError(std::string("--light-bounce does not go with ") + why);
  if (!a.compress.empty())
    throw UsageError("--light-bounce does not go with --compress: a compressed transfer keeps no operator (yet)");
  if (job().size() > 1)
    throw UsageError("--light-bounce runs in one process: its operator is made of every point's gather row at once "
                     "(run it without mpirun)");
}

// The rules across options (each value alone is checked while parsing):
// UsageError, before anything is read.
void check_usage(const PrecomputeArgs& a) {
  const bool target = a.target_opt->count() > 0;
  for (const CLI::Option* o : {a.env_opt, a.cache_opt})
    if (o->count() > 0 && !target)
      throw UsageError(o->get_name() + " is for --target-error (the map and reference cache it measures the error "
                       "with); give --target-error too, or leave " + o->get_name() + " out");
  if (target && a.env.empty())
    throw UsageError("--target-error needs --env MAP: the error depends on the lighting");
  if (target && job().size() > 1)
    throw UsageError("--target-error runs in one process (it precomputes several settings and compares them with a "
                     "reference): run it without mpirun");
  if (a.basis == "wavelet") {
    if (a.mode != "shadowed")
      throw UsageError("--mode " + a.mode + " is not available with --basis wavelet: wavelet transfers are shadowed "
                       "only (use --basis sh for unshadowed or interreflected transfers)");
    for (const CLI::Option* o : a.sh_only)
      if (o->count() > 0)
        throw UsageError(o->get_name() + " does not apply to --basis wavelet (a wavelet transfer is shadowed, one "
                         "ray per cube texel above the horizon; its size is set by --cube-res and --threshold)");
  } else {
    for (const CLI::Option* o : a.wavelet_only)
      if (o->count() > 0) throw UsageError(o->get_name() + " applies to --basis wavelet only");
    if (target && a.tolerance_opt->count() > 0)
      throw UsageError("--bounce-tolerance and --target-error both choose the bounces; give one");
    if (a.material == "glossy" && a.mode == "unshadowed")
      throw UsageError("--material glossy needs --mode shadowed or interreflected (an unshadowed vertex's glossy "
                       "matrix is the hemisphere's, which prt computes at run time)");
    if (a.material == "glossy" && a.opt.bands > kMaxGlossyBands)
      throw UsageError(fmt::format("--material glossy takes --bands at most {} (each matrix has bands^4 entries: {} "
                                   "bands would be {} KB per vertex)",
                                   kMaxGlossyBands, a.opt.bands,
                                   a.opt.bands * a.opt.bands * (a.opt.bands * a.opt.bands + 1) * 2 / 1000));
    if (a.material == "glossy" && target)
      throw UsageError("--target-error chooses diffuse transfer settings only; give --bands and --samples for "
                       "--material glossy");
    if (target && a.mode == "unshadowed")
      throw UsageError("--target-error: the unshadowed transfer has no sampling to choose (use --mode shadowed or "
                       "interreflected)");
  }
  check_not_input("--output", a.output, {{"MESH", a.mesh}, {"--env", a.env}});
}

// The value of `option` (--adaptive, --subdivide) as a tolerance in (0, 1);
// `expected` ends the message for text that is no number.
double parse_tolerance(const std::string& option, const std::string& text, const std::string& expected) {
  double tol = 0;
  try {
    std::size_t used = 0;
    tol = std::stod(text, &used);
    if (used != text.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw UsageError(option + " " + text + ": expected a tolerance, " + expected);
  }
  if (!(tol > 0 && tol < 1)) throw UsageError(fmt::format("{} {}: the tolerance must be in (0, 1)", option, text));
  return tol;
}

// --adaptive [TOL] into a.aopt.tolerance (0: the default for the samples,
// or with --target-error, target / 2); refuses a TOL past
// max_adaptive_tolerance without --adaptive-any.
void parse_adaptive(PrecomputeArgs& a) {
  if (a.adaptive_opt->count() == 0) {
    for (const CLI::Option* o : {a.verify_opt, a.adaptive_any_opt})
      if (o->count() > 0) throw UsageError(o->get_name() + " is for --adaptive; give --adaptive too");
    return;
  }
  if (a.probes_opt->count() > 0)
    throw UsageError("--adaptive chooses among a mesh's vertices or a lightmap's texels: not for --probes (a probe "
                     "volume's probes are traced every one)");
  if (a.basis == "wavelet")
    throw UsageError("--adaptive applies to --basis sh and zh (SH transfer); a wavelet transfer traces every vertex");
  if (a.adaptive == "default" || a.adaptive.empty()) {
    a.aopt.tolerance = 0;
    return;
  }
  const double tol = parse_tolerance("--adaptive", a.adaptive, "a number in (0, 1) (e.g. 0.01), or no value");
  const double most = max_adaptive_tolerance(a.opt.samples);
  if (tol > most && !a.adaptive_any)
    throw UsageError(fmt::format("--adaptive {}: above {:.3g}, the largest tolerance for {} samples whose error stays "
                                 "within 1.1x the full run's (docs/PRECOMPUTE.md, \"Adaptive sample points\"); give "
                                 "--adaptive-any to use it anyway",
                                 a.adaptive, most, a.opt.samples));
  a.aopt.tolerance = tol;
}

// --subdivide's rules (UsageError, before anything is read); the refined
// mesh's path into a.subdivided_mesh (default: the output's name with .ply).
void check_subdivide(PrecomputeArgs& a) {
  if (a.subdivide_opt->count() == 0) {
    for (const CLI::Option* o : {a.subdivide_max_opt, a.subdivided_mesh_opt})
      if (o->count() > 0) throw UsageError(o->get_name() + " is for --subdivide TOL; give --subdivide too");
    return;
  }
  if (a.subdivide.empty() || a.subdivide == "default") {
    // --target-error picks TOL as for --adaptive: half the target, the rest of it left to the bands and rays.
    if (a.target_opt->count() == 0)
      throw UsageError("--subdivide needs a TOL (e.g. --subdivide 0.02), or --target-error E to pick TOL = E / 2");
    a.sopt.tolerance = a.target_error / 2;
  } else {
    a.sopt.tolerance = parse_tolerance("--subdivide", a.subdivide, "a number in (0, 1) (e.g. 0.02)");
  }
  const auto refuse = [](const std::string& what) {
    throw UsageError("--subdivide refines a mesh's vertices for its per-vertex SH transfer: not with " + what);
  };
  if (a.adaptive_opt->count() > 0) refuse("--adaptive (which traces fewer of the vertices; give one of the two)");
  if (a.lightmap_opt->count() > 0) refuse("--lightmap (a lightmap's texels do not follow the vertices)");
  if (a.probes_opt->count() > 0) refuse("--probes");
  if (a.basis != "sh") refuse("--basis " + a.basis);
  if (a.subdivided_mesh.empty()) {
    a.subdivided_mesh = std::filesystem::path(a.output).replace_extension(".ply").string();
    if (same_file(a.subdivided_mesh, a.mesh) || same_file(a.subdivided_mesh, a.output))
      throw UsageError(fmt::format("--subdivide: the refined mesh would go to {} (the output's name with .ply), which is "
                                   "{}; give --subdivided-mesh FILE",
                                   a.subdivided_mesh, same_file(a.subdivided_mesh, a.mesh) ? "MESH" : "--output"));
  } else {
    std::string ext = std::filesystem::path(a.subdivided_mesh).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (ext != ".ply")
      throw UsageError("--subdivided-mesh " + a.subdivided_mesh + ": the refined mesh is written as PLY (.ply)");
    check_not_input("--subdivided-mesh", a.subdivided_mesh, {{"MESH", a.mesh}, {"--env", a.env}});
  }
}

// What --subdivide did, on stderr.
void print_subdivide(const SubdivideReport& r, std::size_t cap, const std::string& path, const Mesh& mesh) {
  fmt::print(stderr, "subdivided: {} -> {} vertices in {} round{} ({} edges split{}), {:.2f} s\n", r.input_vertices,
             r.vertices, r.rounds, r.rounds == 1 ? "" : "s", r.split_edges,
             r.capped ? fmt::format(", capped at {}", cap) : std::string(), r.seconds);
  fmt::print(stderr, "wrote {}: the refined mesh, {} vertices, {} triangles (the transfer is for it)\n", path,
             mesh.vertex_count(), mesh.triangles.size());
}

// What --adaptive did, on stderr.
// `points`: what the sample points are ("vertices" or "texels").
void print_adaptive(const AdaptiveReport& r, const Transfer& t, std::string_view points = "vertices") {
  const std::string_view point = points == "texels" ? "texel" : "vertex";
  fmt::print(stderr,
             "adaptive (TOL {:.3g}): traced {} of {} {} ({:.1f}%), {} interpolated; {} {} traces in all "
             "({:.2f}x fewer than tracing every {}); {} levels, {} patches of which {} traced whole, {} probes; "
             "selecting {:.2f} s, tracing {:.2f} s, predicting {:.2f} s\n",
             r.tolerance, r.traced, r.vertices, points,
             r.vertices ? 100.0 * double(r.traced) / double(r.vertices) : 100.0, t.interpolated_vertices(), r.traces,
             point, r.traces ? double(r.vertices) / double(r.traces) : 1.0, point, r.levels, r.patches,
             r.failed_patches, r.probes, r.seconds_selecting, r.seconds_tracing, r.seconds_predicting);
  if (r.verified > 0)
    fmt::print(stderr,
               "verify: traced {} interpolated {} again: error RMS {:.4f}, 95th percentile {:.4f}, max {:.4f} "
               "(TOL {:.3g}; {} above it, {:.1f}%); they now hold the traced transfer\n",
               r.verified, points, r.verified_rms, r.verified_p95, r.verified_max, r.tolerance, r.verified_over,
               100.0 * double(r.verified_over) / double(r.verified));
}

// The reference cache of --target-error: --cache, else $XDG_CACHE_HOME/prt,
// else ~/.cache/prt, else none.
std::string target_cache(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return (std::filesystem::path(x) / "prt").string();
  if (const char* h = std::getenv("HOME"); h && *h) return (std::filesystem::path(h) / ".cache" / "prt").string();
  return {};
}

// The map --target-error is measured under.
EnvMap target_map(const PrecomputeArgs& a) {
  EnvMap map = load_envmap(a.env);
  require_finite(map);
  if (map.is_cube()) throw Error(a.env + ": --target-error needs a lat-long (2:1) map, not " + map.source_layout);
  return map;
}

TargetLog target_log(const PrecomputeArgs& a) {
  return [quiet = a.quiet](const std::string& line) {
    if (!quiet) fmt::print(stderr, "{}{}\n", isatty(2) ? "\r\033[K" : "", line);
  };
}

// --basis wavelet --target-error: the fewest terms K meeting the target.
std::optional<WaveletTransfer> run_wavelet_target(PrecomputeArgs& a, const Mesh& mesh) {
  const EnvMap map = target_map(a);
  TargetOptions t;
  t.target = a.target_error;
  t.transfer.albedo = a.wopt.albedo;
  t.transfer.vertex_colors = a.wopt.vertex_colors;
  t.transfer.offset = a.wopt.offset;
  const std::optional<WaveletTargetResult> r = run_with_progress(a.quiet, "precompute", [&](const Progress& progress) {
    return choose_wavelet_terms(mesh, map, t, a.wopt, target_cache(a.cache), progress, target_log(a));
  });
  if (!r) return std::nullopt;
  if (!a.quiet) fmt::print(stderr, "target error {}: {}\n", a.target_error, r->explanation);
  return std::move(r->transfer);
}

// --target-error: the cheapest settings meeting the target (prt/tuning.h).
std::optional<TargetResult> run_target(PrecomputeArgs& a, const Mesh& mesh) {
  const EnvMap map = target_map(a);
  TargetOptions t;
  t.target = a.target_error;
  t.transfer = a.opt;
  t.adaptive = a.adaptive_opt->count() > 0;
  t.adaptive_options = a.aopt;
  // Unless given: the largest the search may choose.
  if (a.bands_opt->count() == 0) t.transfer.bands = 16;
  if (a.samples_opt->count() == 0) t.transfer.samples = 4096;
  if (a.bounces_opt->count() == 0) t.transfer.bounces = 3;
  const std::optional<TargetResult> r = run_with_progress(a.quiet, "precompute", [&](const Progress& progress) {
    return choose_transfer(mesh, map, t, target_cache(a.cache), progress, target_log(a));
  });
  if (r && !a.quiet) fmt::print(stderr, "target error {}: {}\n", a.target_error, r->explanation);
  return r;
}

// --basis wavelet: the all-frequency shadowed transfer (prt/wavelet_transfer.h).
int run_wavelet(PrecomputeArgs& a) {
  double rgb[3];
  parse_triple(a.albedo, "--albedo", rgb);
  a.wopt.albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  a.wopt.vertex_colors = a.opt.vertex_colors;
  a.wopt.threads = a.opt.threads;
  a.wopt.offset = a.opt.offset;
  a.wopt.comm = &job();
  if (is_root()) for_path("--output", [&] { check_writable(a.output); });

  const auto t0 = std::chrono::steady_clock::now();
  const Mesh mesh = load_mesh(a.mesh, a.mesh_opt);
  test_fail_rank();
  const bool quiet = a.quiet || !is_root();
  if (!quiet) fmt::print(stderr, "{}\n", describe(mesh));
  const std::unique_ptr<PointTracer> device = make_device(a, mesh, quiet);
  Outputs out("precompute");  // from here Ctrl-C stops cleanly, the write step included
  const std::optional<WaveletTransfer> computed =
      a.target_opt->count() > 0 ? run_wavelet_target(a, mesh)
                         : run_with_progress(quiet, "precompute", [&](const Progress& progress) {
                             return compute_wavelet_transfer(mesh, a.wopt, job_progress(progress));
                           });
  if (!computed) return 130;
  if (!is_root()) return 0;  // rank 0 writes the file
  const WaveletTransfer& t = *computed;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.write([&] { write_wavelet_transfer(a.output, t); });
  if (const int rc = out.commit(); rc != 0) return rc;
  print_rays(a, t.vertices, secs);
  if (!a.quiet)
    fmt::print(stderr,
               "wrote {}: wavelet, cube {} ({} coefficients), threshold {}, {} vertices, kept {:.3f}% of the "
               "coefficients ({:.1f} per vertex), {:.1f} bytes/vertex, {} bytes, precompute {:.2f} s\n",
               a.output, t.cube_res, t.coeff_count(), t.threshold, t.vertices, 100.0 * t.kept_fraction(),
               t.vertices ? double(t.kept()) / double(t.vertices) : 0.0,
               t.vertices ? double(t.bytes()) / double(t.vertices) : 0.0, transfer_file_size(t), secs);
  return 0;
}

// --basis zh: the SH transfer, then K zonal-harmonic lobes per vertex in its
// rest frame (local deformable PRT; prt/zh_transfer.h, docs/LDPRT.md).
int run_zh(PrecomputeArgs& a) {
  if (a.material == "glossy")
    throw UsageError("--material glossy does not apply to --basis zh (its lobes hold the diffuse transfer; "
                     "docs/LDPRT.md)");
  for (const CLI::Option* o : {a.target_opt, a.env_opt, a.cache_opt, a.compress_weights_opt})
    if (o->count() > 0) throw UsageError(o->get_name() + " does not apply to --basis zh (--lobes sets its size)");
  if (!a.compress.empty())
    throw UsageError("--compress does not apply to --basis zh (its K lobes per vertex are its compression)");
  if (a.opt.bands > zh::kMaxBands)
    throw UsageError(fmt::format("--basis zh takes --bands at most {} (a lobe's profile; past it the SH vector is "
                                 "the cheaper form)", zh::kMaxBands));
  a.opt.mode = for_option("--mode", [&] { return parse_transfer_mode(a.mode); });
  double rgb[3];
  parse_triple(a.albedo, "--albedo", rgb);
  a.opt.albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  a.opt.comm = &job();
  a.opt.memory_limit = memory_limit(a);
  if (is_root()) for_path("--output", [&] { check_writable(a.output); });

  const auto t0 = std::chrono::steady_clock::now();
  a.mesh_opt.uvs = a.tangent == "uv";  // the UV tangent, where the file has texture coordinates
  const Mesh mesh = load_mesh(a.mesh, a.mesh_opt);
  test_fail_rank();
  release_free_memory();
  const bool quiet = a.quiet || !is_root();
  if (!quiet) fmt::print(stderr, "{}\n", describe(mesh));
  const std::unique_ptr<PointTracer> device = make_device(a, mesh, quiet);
  Outputs out("precompute");
  const std::optional<Transfer> computed = run_with_progress(quiet, "precompute", [&](const Progress& progress) {
    return a.adaptive_opt->count() > 0 ? compute_adaptive_transfer(mesh, a.opt, a.aopt, job_progress(progress))
                                        : compute_transfer(mesh, a.opt, job_progress(progress));
  }, a.opt.memory_limit);
  if (!computed) return 130;
  if (!is_root()) return 0;  // rank 0 fits and writes
  const auto t1 = std::chrono::steady_clock::now();
  ZhFitOptions fo;
  fo.lobes = a.lobes;
  fo.threads = a.opt.threads;
  std::optional<ZhTransfer> z = run_with_progress(a.quiet, "precompute", [&](const Progress& progress) {
    return fit_zh_transfer(*computed, mesh, fo, progress);
  });
  if (!z) return 130;
  if (a.dynamic_ao) {
    DynamicAoOptions ao;
    ao.threads = a.opt.threads;
    z->rest_ao = dynamic_ao(mesh, ao);
  }
  const auto t2 = std::chrono::steady_clock::now();
  out.write([&] { write_zh_transfer(a.output, *z); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet) {
    fmt::print(stderr,
               "wrote {}: {} lobes x {} bands, {}, {} channel{}, {} vertices ({} analytic, no lobes stored), fit error "
               "{:.3f}% of the SH transfer, {:.1f} bytes per stored vertex (the SH rows: {}), precompute {:.2f} s, "
               "fit {:.2f} s\n",
               a.output, z->lobes, z->bands, transfer_mode_name(z->mode), z->channels, z->channels == 1 ? "" : "s",
               z->vertices, z->analytic_vertices(), 100.0 * z->fit_error, 4.0 * double(z->stride()),
               4 * computed->stride(), std::chrono::duration<double>(t1 - t0).count(),
               std::chrono::duration<double>(t2 - t1).count());
    const TangentCounts tc = tangent_counts(*z);
    fmt::print(stderr, "vertex frames: {} tangents from texture coordinates, {} by the edge rule, {} from the normal "
               "alone (docs/CONVENTIONS.md, \"Vertex frames\")\n",
               tc.uv, tc.edge, tc.none);
  }
  return 0;
}

// The summary's line on the surface integral's sources.
void print_irradiance_samples(const Mesh& mesh, std::size_t added) {
  fmt::print(stderr, "irradiance samples: the {} vertices and {} points between them (triangles split where the light "
                     "entering them changes)\n",
             mesh.vertex_count(), added);
}

// The scale of a translucent precompute, for its summary: the mesh's size in
// millimetres and how far each channel's light goes (1 / sigma_tr).
std::string subsurface_scale(const Mesh& mesh, const SubsurfaceRecord& r) {
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const SubsurfaceMaterial& m = r.material;
  std::string reach;
  for (int c = 0; c < 3; ++c) {
    const Dipole d(m.sigma_a[c], m.sigma_s[c], m.eta);
    reach += fmt::format("{}{:.3g}", c ? ", " : "", d.sigma_tr > 0 ? 1.0 / d.sigma_tr : INFINITY);
  }
  return fmt::format("the mesh is {:.3g} mm across at {:g} mm a unit; its light goes {} mm (1 / sigma_tr: r, g, b)",
                     mesh.positions.empty() ? 0.0 : glm::length(hi - lo) * r.length_scale, r.length_scale, reach);
}

// What prt precompute --lightmap says of the atlas's texels.
void print_texels(const LightmapTexels& texels, int set, std::size_t moved) {
  const int width = texels.layout.width, height = texels.layout.height;
  const std::size_t n = texels.layout.texels.size();
  fmt::print(stderr,
             "lightmap {} in UV set {} (TEXCOORD_{}): {} covered texels ({:.1f}%), {} charts; {} covered in part "
             "(sampled on the covered part), {} moved out of geometry\n",
             lightmap_size_text(texels.layout), set, set, n, 100.0 * double(n) / (double(width) * height), texels.charts, texels.partial,
             moved);
  if (texels.shared)
    fmt::print(stderr,
               "warning: {} texels are touched by two UV charts (less than a texel of padding between them): "
               "each holds one chart's light, and bilinear filtering bleeds it into the other; pack the lightmap "
               "UVs with more margin or use a larger atlas\n",
               texels.shared);
  if (texels.overlapped)
    fmt::print(stderr,
               "warning: {} texels lie where two UV charts overlap a little (a packing with too little margin): each "
               "holds the light of the triangle covering its centre, and the other chart shows it too; --lightmap-uv "
               "auto makes UVs without overlaps\n",
               texels.overlapped);
  if (texels.uv_degenerate)
    fmt::print(stderr, "warning: {} triangles have no area in UV set {}: they get no texels (black in the lightmap)\n",
               texels.uv_degenerate, set);
}

// --lightmap WxH: the SH transfer of every covered texel of SCENE's atlas;
// with `sss`, a translucent material's (compute_subsurface_lightmap).
int run_lightmap(PrecomputeArgs& a, const SubsurfaceRecord* sss = nullptr) {
  const bool wavelet = a.basis == "wavelet";
  if (wavelet && a.mode != "shadowed")
    throw UsageError("--mode " + a.mode + " is not available with --basis wavelet: wavelet transfers are shadowed only");
  if (wavelet)
    for (const CLI::Option* o : a.sh_only)
      if (o->count() > 0 && o != a.material_opt)
        throw UsageError(o->get_name() + " does not apply to --basis wavelet (--cube-res and --threshold set its size)");
  if (!wavelet)
    for (const CLI::Option* o : a.wavelet_only)
      if (o->count() > 0) throw UsageError(o->get_name() + " applies to --basis wavelet only");
  for (const CLI::Option* o : {a.material_opt, a.target_opt, a.vertex_colors_opt, a.weld_opt})
    if (o->count() > 0 && !(o == a.material_opt && (a.material == "diffuse" || sss)))
      throw UsageError(o->get_name() + " does not apply to --lightmap (a lightmap is diffuse; its albedo is the "
                       "scene's materials, or --albedo)");
  if (!a.compress.empty()) throw UsageError("--compress does not apply to --lightmap");
  if (a.opt.directional && (wavelet || sss))
    throw UsageError(wavelet ? "--directional is an SH lightmap's (the L1 of its incident light), not --basis wavelet's"
                             : "--directional: a translucent lightmap's light is diffuse, with no directional rows");
  if (a.obscurance_map.empty() != !(a.obscurance > 0))
    throw UsageError("--obscurance D and --obscurance-map FILE go together (the distance and where to write the map)");
  for (const auto& [option, m] : {std::pair{"--ao-map", &a.ao_map}, std::pair{"--bent-normal-map", &a.bent_map},
                                  std::pair{"--obscurance-map", &a.obscurance_map}})
    if (!m->empty()) {
      std::string ext = std::filesystem::path(*m).extension().string();
      for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
      if (ext != ".exr") throw UsageError(*m + ": the extra maps are RGBA float EXR (.exr)");
      if (is_root()) for_path(option, [&] { check_writable(*m); });
    }
  int width = 0, height = 0;
  for_option("--lightmap", [&] { parse_lightmap_size(a.lightmap, width, height); });
  a.opt.mode = for_option("--mode", [&] { return parse_transfer_mode(a.mode); });
  std::optional<glm::vec3> albedo;
  if (a.albedo_opt->count() > 0) {
    double rgb[3];
    parse_triple(a.albedo, "--albedo", rgb);
    albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  }
  a.opt.comm = &job();
  a.opt.memory_limit = memory_limit(a);
  if (is_root()) for_path("--output", [&] { check_writable(a.output); });
  const auto t0 = std::chrono::steady_clock::now();
  const bool quiet = a.quiet || !is_root();
  const SceneToBake bake = load_scene_to_bake(
      a.mesh, a.mesh_opt,
      {a.lightmap_uv, a.uv, a.uv_padding, a.pages, a.texel_size, a.uv_opt, a.uv_padding_opt, a.pages_opt, a.texel_opt},
      width, height, quiet);
  const Scene& scene = bake.scene;
  test_fail_rank();
  if (!quiet) fmt::print(stderr, "{}\n", describe(scene));
  if (!quiet && sss)
    fmt::print(stderr, "material: subsurface, {}\n{}\n", describe_subsurface(*sss), subsurface_scale(scene.mesh, *sss));
  const int set = bake.atlas.uv_set;
  if (!wavelet) {  // a limit the transfer's plan would refuse, refused before the atlas is rasterised
    release_free_memory();
    check_lightmap_memory(scene, width, bake.atlas.height, set, a.opt, a.adaptive_opt->count() > 0,
                          albedo ? &*albedo : nullptr);
  }
  LightmapTexels texels = lightmap_texels(scene, bake.atlas, albedo ? &*albedo : nullptr);
  const std::size_t moved = move_texels_out_of_geometry(scene.mesh, texels, a.opt.offset);
  if (!quiet) print_texels(texels, set, moved);
  const std::unique_ptr<PointTracer> device = make_device(a, scene.mesh, quiet);
  Outputs out("precompute");
  if (wavelet) {  // the all-frequency variant: a wavelet transfer at the texels (docs/LIGHTMAPS.md)
    a.wopt.threads = a.opt.threads;
    a.wopt.offset = a.opt.offset;
    a.wopt.comm = &job();
    a.wopt.vertex_colors = true;
    if (albedo) a.wopt.albedo = *albedo;
    const Mesh points = texel_points(texels);
    const std::optional<WaveletTransfer> w = run_with_progress(quiet, "precompute", [&](const Progress& progress) {
      return compute_wavelet_at_points(scene.mesh, points, a.wopt, job_progress(progress));
    });
    if (!w) return 130;
    if (!is_root()) return 0;
    WaveletLightmap wl{*w, texels.layout};
    wl.transfer.mesh_hash = texels.layout.scene_hash;
    out.write([&] { write_wavelet_lightmap(a.output, wl); });
    if (const int rc = out.commit(); rc != 0) return rc;
    if (!a.quiet)
      fmt::print(stderr, "wrote {}: wavelet lightmap {}, cube {}, {} covered texels, {:.1f} coefficients and {:.1f} "
                         "bytes per texel, {:.2f} s\n",
                 a.output, lightmap_size_text(texels.layout), wl.transfer.cube_res, wl.transfer.vertices,
                 double(wl.transfer.kept()) / double(std::max<std::size_t>(wl.transfer.vertices, 1)),
                 double(wl.transfer.bytes()) / double(std::max<std::size_t>(wl.transfer.vertices, 1)),
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    print_rays(a, wl.transfer.vertices, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return 0;
  }
  const bool adapt = a.adaptive_opt->count() > 0;
  AdaptiveReport adaptive;
  SubsurfaceScatterOptions so;
  if (sss) {
    so.length_scale = sss->length_scale;
    so.threads = a.opt.threads;
  }
  const std::optional<LightmapTransfer> computed = run_with_progress(quiet, "precompute", [&](const Progress& progress) {
    if (sss) return compute_subsurface_lightmap(scene, texels, a.opt, sss->material, so, job_progress(progress));
    return adapt ? compute_adaptive_lightmap_transfer(scene, texels, a.opt, a.aopt, job_progress(progress), &adaptive)
                 : compute_lightmap_transfer(scene, texels, a.opt, job_progress(progress));
  }, a.opt.memory_limit);
  if (!computed) return 130;
  if (!is_root()) return 0;
  std::vector<float> obscurance;
  if (a.obscurance > 0) {
    const std::optional<std::vector<float>> w = run_with_progress(quiet, "precompute", [&](const Progress&) {
      return point_obscurance(scene.mesh, texels.positions, texels.normals, a.obscurance, a.opt.samples, a.opt.seed,
                              a.opt.offset);
    });
    if (!w) return 130;
    obscurance = *w;
  }
  // An extra map: per-texel values in the lightmap's layout, A = coverage.
  const auto write_map = [&](const std::string& path, const std::vector<glm::vec3>& values) {
    write_lightmap_pages(out, path, texels.layout, lightmap_rgba(texels.layout, values));
  };
  const Transfer& ct = computed->transfer;
  if (!a.ao_map.empty()) {
    std::vector<glm::vec3> v(ct.ao.size());
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = glm::vec3(ct.ao[i]);
    write_map(a.ao_map, v);
  }
  if (!a.bent_map.empty()) write_map(a.bent_map, ct.bent_normals);
  if (!a.obscurance_map.empty()) {
    std::vector<glm::vec3> v(obscurance.size());
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = glm::vec3(obscurance[i]);
    write_map(a.obscurance_map, v);
  }
  out.write([&] { write_lightmap_transfer(a.output, *computed); });
  if (const int rc = out.commit(); rc != 0) return rc;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!a.quiet) {
    const Transfer& t = computed->transfer;
    fmt::print(stderr,
               "wrote {}: lightmap {}, {} {} bands, {} channel{}, {} covered texels ({} analytic, no row stored), "
               "{} bytes, {:.2f} s\n",
               a.output, lightmap_size_text(texels.layout), transfer_mode_name(t.mode), t.bands, t.channels, t.channels == 1 ? "" : "s",
               t.vertices, t.analytic_vertices(), transfer_file_size(*computed), secs);
    if (t.glossy_rows != 0)
      fmt::print(stderr, "directional rows: {} x {} ({} channel{}), {} bytes per stored texel\n", t.glossy_rows,
                 t.bands * t.bands, t.glossy_channels(), t.glossy_channels() == 1 ? "" : "s", 4 * t.glossy_stride());
    if (adapt) print_adaptive(adaptive, t, "texels");
  }
  print_rays(a, texels.positions.size(), secs);
  return 0;
}

// --probes NXxNYxNZ: the probe volume over SCENE's bounding box.
int run_probes(PrecomputeArgs& a) {
  if (a.lightmap_opt->count() > 0) throw UsageError("--probes and --lightmap are two runs (a probe volume, a lightmap)");
  if (a.basis != "sh") throw UsageError("--basis does not apply to --probes (a probe stores a visibility cube; docs/PROBES.md)");
  for (const CLI::Option* o : {a.material_opt, a.target_opt, a.vertex_colors_opt, a.weld_opt, a.uv_opt, a.tolerance_opt,
                               a.compress_weights_opt, a.lightmap_uv_opt, a.uv_padding_opt, a.pages_opt,
                               a.texel_opt})
    if (o->count() > 0 && !(o == a.material_opt && a.material == "diffuse"))
      throw UsageError(o->get_name() + " does not apply to --probes");
  for (const CLI::Option* o : a.wavelet_only)
    if (o->count() > 0) throw UsageError(o->get_name() + " does not apply to --probes (--probe-cube sets its cube)");
  if (!a.compress.empty() || !a.ao_map.empty() || !a.bent_map.empty() || !a.obscurance_map.empty())
    throw UsageError("--compress and the lightmap's extra maps do not apply to --probes");
  if (job().size() > 1) throw UsageError("--probes runs in one process (not under mpirun) for now");
  const std::array<int, 3> dims = for_option("--probes", [&] { return parse_probe_dims(a.probes); });
  ProbeOptions o = a.popt;
  o.mode = for_option("--mode", [&] { return parse_transfer_mode(a.mode); });
  if (o.mode == TransferMode::Unshadowed)
    throw UsageError("--mode unshadowed does not apply to --probes (a probe's light is the scene's occlusion of the map)");
  o.bands = a.bands_opt->count() > 0 ? a.opt.bands : 3;
  if (o.bands > 8) throw UsageError(fmt::format("--bands {}: a probe's light takes at most 8 bands", o.bands));
  o.bounces = a.opt.bounces;
  if (o.mode == TransferMode::Interreflected && (o.bounces < 1 || o.bounces > kMaxProbeBounces))
    throw UsageError(fmt::format("--bounces {}: probes take 1 to {}", o.bounces, kMaxProbeBounces));
  if (a.bounce_bands_opt->count() > 0 && o.mode != TransferMode::Interreflected)
    throw UsageError("--bounce-bands applies to --mode interreflected");
  // --samples: rays per probe, as k^2 rays in each of the base cube's 6 (r/4)^2
  // texels (compute_probe_transfer traces at r/4, then refines at the edges).
  const int base = std::max(1, o.cube_res / 4);
  if (a.samples_opt->count() > 0) {
    const double per_texel = double(a.opt.samples) / (6.0 * base * base);
    const int k = std::clamp(int(std::lround(std::sqrt(std::max(per_texel, 1.0)))), 1, 8);
    o.rays_per_texel = k * k;
  }
  o.seed = a.opt.seed;
  o.threads = a.opt.threads;
  o.offset = a.opt.offset;
  if (a.albedo_opt->count() > 0) {
    double rgb[3];
    parse_triple(a.albedo, "--albedo", rgb);
    o.override_albedo = true;
    o.albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  }
  for_path("--output", [&] { check_writable(a.output); });
  const auto t0 = std::chrono::steady_clock::now();
  const Scene scene = load_scene_or_mesh(a.mesh, a.mesh_opt);
  if (scene.materials.empty() && !o.override_albedo) {  // a bare mesh: --albedo's default
    double rgb[3];
    parse_triple(a.albedo, "--albedo", rgb);
    o.override_albedo = true;
    o.albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  }
  const ProbeGrid grid = probe_grid(scene.mesh, dims);
  const std::unique_ptr<PointTracer> device = make_device(a, scene.mesh, a.quiet);
  o.tracer = device.get();
  if (!a.quiet) {
    const glm::dvec3 sp = grid.spacing();
    fmt::print(stderr, "{}\nprobes {}x{}x{} ({} in all) over [{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] x [{:.4g}, {:.4g}], spacing "
                       "{:.4g} x {:.4g} x {:.4g}; {} bands, {}, visibility cube {} ({} rays per probe, more at edges)\n",
               describe(scene), dims[0], dims[1], dims[2], grid.count(), grid.min.x, grid.max.x, grid.min.y, grid.max.y,
               grid.min.z, grid.max.z, sp.x, sp.y, sp.z, o.bands, transfer_mode_name(o.mode), o.cube_res,
               6 * base * base * o.rays_per_texel);
  }
  Outputs out("precompute");
  const std::optional<ProbeTransfer> computed = run_with_progress(a.quiet, "precompute", [&](const Progress& progress) {
    return compute_probe_transfer(scene, grid, o, progress);
  });
  if (!computed) return 130;
  const ProbeTransfer& t = *computed;
  out.write([&] { write_probe_transfer(a.output, t); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet) {
    std::size_t counts[3] = {0, 0, 0};
    for (ProbeState st : t.state) ++counts[int(st)];
    fmt::print(stderr,
               "wrote {}: {} probes: {} stored, {} see only sky (nothing stored), {} inside geometry (no weight); "
               "{} bytes ({:.0f} per stored probe), {:.2f} s\n",
               a.output, t.probes(), counts[1], counts[0], counts[2], t.bytes(),
               counts[1] ? double(t.bytes()) / double(counts[1]) : 0.0,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    print_rays(a, t.probes(), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
               6.0 * base * base * o.rays_per_texel);
  }
  return 0;
}

// What an SH vertex transfer's run reports besides the transfer.
struct ShReports {
  TransferMemory memory;
  AdaptiveReport adaptive;
  SubdivideReport subdivided;
  std::optional<Mesh> refined;  // --subdivide: the mesh the transfer is for
};

// --compress KxN and --compress-weights, checked: what a vertex transfer is
// compressed with when --compress is given.
CompressOptions compress_options(const PrecomputeArgs& a) {
  CompressOptions copt;
  copt.weight_bits = a.compress_weights;
  if (!a.compress.empty()) parse_compress(a.compress, copt);
  if (a.compress.empty() && a.compress_weights_opt->count() > 0)
    throw UsageError("--compress-weights is for --compress KxN; give both, or leave it out");
  return copt;
}

// The summary of an SH vertex transfer written (`secs` after loading began;
// `cap`: the refined mesh's most vertices).
void print_sh_summary(const PrecomputeArgs& a, const Transfer& t, const ShReports& rep, std::size_t cap, double secs) {
  fmt::print(stderr, "wrote {}: {} {} bands, {} channel{}, {} vertices, {} bytes/vertex transfer, {:.2f} s\n",
             a.output, transfer_mode_name(t.mode), t.bands, t.channels, t.channels == 1 ? "" : "s", t.vertices,
             4 * t.stride(), secs);
  if (t.glossy)
    fmt::print(stderr, "glossy matrices: {}x{}{}, {} bytes per stored vertex, {} per vertex on average\n",
               t.bands * t.bands, t.bands * t.bands,
               t.glossy_symmetric() ? " symmetric (upper triangle stored)"
                                    : fmt::format(" x {} channel{}", t.glossy_channels(),
                                                  t.glossy_channels() == 1 ? "" : "s"),
               4 * t.glossy_stride(), 4 * t.glossy_matrices.size() / std::max<std::size_t>(t.vertices, 1));
  fmt::print(stderr, "analytic (unoccluded, no stored transfer): {} of {} vertices ({:.1f}%), {} bytes saved\n",
             t.analytic_vertices(), t.vertices,
             t.vertices ? 100.0 * double(t.analytic_vertices()) / double(t.vertices) : 0.0, analytic_bytes_saved(t));
  if (t.mode == TransferMode::Interreflected && a.opt.bounces > 0) {
    std::string energies;
    for (double e : t.bounce_energy) energies += fmt::format(" {:.3g}", t.direct_energy > 0 ? e / t.direct_energy : 0.0);
    fmt::print(stderr, "bounces: {} of at most {}{}; energy of each relative to the direct part:{}\n", t.bounces,
               a.opt.bounces, t.bounces < a.opt.bounces ? " (the last fell below --bounce-tolerance)" : "",
               energies);
  }
  if (rep.memory.records_in_memory + rep.memory.records_spilled > 0 || a.memory_limit.size())
    fmt::print(stderr,
               "memory: peak {:.2f} GB resident of --memory-limit {:.2f} GB{}; gather records {:.1f} MB in memory, "
               "{:.1f} MB in the temporary file (blocks of {} vertices)\n",
               double(peak_resident_bytes()) / 1e9, double(a.opt.memory_limit) / 1e9,
               a.memory_limit.empty() ? " (the default)" : "", double(rep.memory.records_in_memory) / 1e6,
               double(rep.memory.records_spilled) / 1e6, rep.memory.block);
  if (a.adaptive_opt->count() > 0 && a.target_opt->count() == 0) print_adaptive(rep.adaptive, t);
  if (rep.refined) print_subdivide(rep.subdivided, cap, a.subdivided_mesh, *rep.refined);
  if (!t.ao.empty() && t.mode != TransferMode::Unshadowed) {
    double mean = 0;
    for (float v : t.ao) mean += v;
    fmt::print(stderr, "ambient occlusion: mean {:.4f}\n", mean / double(std::max<std::size_t>(t.ao.size(), 1)));
  }
}

// The SH transfer at the mesh's vertices (the basis and options checked).
int run_sh_vertices(PrecomputeArgs& a) {
  a.opt.mode = for_option("--mode", [&] { return parse_transfer_mode(a.mode); });
  a.opt.glossy = a.material == "glossy";
  double rgb[3];
  parse_triple(a.albedo, "--albedo", rgb);
  a.opt.albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  a.opt.comm = &job();
  a.opt.memory_limit = memory_limit(a);
  ShReports rep;
  a.opt.memory_report = &rep.memory;
  // Test hook (tests/mpi): PRT_TEST_RECORDS_IN_MEMORY=BYTES caps the records
  // kept in memory, so a small mesh sends the rest to the temporary file.
  if (const char* cap = std::getenv("PRT_TEST_RECORDS_IN_MEMORY"); cap && *cap)
    a.opt.records_in_memory_max = std::size_t(std::strtoull(cap, nullptr, 10));
  if (is_root()) for_path("--output", [&] { check_writable(a.output); });
  const bool subdivide = a.subdivide_opt->count() > 0;
  if (subdivide && is_root()) for_path("--subdivided-mesh", [&] { check_writable(a.subdivided_mesh); });

  CompressOptions copt = compress_options(a);  // checked before the long work
  const auto t0 = std::chrono::steady_clock::now();
  const Mesh mesh = load_mesh(a.mesh, a.mesh_opt);
  if (subdivide && a.sopt.max_vertices != 0 && a.sopt.max_vertices < mesh.vertex_count())
    throw UsageError(fmt::format("--subdivide-max-vertices {}: below the mesh's {} vertices (0: 4x the mesh's)",
                                 a.sopt.max_vertices, mesh.vertex_count()));
  test_fail_rank();
  release_free_memory();
  const bool quiet = a.quiet || !is_root();
  if (!quiet) fmt::print(stderr, "{}\n", describe(mesh));
  const std::unique_ptr<PointTracer> device = make_device(a, mesh, quiet);
  Outputs out("precompute");  // from here Ctrl-C stops cleanly, the write step included
  const bool adapt = a.adaptive_opt->count() > 0;
  // --target-error: the settings chosen on the input mesh; with --subdivide
  // the refinement then runs with them (the chosen transfer is the input's).
  std::optional<Transfer> computed;
  if (a.target_opt->count() > 0) {
    std::optional<TargetResult> r = run_target(a, mesh);
    if (!r) return 130;
    if (subdivide) {
      a.opt.bands = r->bands;
      a.opt.samples = r->samples;
      a.opt.bounces = r->bounces;
    } else {
      computed = std::move(r->transfer);
    }
  }
  if (!computed)
    computed = run_with_progress(quiet, "precompute", [&](const Progress& progress) {
      if (subdivide) {
        Subdivided d = subdivide_for_transfer(mesh, a.opt, a.sopt, job_progress(progress), &rep.subdivided);
        rep.refined = std::move(d.mesh);
        return std::move(d.transfer);
      }
      return adapt ? compute_adaptive_transfer(mesh, a.opt, a.aopt, job_progress(progress), &rep.adaptive)
                   : compute_transfer(mesh, a.opt, job_progress(progress));
    }, a.opt.memory_limit);
  if (!computed) return 130;
  if (!is_root()) return 0;  // rank 0 compresses and writes the file
  const Transfer& t = *computed;
  // The refined mesh goes with the transfer: both written, or neither.
  const auto write_refined = [&] {
    if (rep.refined)
      out.write([&] {
        write_ply(a.subdivided_mesh, *rep.refined, rep.refined->colors, PlyColors::Float,
                  "prt precompute --subdivide: refined mesh");
      });
  };
  const std::size_t cap = a.sopt.max_vertices ? a.sopt.max_vertices : 4 * mesh.vertex_count();
  if (!a.compress.empty()) {
    CompressOptions o = copt;
    const std::optional<CompressedTransfer> c = run_with_progress(a.quiet, "precompute", [&](const Progress& p) {
      o.progress = p;
      return compress_transfer(t, o);
    });
    if (!c) return 130;
    out.write([&] { write_compressed_transfer(a.output, *c); });
    write_refined();
    if (const int rc = out.commit(); rc != 0) return rc;
    if (!a.quiet) fmt::print(stderr, "wrote {} (compressed):\n{}", a.output, describe_transfer(*c));
    if (!a.quiet && rep.refined) print_subdivide(rep.subdivided, cap, a.subdivided_mesh, *rep.refined);
    return 0;
  }
  out.write([&] { write_transfer(a.output, t); });
  write_refined();
  if (const int rc = out.commit(); rc != 0) return rc;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!a.quiet) print_sh_summary(a, t, rep, cap, secs);
  print_rays(a, mesh.vertex_count(), secs);
  return 0;
}

// --material subsurface (docs/SUBSURFACE.md): what does not apply, refused
// by name with the reason.
void check_subsurface(const PrecomputeArgs& a) {
  const auto no = [](const std::string& what, const std::string& why) {
    throw UsageError(what + " does not apply to --material subsurface: " + why);
  };
  if (a.basis != "sh")
    no("--basis " + a.basis, "its exit radiance is view-independent and smooth (the dipole spreads light over "
                             "millimetres), so SH transfer vectors hold it; leave --basis out");
  if (a.mode == "unshadowed")
    throw UsageError("--material subsurface is shadowed or interreflected: the light entering each vertex is traced "
                     "(unshadowed light would pass through the object's other side)");
  for (const auto& [option, path] : {std::pair{"--ao-map", &a.ao_map}, std::pair{"--bent-normal-map", &a.bent_map},
                                     std::pair{"--obscurance-map", &a.obscurance_map}})
    if (!path->empty())
      no(option, "a translucent lightmap's texels are not traced (each sums the light entering the surface around "
                 "it); precompute a diffuse lightmap for the extra maps");
  if (a.probes_opt->count() > 0) no("--probes", "a probe volume records the light arriving at points in space");
  for (const CLI::Option* o : {a.albedo_opt, a.vertex_colors_opt})
    if (o->count() > 0)
      no(o->get_name(), "the material's reflectance is its profile (--sss, or --sigma-a and --sigma-s), not an albedo");
  if (a.light_bounce_opt->count() > 0) no("--light-bounce", "the lights' bounce operator is a diffuse surface's");
  if (a.target_opt->count() > 0)
    no("--target-error", "it chooses a diffuse transfer's settings against the diffuse reference; give --bands and "
                         "--samples");
  if (a.adaptive_opt->count() > 0) no("--adaptive", "the surface integral sums every vertex's traced light");
  if (a.subdivide_opt->count() > 0)
    no("--subdivide", "the surface integral runs once over the whole mesh; precompute a finer mesh instead");
  check_not_input("--output", a.output, {{"MESH", a.mesh}});
}

// A translucent material's transfer at the mesh's vertices
// (compute_subsurface_transfer), written as an RGB SH transfer.
int run_subsurface(PrecomputeArgs& a, const SubsurfaceRecord& r) {
  check_subsurface(a);
  a.opt.mode = for_option("--mode", [&] { return parse_transfer_mode(a.mode); });
  a.opt.comm = &job();
  a.opt.memory_limit = memory_limit(a);
  if (is_root()) for_path("--output", [&] { check_writable(a.output); });
  CompressOptions copt = compress_options(a);  // checked before the long work
  const auto t0 = std::chrono::steady_clock::now();
  const Mesh mesh = load_mesh(a.mesh, a.mesh_opt);
  const bool quiet = a.quiet || !is_root();
  if (!quiet)
    fmt::print(stderr, "{}\nmaterial: subsurface, {}\n{}\n", describe(mesh), describe_subsurface(r),
               subsurface_scale(mesh, r));
  Outputs out("precompute");
  SubsurfaceScatterOptions so;
  so.length_scale = r.length_scale;
  so.threads = a.opt.threads;
  std::size_t added = 0;
  so.added_samples = &added;
  const std::optional<Transfer> t = run_with_progress(quiet, "precompute", [&](const Progress& progress) {
    return compute_subsurface_transfer(mesh, a.opt, r.material, so, job_progress(progress));
  }, a.opt.memory_limit);
  if (!t) return 130;
  if (!is_root()) return 0;
  if (!a.quiet) print_irradiance_samples(mesh, added);
  if (!a.compress.empty()) {
    const std::optional<CompressedTransfer> c = run_with_progress(a.quiet, "precompute", [&](const Progress& p) {
      copt.progress = p;
      return compress_transfer(*t, copt);
    });
    if (!c) return 130;
    out.write([&] { write_compressed_transfer(a.output, *c); });
    if (const int rc = out.commit(); rc != 0) return rc;
    if (!a.quiet) fmt::print(stderr, "wrote {} (compressed):\n{}", a.output, describe_transfer(*c));
    return 0;
  }
  out.write([&] { write_transfer(a.output, *t); });
  if (const int rc = out.commit(); rc != 0) return rc;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!a.quiet) {
    fmt::print(stderr, "wrote {}: subsurface ({}), {} bands, 3 channels, {} vertices, {} bytes/vertex transfer, {:.2f} s\n",
               a.output, transfer_mode_name(t->mode), t->bands, t->vertices, 4 * t->stride(), secs);
    if (t->mode == TransferMode::Interreflected && !t->bounce_energy.empty()) {
      std::string energies;
      for (double e : t->bounce_energy) energies += fmt::format(" {:.3g}", t->direct_energy > 0 ? e / t->direct_energy : 0.0);
      fmt::print(stderr, "bounces: {}; energy of each relative to the direct part:{}\n", t->bounces, energies);
    }
  }
  return 0;
}

int run_precompute(PrecomputeArgs& a) {
  check_subdivide(a);
  parse_adaptive(a);
  check_device(a);  // before any kind of run
  if (const std::optional<SubsurfaceRecord> r = subsurface_record(a.sss, a.material)) {
    if (a.lightmap_opt->count() == 0) return run_subsurface(a, *r);
    check_subsurface(a);
    check_not_input("--output", a.output, {{"SCENE", a.mesh}});
    return run_lightmap(a, &*r);
  }
  // No output over another (each is kept off the inputs by check_not_input below).
  check_distinct_outputs({{"--output", a.output},
                          {"--ao-map", a.ao_map},
                          {"--bent-normal-map", a.bent_map},
                          {"--obscurance-map", a.obscurance_map},
                          {"--subdivided-mesh", a.subdivided_mesh},
                          {"--cache", a.cache}});
  // --memory-limit plans an SH transfer's memory (docs/PRECOMPUTE.md, "Memory"); a probe volume or a wavelet
  // transfer would ignore it.
  // --probes with --light-bounce: the operator's receivers at a probe grid's
  // probes (docs/LIGHTS.md "Bounce"), in the transfer's own run; without it,
  // a probe volume's run.
  const bool probe_volume = a.probes_opt->count() > 0 && !a.opt.light_bounce;
  if (a.memory_limit_opt->count() > 0 && (probe_volume || a.basis == "wavelet"))
    throw UsageError(fmt::format(
        "--memory-limit does not apply to {}: it plans the memory of an SH transfer at vertices or texels (its per-point "
        "arrays first, then the bounces' gather records, which go to a temporary file past the limit; "
        "docs/PRECOMPUTE.md, \"Memory\"), and {} has no such plan{}; leave --memory-limit out",
        probe_volume ? "--probes" : "--basis wavelet",
        probe_volume ? "a probe volume" : "a wavelet transfer",
        probe_volume ? " (a 64x32x64 volume takes about 80 MB; docs/PROBES.md)"
                                  : " (its size is set by --cube-res and --threshold)"));
  if (a.basis == "zh" && (a.probes_opt->count() > 0 || a.lightmap_opt->count() > 0))
    throw UsageError("--basis zh is per vertex (a deforming mesh's lobes): not for --probes or --lightmap");
  check_light_bounce(a);  // every kind of run
  if (probe_volume) {
    check_not_input("--output", a.output, {{"SCENE", a.mesh}});
    return run_probes(a);
  }
  for (const CLI::Option* o : {a.probe_cube_opt, a.bounce_bands_opt})
    if (o->count() > 0)
      throw UsageError(o->get_name() + " applies to a probe volume's run (--probes without --light-bounce)");
  if (a.probes_opt->count() > 0)
    a.opt.light_bounce_probes = for_option("--probes", [&] { return parse_probe_dims(a.probes); });
  if (a.lightmap_opt->count() > 0) {
    check_not_input("--output", a.output, {{"SCENE", a.mesh}});
    for (const auto& [option, path] : {std::pair{"--ao-map", &a.ao_map}, std::pair{"--bent-normal-map", &a.bent_map},
                                       std::pair{"--obscurance-map", &a.obscurance_map}})
      check_not_input(option, *path, {{"SCENE", a.mesh}});
    return run_lightmap(a);
  }
  if (a.uv_opt->count() > 0) throw UsageError("--uv picks the lightmap's UV set: give --lightmap WxH too");
  if (a.directional_opt->count() > 0)
    throw UsageError("--directional keeps a lightmap's L1 rows: give --lightmap WxH too (at vertices, --material "
                     "glossy keeps whole matrices)");
  for (const CLI::Option* o : {a.lightmap_uv_opt, a.uv_padding_opt, a.pages_opt, a.texel_opt})
    if (o->count() > 0) throw UsageError(o->get_name() + " shapes a lightmap's atlas: give --lightmap WxH too");
  if (!a.ao_map.empty() || !a.bent_map.empty() || !a.obscurance_map.empty() || a.obscurance > 0)
    throw UsageError("--ao-map, --bent-normal-map and --obscurance(-map) write maps of a lightmap: give --lightmap WxH "
                     "too (a vertex transfer keeps its ambient occlusion and bent normals in the file)");
  for (const CLI::Option* o : {a.lobes_opt, a.dynamic_ao_opt, a.tangent_opt})
    if (a.basis != "zh" && o->count() > 0) throw UsageError(o->get_name() + " applies to --basis zh only");
  if (a.basis == "zh") {
    for (const CLI::Option* o : a.wavelet_only)
      if (o->count() > 0) throw UsageError(o->get_name() + " applies to --basis wavelet only");
    check_not_input("--output", a.output, {{"MESH", a.mesh}});
    return run_zh(a);
  }
  check_usage(a);
  if (a.basis == "wavelet") return run_wavelet(a);
  return run_sh_vertices(a);
}

// --basis and the options of --basis zh.
void add_basis_options(CLI::App* s, PrecomputeArgs& a) {
  s->add_option("--basis", a.basis,
                "sh (spherical harmonics, all modes), wavelet (all-frequency shadows: Haar on a cube map, "
                "Ng et al. 2003) or zh (local deformable PRT: --lobes zonal-harmonic lobes per vertex in its own frame, "
                "which follow the mesh when it bends; Sloan, Luna & Snyder 2005; docs/LDPRT.md)")
      ->check(CLI::IsMember({"sh", "wavelet", "zh"}))
      ->capture_default_str();
  a.lobes_opt = s->add_option("--lobes", a.lobes,
                              "--basis zh: zonal-harmonic lobes per vertex K (1 to 8; 4 keeps the 6-band shadowed "
                              "transfer within about 1.3% on the shared meshes)")
                    ->check(int_range(1, zh::kMaxLobes))
                    ->capture_default_str();
  a.dynamic_ao_opt = s->add_flag("--dynamic-ao", a.dynamic_ao,
                                 "With --basis zh: also store the rest pose's dynamic ambient occlusion (Bunnell 2005; 4 "
                                 "bytes a vertex), which prt relight --dynamic-ao compares a pose's with to restore "
                                 "the distant occlusion the lobes cannot follow");
  a.tangent_opt = s->add_option("--tangent", a.tangent,
                               "With --basis zh: each vertex frame's tangent: uv (the direction of increasing u of "
                               "the mesh's first texture coordinates, where it has them; the edge rule elsewhere) or "
                               "edge (the edge rule everywhere); docs/CONVENTIONS.md, \"Vertex frames\"")
                     ->check(CLI::IsMember({"uv", "edge"}))
                     ->capture_default_str();
}

// What the transfer holds and how it is computed: material, mode, bands, rays, bounces,
// the error target, the wavelet basis's cube, albedo, threads, seed, offset, welding.
void add_transfer_options(CLI::App* s, PrecomputeArgs& a) {
  a.material_opt =
      add_shared(s, SharedOption::Material, a.material,
                 "diffuse (transfer vectors), glossy: also the transfer matrices of glossy, view-dependent PRT "
                 "(docs/GLOSSY.md; shadowed or interreflected, bands at most 12), or subsurface: a translucent "
                 "material's RGB transfer (--sss or --sigma-a/--sigma-s, --eta, --length-scale; docs/SUBSURFACE.md)");
  add_subsurface_options(s, a.sss);
  a.mode_opt = add_shared(s, SharedOption::Mode, a.mode, "Transfer: unshadowed (no rays), shadowed, or interreflected");
  a.bands_opt = add_shared(s, SharedOption::BandsComputed, a.opt.bands,
                           "SH bands n: prt render and prt view draw at most 16, and transfer accuracy is measured up "
                           "to 16");
  a.samples_opt = s->add_option("-s,--samples", a.opt.samples, "Rays per vertex (about)")
                      ->check(int_range(1, 1 << 24))
                      ->capture_default_str();
  a.bounces_opt = add_shared(s, SharedOption::Bounces, a.opt.bounces, "Diffuse bounces (interreflected mode), at most");
  a.sh_only.insert(a.sh_only.end(), {a.bands_opt, a.samples_opt, a.bounces_opt, a.material_opt});
  a.target_opt =
      add_shared(s, SharedOption::TargetError, a.target_error,
                 "Choose the fewest bands, bounces and samples (wavelet basis: terms K) whose relative RMS error "
                 "against the reference under --env is at most this (--bands/--samples/--bounces: the most to try)");
  a.env_opt = s->add_option("--env", a.env, "Lat-long map the --target-error is measured under")->check(path_value());
  a.cache_opt = s->add_option("--cache", a.cache, "Reference cache of --target-error (default ~/.cache/prt)")
                    ->check(path_value());
  a.tolerance_opt =
      s->add_option("--bounce-tolerance", a.opt.bounce_tolerance,
                    "Stop adding bounces once one adds less than this fraction of the direct part's energy, in "
                    "[0, 1) (0: never)")
          ->check(number_range(0.0, 1.0, false, true))
          ->capture_default_str();
  a.sh_only.push_back(a.tolerance_opt);
  a.light_bounce_opt =
      s->add_flag("--light-bounce", a.opt.light_bounce,
                  "Interreflected: also keep the bounces' gather as the operator that bounces the lights' direct light "
                  "at run time (prt relight/render --lights; docs/LIGHTS.md \"Bounce\")");
  a.bounce_patch_opt =
      s->add_option("--bounce-patch", a.opt.light_bounce_patch,
                    "With --light-bounce: the finest source patches' size in world units (0: a lightmap's mean texel, "
                    "a mesh's mean edge)")
          ->check(number_range(0.0, 1e30, true, true))
          ->capture_default_str();
  a.bounce_ratio_opt =
      s->add_option("--bounce-ratio", a.opt.light_bounce_ratio,
                    "With --light-bounce: a hit at distance d joins the coarsest source patch of size at most this times "
                    "d (smaller: more accurate, larger files; docs/LIGHTS.md \"Bounce\" tables both)")
          ->check(number_range(0.0, 1e6, true, false))
          ->capture_default_str();
  a.bounce_clusters_opt =
      s->add_option("--bounce-clusters", a.opt.light_bounce_clusters,
                    "With --light-bounce: a far hit's light is received once for the texels of a patch this many "
                    "levels finer than its source patch (smaller: smaller, faster, coarser; -1: each texel gathers all "
                    "its hits; docs/LIGHTS.md \"Bounce\")")
          ->check(int_range(-1, prt::kMaxPatchLevels - 1, "-1: none"))
          ->capture_default_str();
  a.sh_only.insert(a.sh_only.end(), {a.light_bounce_opt, a.bounce_patch_opt, a.bounce_ratio_opt, a.bounce_clusters_opt});
  a.wavelet_only.push_back(
      s->add_option("--cube-res", a.wopt.cube_res, "Wavelet basis: cube face size r (16, 32, 64; 6 r^2 coefficients)")
          ->check(cube_resolution())
          ->capture_default_str());
  a.wavelet_only.push_back(
      s->add_option("--threshold", a.wopt.threshold,
                    "Wavelet basis: relative L2 truncation error per vertex, in [0, 1) (0 keeps every non-zero term)")
          ->check(number_range(0.0, 1.0, false, true))
          ->capture_default_str());
  a.albedo_opt = add_shared(s, SharedOption::Albedo, a.albedo,
                            "Diffuse albedo (with --lightmap: replaces the scene's materials)");
  a.vertex_colors_opt = s->add_flag("--vertex-colors", a.opt.vertex_colors, "Use the mesh's vertex colours as albedo");
  add_shared(s, SharedOption::Threads, a.opt.threads, "Worker threads");
  a.sh_only.push_back(
      add_shared(s, SharedOption::Seed, a.opt.seed, "Seed of the direction set"));
  add_shared(s, SharedOption::Offset, a.opt.offset, "Ray origin offset along the normal");
  a.weld_opt = s->add_flag("--weld", a.mesh_opt.weld, "Merge vertices that share a position before precomputing");
}

// --lightmap, --probes and their options, and a lightmap's extra maps.
void add_lightmap_options(CLI::App* s, PrecomputeArgs& a) {
  a.lightmap_opt = add_shared(s, SharedOption::Lightmap, a.lightmap,
                                 "WxH: an SH lightmap instead of vertices: the transfer of every texel of a W x H "
                                 "atlas a triangle of SCENE (glTF with materials, or OBJ with vt) covers, in its "
                                 "lightmap UV set (docs/LIGHTMAPS.md)");
  a.device_opt = s->add_option("--device", a.device,
                               "cpu (Embree on every core) or gpu: the rays (shadowed, interreflected, glossy, "
                               "directional, wavelet; per vertex, texel or probe) traced in OpenGL compute shaders "
                               "over a BVH built here, headless through EGL "
                               "(the GPU's EGL device when there is one; Mesa's llvmpipe otherwise); prints rays "
                               "per second (docs/PRECOMPUTE.md \"On the GPU\")")
                     ->check(CLI::IsMember({"cpu", "gpu"}))
                     ->capture_default_str();
  a.directional_opt =
      s->add_flag("--directional", a.opt.directional,
                  "With --lightmap: also each texel's directional rows, the L1 of its incident light, for normal-mapped "
                  "surfaces (prt relight --directional godot|monosh|dominant|sh; docs/LIGHTMAPS.md \"Directional "
                  "lightmaps\")");
  a.uv_opt = add_shared(s, SharedOption::UvSet, a.uv,
                           "With --lightmap: the UV set the atlas is laid out in (default TEXCOORD_1 when every "
                           "object has it, else TEXCOORD_0)");
  a.lightmap_uv_opt = add_shared(s, SharedOption::LightmapUv, a.lightmap_uv,
                                 "With --lightmap: 'scene' (its own UV set, --uv) or 'auto': lightmap UVs made by "
                                 "prt for the WxH atlas (prt unwrap's; SCENE may then be any mesh file). Relight, "
                                 "render, view and export make them again from the same SCENE");
  a.uv_padding_opt = add_shared(s, SharedOption::UvPadding, a.uv_padding,
                                "With --lightmap-uv auto: empty texels between any two charts");
  a.pages_opt = add_shared(s, SharedOption::Pages, a.pages,
                           "With --lightmap: pages of WxH, page p in UV tile u in [p, p+1] (UDIM 1001+p); 'auto': the "
                           "tiles SCENE's UVs use, or with --lightmap-uv auto the pages --texel-size takes (images: "
                           "one EXR per page, NAME.1001.exr ...)")
                    ->capture_default_str();
  a.texel_opt = add_shared(s, SharedOption::TexelSize, a.texel_size,
                           "With --lightmap-uv auto --pages auto: a texel's edge in scene units, which decides the "
                           "pages (the charts then fill them)");
  a.probes_opt = s->add_option("--probes", a.probes,
                               "NXxNYxNZ: a relightable probe volume instead of vertices: probes on a grid spanning "
                               "SCENE's bounding box, corners included (docs/PROBES.md); --bands (default 3), --mode "
                               "shadowed|interreflected, --samples (rays per probe). With --light-bounce: the "
                               "operator's receivers include that grid's probes, for the probe-lit object of "
                               "prt render --probes (docs/LIGHTS.md \"Bounce\")");
  a.probe_cube_opt = s->add_option("--probe-cube", a.popt.cube_res,
                                   "With --probes: the visibility cube's finest face size r (4 to 64; traced at r/4, refined where an edge crosses)")
                         ->check(int_one_of({4, 8, 16, 32, 64}))
                         ->capture_default_str();
  a.bounce_bands_opt = s->add_option("--bounce-bands", a.popt.bounce_bands,
                                     "With --probes --mode interreflected: the environment bands the bounce light "
                                     "takes (1 to 16)")
                           ->check(int_range(1, 16))
                           ->capture_default_str();
  s->add_option("--ao-map", a.ao_map,
                "With --lightmap: also write the texels' ambient occlusion (1/pi integral V cos) as an RGBA EXR in the "
                "lightmap's layout (A = 1 at covered texels)")->check(path_value());
  s->add_option("--bent-normal-map", a.bent_map,
                "With --lightmap: also write the texels' bent normals (world x, y, z in R, G, B) as an RGBA EXR")
      ->check(path_value());
  s->add_option("--obscurance", a.obscurance,
                "With --lightmap and --obscurance-map: obscurance distance d; an occluder at distance t counts "
                "rho(t) = min(t/d, 1) (Zhukov et al. 1998)")
      ->check(number_range(0.0, 1e30, true, false));
  s->add_option("--obscurance-map", a.obscurance_map, "With --obscurance d: the obscurance map to write (RGBA EXR)")
      ->check(path_value());
}

// --memory-limit and --compress.
void add_memory_options(CLI::App* s, PrecomputeArgs& a) {
  a.memory_limit_opt =
      s->add_option("--memory-limit", a.memory_limit,
                    "The most memory the process may hold, e.g. 8G or 512M (K, M, G, T: powers of 1000; KiB, MiB, "
                    "GiB, TiB: of 1024); default 80% of the machine's memory, shared among the mpirun processes on it. "
                    "Past what the per-vertex arrays need, the bounces' gather records go to a temporary file in "
                    "TMPDIR; the result is the same bits; a limit the plan cannot meet is refused before the work "
                    "(a lightmap's from its atlas, before rasterising it). SH transfer only: not --probes or --basis "
                    "wavelet (docs/PRECOMPUTE.md, \"Memory\")")
          ->check(memory_size_value());
  a.sh_only.push_back(a.memory_limit_opt);
  a.sh_only.push_back(s->add_option("--compress", a.compress,
                                    "Write the transfer compressed by clustered PCA: K clusters x N principal "
                                    "vectors, e.g. 128x8 (prt compress; docs/COMPRESSION.md)")
                          ->check(compress_value()));
  a.compress_weights_opt = s->add_option("--compress-weights", a.compress_weights,
                                         "Bits per weight of --compress: 16 or 32")
                               ->check(int_one_of({16, 32}))
                               ->capture_default_str();
  a.sh_only.push_back(a.compress_weights_opt);
}

// --adaptive sample points and --subdivide.
void add_adaptive_options(CLI::App* s, PrecomputeArgs& a) {
  a.adaptive_opt =
      s->add_option("--adaptive", a.adaptive,
                    "Adaptive sample points: trace a subset of the vertices (with --lightmap, texels) and interpolate the "
                    "rest along the surface "
                    "where probes show interpolation adds at most TOL (relative RMS of the transfer, band-weighted); "
                    "without a value 0.01, and 0.01 x sqrt(1024 / samples) past 1024 samples (docs/PRECOMPUTE.md)")
          ->expected(0, 1)
          ->default_str("")
          ->type_name("[TOL]");
  a.verify_opt = s->add_option("--verify-adaptive", a.aopt.verify_fraction,
                               "With --adaptive: trace this fraction of the interpolated vertices (texels) again and report "
                               "their error against TOL (they keep the traced transfer)")
                     ->check(number_range(0.0, 1.0))
                     ->type_name("FRACTION");
  a.adaptive_any_opt = s->add_flag("--adaptive-any", a.adaptive_any,
                                   "With --adaptive TOL: take a TOL above 1.5x the default (the error may then pass "
                                   "1.1x the full run's)");
  a.subdivide_opt =
      s->add_option("--subdivide", a.subdivide,
                    "For coarse meshes: split the edges whose ends' transfer differs by more than TOL (relative, "
                    "band-weighted: the metric of --adaptive) at their midpoints, round by round, and write the refined "
                    "mesh (--subdivided-mesh) with the transfer for it; with --target-error E, the search's settings "
                    "and, without a value, TOL = E / 2 (docs/PRECOMPUTE.md, \"Subdividing coarse meshes\")")
          ->expected(0, 1)
          ->default_str("")
          ->type_name("[TOL]");
  a.subdivide_max_opt = s->add_option("--subdivide-max-vertices", a.sopt.max_vertices,
                                      "With --subdivide: the most vertices the refined mesh may have (0: 4x the "
                                      "mesh's)")
                            ->check(count_range(0, kMaxSubdivideVertices, "0: 4x the mesh's; a mesh's vertex "
                                                                          "indices are 32-bit"))
                            ->capture_default_str();
  a.subdivided_mesh_opt = s->add_option("--subdivided-mesh", a.subdivided_mesh,
                                        "With --subdivide: where the refined mesh goes, PLY with normals (and "
                                        "colours) (default: the output's name with .ply)")->check(path_value());
}

}  // namespace

Run add_precompute(CLI::App& app) {
  auto a = std::make_shared<PrecomputeArgs>();
  CLI::App* s = app.add_subcommand("precompute", "Precompute per-vertex SH transfer of a mesh (Embree ray tracing)");
  s->footer(
      "Defaults: shadowed, 5 bands (25 coefficients: soft shadows of area lights, 100 bytes/vertex in grey),\n"
      "1024 rays per vertex (the hemisphere half of a 2048-direction spherical Fibonacci set; D3DX's default ray\n"
      "count), 1 bounce (most of the interreflected light at albedo 0.8), albedo 0.8 (light grey paint; 1 would\n"
      "reflect all light). A grey albedo stores one channel. Ctrl-C stops without writing anything.\n"
      "--basis wavelet (shadowed only; --cube-res, default 32, and --threshold, default 1e-2) stores sparse int16\n"
      "Haar coefficients per vertex for all-frequency shadows; relight it with prt relight --terms K.\n"
      "--basis zh (--lobes K, default 4) fits K zonal-harmonic lobes to each vertex's SH transfer, stored in the\n"
      "vertex's own frame: prt relight POSED file.prt ENV relights any pose of the mesh (docs/LDPRT.md).\n"
      "--target-error e --env MAP chooses bands, bounces and samples: the cheapest that reach relative RMS e\n"
      "against a Monte Carlo reference under MAP (docs/REPORT.md).\n"
      "--material glossy also stores per-vertex transfer matrices (Sloan, Kautz & Snyder 2002) for a Phong lobe whose\n"
      "exponent and strength are chosen at run time (prt relight --eye --gloss --specular, prt render, prt view).\n"
      "Memory: --memory-limit (default 80% of the machine's memory) bounds the process; the bounces' gather records\n"
      "past it go to a temporary file in TMPDIR, and the file written is the same bytes at any limit.\n"
      "Many processes: mpirun -np N prt precompute ... splits the vertices over N processes (on one machine or\n"
      "several; each with its own --threads and --memory-limit) and writes the same bytes as one process\n"
      "(docs/PRECOMPUTE.md, \"Memory\" and \"Many processes\").\n"
      "Example: prt precompute models/scene.obj -o scene.prt --mode interreflected --bounces 2\n"
      "         prt precompute bunny.off -o bunny-glossy.prt --material glossy --bands 5\n"
      "         prt precompute bunny.off -o bunny-marble.prt --material subsurface --sss marble --length-scale 400\n"
      "         prt precompute bunny.off -o bunny.prt --target-error 0.02 --env envmaps/forest.exr\n"
      "         prt precompute bunny.off -o bunny.wlt --basis wavelet --cube-res 32\n"
      "         prt precompute models/tube.obj -o tube-zh.prt --basis zh --lobes 4 --bands 6\n"
      "         prt precompute models/room.gltf --lightmap 256x256 --mode interreflected -o room.prt\n"
      "         prt precompute models/room.gltf --probes 16x8x16 -o room-probes.prt\n"
      "         prt precompute models/room.gltf --lightmap 256x256 --mode interreflected --light-bounce --probes "
      "16x8x16 -o room-lights.prt\n"
      "         prt precompute coarse.obj -o fine.prt --subdivide 0.02 --subdivided-mesh fine.ply");
  s->add_option("MESH", a->mesh, "Mesh file: OBJ, PLY, OFF, STL, glTF/GLB (with --lightmap: a scene, glTF/GLB or OBJ)")
      ->check(path_value())
      ->required();
  s->add_option("-o,--output", a->output, "Transfer file to write (docs/FORMAT.md)")->check(path_value())->required();
  add_basis_options(s, *a);
  add_transfer_options(s, *a);
  add_lightmap_options(s, *a);
  add_memory_options(s, *a);
  add_adaptive_options(s, *a);
  s->add_flag("-q,--quiet", a->quiet, "No progress or summary on stderr");
  return [a] { return run_precompute(*a); };
}

}  // namespace prt::cli
