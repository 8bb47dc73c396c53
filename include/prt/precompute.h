// prt/precompute.h - computing transfer with Embree (prt::precompute): SH
// transfer vectors (Sloan, Kautz & Snyder 2002) and all-frequency wavelet
// transfer (Ng, Ramamoorthi & Hanrahan 2003). The results are prt::scene's
// data types (prt/transfer.h, prt/wavelet_transfer.h), written and read by
// prt/transfer_io.h and relit on the CPU or the GPU without Embree.
#pragma once

#include <prt/communicator.h>
#include <prt/mesh.h>
#include <prt/point_tracer.h>
#include <prt/probes.h>
#include <prt/progress.h>
#include <prt/compressed_transfer.h>
#include <prt/cpca.h>
#include <prt/lightmap.h>
#include <prt/scene.h>
#include <prt/transfer.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>

#include <glm/vec3.hpp>

#include <array>
#include <functional>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

namespace prt {

namespace detail {
class RayScene;
}  // namespace detail

// ---- SH transfer (docs/PRECOMPUTE.md) -----------------------------------------
// The ranges of the options every transfer computation takes (prt precompute's
// --bands, --samples, --bounces, --threads take the same; the validators
// below refuse the rest, so a C++ or Python caller gets the command's rules).
// Bands: prt render and prt view draw at most 16 (kMaxRenderBands), and
// transfer accuracy (the float basis table, docs/PERFORMANCE.md's error
// tables, prt report's grid) is measured up to 16 (docs/CONVENTIONS.md,
// "Band counts").
inline constexpr int kMaxTransferBands = 16;
inline constexpr int kMaxSamples = 1 << 24;  // rays per vertex (prt reference: paths per vertex)
inline constexpr int kMaxBounces = 64;       // albedo 0.9: the 65th bounce would add 0.9^64 = 0.1% of the direct light
inline constexpr int kMaxThreads = 1024;     // worker threads (0: every core)
// The lights' bounce operator's source patches, in spacings of the points
// (TransferOptions::light_bounce_patch; docs/LIGHTS.md "Bounce" measures it).
inline constexpr double kLightBouncePatchSpacings = 1.0;
inline constexpr double kLightBounceRatio = 1.0;
// Far hits gathered by clusters of receivers this many levels finer than
// their source patch (TransferOptions::light_bounce_clusters).
inline constexpr int kLightBounceClusters = 2;

struct TransferOptions {
  TransferMode mode = TransferMode::Shadowed;
  int bands = 5;                 // 1 to kMaxTransferBands (docs/CONVENTIONS.md, "Band counts")
  int samples = 1024;            // ~rays per vertex: 2*samples directions over the sphere, 1 to kMaxSamples
  int bounces = 1;               // interreflected only; 0 = shadowed; at most this many (kMaxBounces)
  // Interreflected: stop adding bounces once one adds less than this fraction
  // of the direct transfer's energy (mean |T| over all coefficients; see
  // Transfer::bounce_energy); Transfer::bounces says how many were computed.
  // 0: always `bounces`.
  double bounce_tolerance = 0;
  glm::vec3 albedo{1.0f};        // used when the mesh has no colours or vertex_colors is false
  bool vertex_colors = false;    // use the mesh's per-vertex colours as albedo
  int threads = 0;               // 0: all cores; at most kMaxThreads
  std::uint64_t seed = 1;        // rotates the direction set; same seed, same inputs -> same bits
  double offset = 0;             // ray origin offset; 0: 1e-4 x the mesh's bounding-box diagonal
  // Also the glossy transfer matrices (prt/transfer.h, Transfer::glossy), from
  // the same rays; shadowed or interreflected, bands at most kMaxGlossyBands.
  bool glossy = false;
  // Lightmaps only (compute_lightmap_transfer): also each texel's directional
  // rows, rows k = 0..3 of its glossy matrix M_p (the L1 of its incident
  // radiance: Transfer::glossy_rows = kDirectionalRows), from the same rays;
  // shadowed or interreflected, 2 bands or more
  // (prt/lightmap_directional.h; docs/LIGHTMAPS.md "Directional lightmaps").
  bool directional = false;
  // The first pass's rays traced by this tracer instead of Embree on the
  // CPU's threads (prt precompute --device gpu; prt/point_tracer.h,
  // prt/gpu_tracer.h): the same rays, each taken and each point finished
  // as on the CPU. A shadowed diffuse transfer takes the tracer's sums
  // (PointTracer::trace); everything else its closest hits (trace_hits):
  // interreflection's gather, glossy matrices, directional rows, the
  // transmitted kernel. One process (prt::Error under a communicator of
  // more). The lights' bounce operator's probe rows stay on Embree.
  // nullptr: the CPU.
  const PointTracer* tracer = nullptr;
  // The most memory the process may hold while computing, in bytes (0: no
  // limit; docs/PRECOMPUTE.md, "Memory"). What the result needs whatever the
  // limit (the ray scene, the per-vertex arrays) comes first; the gather
  // records of the bounces and the glossy hits stay in memory as far as the
  // rest allows and go to a temporary file (TMPDIR) past it. The result is
  // the same bits at any limit. A limit below TransferMemory::minimum throws
  // prt::Error before any ray is traced.
  std::size_t memory_limit = 0;
  // The most bytes of those records kept in memory, whatever the limit
  // leaves (the rest go to the temporary file); for tests and for a caller
  // that wants memory for something else.
  std::size_t records_in_memory_max = std::numeric_limits<std::size_t>::max();
  // The processes sharing the job (prt/communicator.h): this one traces its
  // range of the vertices; rank 0 returns the whole transfer, the others an
  // empty one. nullptr: this process alone.
  const Communicator* comm = nullptr;
  // Interreflected with bounces: also keep the gather as the lights' bounce
  // operator (Transfer::light_bounce, prt/light_bounce.h; docs/LIGHTS.md
  // "Bounce"), its finest source patches cells of `light_bounce_patch` world
  // units a side (0: kLightBouncePatchSpacings times the points' mean
  // spacing: a lightmap's texel size, a mesh's mean edge length), a hit at
  // distance d merged into the coarsest patch of cell at most
  // light_bounce_ratio x d, and received by the point's patch
  // light_bounce_clusters levels finer than that (prt::link_clusters; -1:
  // every point gathers all its own hits). One process.
  bool light_bounce = false;
  double light_bounce_patch = 0;
  double light_bounce_ratio = kLightBounceRatio;
  int light_bounce_clusters = kLightBounceClusters;
  // With light_bounce: the operator's receivers include the probes of
  // prt::probe_grid(mesh, light_bounce_probes) (LightBounce::ProbeRows;
  // prt precompute --lightmap WxH --light-bounce --probes NXxNYxNZ); 0 0 0:
  // none.
  std::array<int, 3> light_bounce_probes{0, 0, 0};
  // > 0: each direction weighted by the Fresnel transmittance into a
  // dielectric of this relative index (prt/subsurface.h's
  // fresnel_transmittance; 1 to 3), S_k = (1/pi) int V T(eta, cos) cos+ Y_k:
  // the irradiance transmitted into a translucent surface, over pi
  // (docs/SUBSURFACE.md). Shadowed, or interreflected with between_bounces;
  // neither glossy nor a light-bounce operator; every vertex's row is
  // stored (none is analytic), and its AO is the transmitted irradiance's
  // (1 - the occluded part of K_0). 0: the cosine alone.
  double transmission_eta = 0;
  // With transmission_eta, at the mesh's vertices (compute_transfer): the
  // surface integral of a translucent material (compute_subsurface_transfer),
  // applied in place to the direct rows and, interreflected, to each
  // bounce's rows before they are summed and gathered again. The rows are
  // every vertex's, three channels (the transfer is RGB when this is set),
  // each E_t / pi of its light; it leaves each the exit radiance's row.
  // Under mpirun every rank calls it on the same rows (rank 0 alone when
  // shadowed).
  std::function<void(std::vector<float>& rows)> between_bounces;
  // When set, compute_transfer fills it with its plan and what its records
  // took (TransferMemory below).
  struct TransferMemory* memory_report = nullptr;
};

// What compute_transfer holds for a mesh and options, in bytes, on the
// calling rank: `base` the process before it starts (resident now: the
// mesh, libraries), `fixed` what it adds whatever the limit (the ray
// scene's estimate, per-vertex arrays, the output), `minimum` the smallest
// memory_limit that works (base + fixed + the smallest block of vertices),
// `per_vertex_records` the gather records and glossy hits a vertex may need
// at most; after a run, `block` the vertices per block of the first pass and
// the bytes of records it kept in memory and wrote to the temporary file.
struct TransferMemory {
  std::size_t base = 0, fixed = 0, minimum = 0, per_vertex_records = 0;
  std::size_t block = 0;
  std::uint64_t records_in_memory = 0, records_spilled = 0;
};
TransferMemory transfer_memory(const Mesh& mesh, const TransferOptions& options);

// This process's resident memory now, in bytes (Linux; 0 where unknown).
std::size_t resident_memory();

// The default memory limit: 80% of the machine's memory (or of the cgroup's
// limit, when lower), shared among `processes_here` processes on it.
std::size_t default_memory_limit(int processes_here = 1);

// ---- transfer at other points than the vertices ---------------------------------
// Points on or near the mesh's surface (a lightmap's texels, probes): each
// with a unit normal (zero: no transfer) and an albedo in [0, 1] (none given:
// TransferOptions::albedo for all).
struct SamplePoints {
  std::vector<glm::vec3> positions, normals, albedo;
};

// The transfer at the points, as compute_transfer computes it at vertices
// (the same direction set, offsets and sums), split over options.comm's
// ranks and traced in blocks under options.memory_limit alike. The mesh
// occludes them and, interreflected, lights them: with B bounces the mesh's
// vertices are computed first with B - 1 (compute_transfer, their colours
// with vertex_colors), and each point gathers their total once from its
// rays' front hits, so the points hold bounces 1..B of the same light paths
// (to float rounding: the vertices' sums are grouped differently). The
// result's `vertices` is the number of points, with a row for every point
// in their order (no analytic rows dropped: relight() would evaluate those
// from the mesh's normals); no bounce energies. Glossy is refused. Throws prt::Error for a point out of
// range, a normal neither unit nor zero, or an albedo outside [0, 1].
Transfer compute_point_transfer(const Mesh& mesh, const SamplePoints& points, const TransferOptions& options,
                                const Progress& progress = {});

// ---- lightmaps (prt/lightmap.h; docs/LIGHTMAPS.md) ----------------------------
// Moves the texel samples that lie inside or behind geometry (a floor texel
// under a wall standing on it, a wall texel below the floor it goes through)
// to the geometry's visible side: 8 rays along the surface from each sample,
// 1.5 texels long; the nearest back face one hits is stepped past (the sample
// moves along its own surface). What production bakers do so that such
// texels do not leak darkness (or light) into their visible neighbours.
// Returns how many moved. `offset` 0: default_ray_offset.
std::size_t move_texels_out_of_geometry(const Mesh& mesh, LightmapTexels& texels, double offset = 0);

// The SH transfer of every covered texel, as compute_transfer computes it at
// vertices (options.mode, bands, samples, seed, offset, memory_limit, comm;
// no glossy), each texel with its own albedo (one channel when all are the
// same grey). Interreflected: the texels gather their bounces from each
// other (a front hit takes the transfer of the texel under its lightmap UV),
// as vertices gather from vertices. Texels none of whose rays hit anything
// are analytic (no row). Rank 0 returns the whole transfer, the others an
// empty one.
LightmapTransfer compute_lightmap_transfer(const Scene& scene, const LightmapTexels& texels,
                                           const TransferOptions& options, const Progress& progress = {});

// Before rasterising a width x height atlas of `scene`'s UV set `uv_set`
// (lightmap_texels takes 25 bytes a texel of the atlas, seconds for a large
// one): throws prt::Error ("--memory-limit ...: too small") when
// options.memory_limit (0: none) is below the least the transfer's plan will
// need: the process now, the texels' samples (56 bytes each) and atlas map
// (4 bytes a texel), and compute_lightmap_transfer's arrays and ray scene for
// lightmap_texels_at_least texels (adaptive: for the texels alone, its
// batches traced later). A limit refused here is one that plan refuses after
// the rasterising; one passed here may still be refused there (the texels
// are more than their UV area, the albedo may take three channels).
// `albedo` (non-null): the texels' albedo (--albedo), else the scene's.
void check_lightmap_memory(const Scene& scene, int width, int height, int uv_set, const TransferOptions& options,
                           bool adaptive = false, const glm::vec3* albedo = nullptr);

// Obscurance (Zhukov, Iones & Kronin 1998; the seed's definition) at points:
// W = (1/pi) integral rho(t(w)) max(n.w, 0) dw with rho(t) = min(t / d, 1)
// for an occluder at distance t (1 where the ray escapes), from the
// direction set of `samples` and `seed` (as the transfer's rays). 1: nothing
// within d. As d grows W tends to the ambient occlusion kappa_A (every
// occluder counts fully); a small d keeps only contact shadows.
// Throws prt::Error for d <= 0 or not finite.
std::vector<float> point_obscurance(const Mesh& mesh, std::span<const glm::vec3> positions,
                                    std::span<const glm::vec3> normals, double distance, int samples = 1024,
                                    std::uint64_t seed = 1, double offset = 0);

// Glossy matrices have bands^4 entries: 12 bands are 83 KB per vertex (mono,
// shadowed), far past any GPU's per-frame budget (docs/GLOSSY.md).
inline constexpr int kMaxGlossyBands = 12;

// Computes the transfer. Throws prt::Error on bad options. Deterministic:
// the same mesh, options and thread count give the same bits.
Transfer compute_transfer(const Mesh& mesh, const TransferOptions& options, const Progress& progress = {});

// ---- adaptive sample points (docs/PRECOMPUTE.md, "Adaptive sample points") ----
// compute_transfer traces every vertex; a dense scan has far more vertices
// than its transfer has detail. compute_adaptive_transfer traces a nested
// subset (Poisson-disk levels, coarse to fine), predicts the rest of each
// level from the traced vertices around them along the surface, traces a
// few probes of every patch of predictions and the whole patch where the
// probes' error exceeds the tolerance.
struct AdaptiveOptions {
  // TOL: the relative RMS error interpolation may add to a patch's transfer
  // (band-weighted: relit radiance under typical lighting; docs/PRECOMPUTE.md).
  // 0: default_adaptive_tolerance(samples). Any value in (0, 1).
  double tolerance = 0;
  double probe_fraction = 1.0 / 32;  // of each patch's predictions traced to check it, (0, 1]
  int min_probes = 3;                // probes per patch at least
  // Trace this fraction of the interpolated vertices once more at the end
  // and report their interpolation error (AdaptiveReport::verified...); the
  // verified vertices keep the traced transfer. [0, 1].
  double verify_fraction = 0;
  std::uint64_t seed = 1;  // which vertices probe and verify
};

// The default TOL for `samples` rays: 0.01 at 1024 and fewer, falling as
// the sampling noise (1 / sqrt(samples)) past 1024, so that interpolation
// adds well under the error the full run already has (docs/PRECOMPUTE.md
// measures 1.00-1.03x the full run's error against prt reference at it).
double default_adaptive_tolerance(int samples);
// The largest TOL prt precompute --adaptive takes without --adaptive-any:
// 1.5x the default, where the measured error stays within 1.1x the full run's.
double max_adaptive_tolerance(int samples);

// What an adaptive run did: vertices traced (probes, failing patches and
// the levels' own) and interpolated, per level; the verification's error
// (the metric of TOL) over the verified vertices.
struct AdaptiveReport {
  double tolerance = 0;
  int levels = 0;
  std::size_t vertices = 0, traced = 0, interpolated = 0, probes = 0, patches = 0, failed_patches = 0;
  // Vertices traced summed over every pass (interreflected: the choice's,
  // then the chosen ones' again), each about `samples` rays; compute_transfer's is `vertices`.
  std::size_t traces = 0;
  std::size_t verified = 0, verified_over = 0;  // verified vertices; how many above TOL
  double verified_rms = 0, verified_p95 = 0, verified_max = 0;
  double seconds_selecting = 0, seconds_tracing = 0, seconds_predicting = 0;
};

// The transfer of compute_transfer (same options, rows, file layout), with
// Transfer::interpolated marking the vertices interpolated. Shadowed: the
// levels' batches are the result. Interreflected: the vertices are chosen
// on the shadowed transfer, then the chosen ones traced again with the
// bounces, gathering from every vertex (the others interpolated at each
// bounce). Glossy: the matrices at the traced vertices are traced, the rest
// interpolated (about each vertex's hemisphere product matrix). Unshadowed
// traces nothing: every vertex is computed. Composes with memory_limit and
// comm (every rank runs the same choices; each batch is split over the ranks).
// Throws prt::Error on bad options.
Transfer compute_adaptive_transfer(const Mesh& mesh, const TransferOptions& options, const AdaptiveOptions& adaptive,
                                   const Progress& progress = {}, AdaptiveReport* report = nullptr);

// The same among a lightmap's texels (compute_lightmap_transfer's rows): the
// texels are the sample points, neighbours those next to each other in the
// atlas (8 around) within two texels' world size of each other, so one
// chart's texels predict each other and never another chart's (a UV seam is
// walked by neither side: each side is traced where its own chart does not
// reach). Interreflected: the bounces gather from every texel, the
// interpolated ones too. Interpolated texels are marked in
// out.transfer.interpolated; AdaptiveReport counts texels as vertices.
LightmapTransfer compute_adaptive_lightmap_transfer(const Scene& scene, const LightmapTexels& texels,
                                                    const TransferOptions& options, const AdaptiveOptions& adaptive,
                                                    const Progress& progress = {}, AdaptiveReport* report = nullptr);

struct ZhFitOptions {
  int lobes = 4;
  int rounds = 12;  // zh::FitOptions::rounds
  int threads = 0;  // 0: all
};

// Local deformable PRT (prt/zh_transfer.h, docs/LDPRT.md): fits
// options.lobes lobes to every stored row of `t` (computed for the
// rest pose `mesh`, check_matches): the axes on the rows' channel sum (one
// channel: the row), each channel's coefficients by least squares for those
// axes, the axes then moved into the vertex's rest frame. A vertex without a
// frame stores zero lobes (its transfer is zero: no normal). `progress` (may
// be empty) is called with rows done and total; returning false cancels
// (prt::Error("cancelled"), as compute_transfer). Throws prt::Error for a
// glossy transfer, bands over zh::kMaxBands or lobes out of range.
ZhTransfer fit_zh_transfer(const Transfer& t, const Mesh& mesh, const ZhFitOptions& options,
                           const Progress& progress = {});

// The flat BVH of `mesh`'s triangles a GPU traverses (prt/point_tracer.h),
// built by Embree's rtcBuildBVH (SAH, leaves of at most `max_leaf`
// triangles, 1 to kFlatBvhMaxLeaf). Degenerate triangles (no area) are left
// out, as Embree leaves them out of the CPU's scene. Throws prt::Error for a
// tree deeper than kFlatBvhMaxDepth or a bad max_leaf.
FlatBvh build_flat_bvh(const Mesh& mesh, int max_leaf = 4);

// Reference: the shadowed glossy transfer matrices M_p (nc x nc row-major,
// double, nc = bands^2) of the listed vertices only, traced as
// compute_transfer traces them (direction set of options.seed, offset) with
// options.samples; for measuring how far the stored matrices' sampling is
// from exact (many samples here, at a few vertices). Zero for a vertex
// without a normal. Throws prt::Error on bad options or an index out of range.
std::vector<double> glossy_vertex_matrices(const Mesh& mesh, const TransferOptions& options,
                                           std::span<const std::uint32_t> vertices);

// ---- compression (prt/cpca.h, prt/compressed_transfer.h; docs/COMPRESSION.md) ----
// How clustered PCA weighs a signal's values (docs/COMPRESSION.md "The
// metric"). Plain: as they are (the least squared error of the rows).
// Band: each band block (diffuse: a channel's band l; glossy matrices: the
// block of output band l1 and input band l2, per channel) scaled by the
// inverse square root of its root mean square over the rows: halfway (in
// logarithm) between the rows as they are and every band block at unit
// mean square, so that the fit spends more of its error on the weak bands
// without giving up the strong ones, and the relit error moves less from
// one lighting to another (docs/COMPRESSION.md measures both ends).
// The stored means and bases are the fit's, scaled back (orthonormal in the
// metric, not in the rows' own values).
enum class CompressionMetric { Plain, Band };
const char* compression_metric_name(CompressionMetric m);

// The ranges of CompressOptions (prt compress's --clusters, --pca,
// --glossy-clusters, --glossy-pca and --iterations take the same;
// compress_transfer and compress_signal refuse the rest).
inline constexpr int kMaxClusters = 1 << 24;
inline constexpr int kMaxVectors = 1 << 20;
inline constexpr int kMaxCompressIterations = 1000;

struct CompressOptions {
  int clusters = 64;        // K, 1 to kMaxClusters (at most the stored rows; fewer rows: one cluster per row)
  int vectors = 8;          // N, 0 to kMaxVectors (capped at each signal's dimension)
  // The glossy matrices' own K and N (0 and -1: clusters and vectors above).
  int glossy_clusters = 0, glossy_vectors = -1;
  int iterations = 20;      // 1 to kMaxCompressIterations
  std::uint64_t seed = 1;
  int weight_bits = 32;     // 32 (float) or 16 (ClusteredSignal::weight_bits)
  Progress progress;        // per round of each fit (CpcaOptions::progress; phase "coefficients" or "glossy matrices")
  CompressionMetric metric = CompressionMetric::Plain;
};

// The per-value scales of `metric` for the rows of t's coefficients (glossy
// false: stride() values) or glossy matrices (glossy_stride()): each value
// is multiplied by its scale before the fit. Plain: all 1. Band: 1 / the
// square root of the root mean square of the value's band block over the
// stored rows (1 for an all-zero block); a packed symmetric matrix's
// off-diagonal values also by sqrt(2) (they stand for two entries).
std::vector<double> metric_scales(const Transfer& t, bool glossy, CompressionMetric metric);

// Clustered PCA of the transfer's stored rows (all channels of a row as one
// signal) and, when it has them, of its glossy matrices, each fitted on its
// own. The direct part of an interreflected transfer is dropped. Throws
// prt::Error for bad options.
CompressedTransfer compress_transfer(const Transfer& t, const CompressOptions& options);
// One signal: `rows` (a multiple of dim values) fitted with options.clusters
// and options.vectors (capped at the rows and at dim), weights of
// options.weight_bits; `phase` names it to options.progress.
// `scales` (empty or dim values): the metric (metric_scales), which
// options.metric then does not choose.
ClusteredSignal compress_signal(std::span<const float> rows, std::size_t dim, const CompressOptions& options,
                                const char* phase = "rows", std::span<const double> scales = {});
// A fit of rows scaled by `scales` (empty: 1) as a signal: means and bases
// scaled back, the first `vectors` (<= fit.vectors) of each cluster kept,
// weights quantised to `weight_bits`. compress_signal's last step; the
// compression search's truncation of a fit to fewer vectors.
ClusteredSignal signal_from_fit(const Cpca& fit, int vectors, int weight_bits, std::span<const double> scales = {});

// ---- wavelet transfer (docs/WAVELETS.md) -------------------------------------------
struct WaveletOptions {
  int cube_res = 32;          // face size r: power of two in [2, 256]
  double threshold = 1e-2;    // relative L2 truncation error per vertex, in [0, 1) (see WaveletTransfer;
                               // docs/WAVELETS.md: 1e-2 moves no measured error by more than 4e-4, stores 34% less than 1e-3)
  glm::vec3 albedo{1.0f};     // used unless vertex_colors; [0, 1] per channel
  bool vertex_colors = false; // use the mesh's per-vertex colours as albedo (clamped to [0, 1])
  int threads = 0;            // 0: all cores
  double offset = 0;          // ray origin offset; 0: detail default (1e-4 x bounding-box diagonal)
  // The processes sharing the job (as TransferOptions::comm): each traces
  // its range, rank 0 returns the whole transfer, the others an empty one.
  const Communicator* comm = nullptr;
  // The visibility traced by this tracer instead of Embree on the CPU's
  // threads (as TransferOptions::tracer; prt/point_tracer.h,
  // prt/gpu_tracer.h): the same rays (PointTracer::trace_hits along the
  // cube's texel directions), a texel visible where its ray hits nothing,
  // each vertex then compressed as on the CPU. The tracer's BVH is the
  // occluders' (build_flat_bvh). One process (refused with prt::Error under
  // a comm of more than one). nullptr: the CPU.
  const PointTracer* tracer = nullptr;
};

// Traces one occlusion ray per texel above the horizon of every vertex (from
// p + offset n, tnear = offset), builds t, transforms, thresholds, quantises
// and transposes. Vertices with a zero normal get no coefficients. TBB over
// blocks of vertices; deterministic (same bits for any thread count).
// Progress: phase "rays" ("rays (GPU)" with a tracer), cancellable (throws
// prt::Error("cancelled")).
// Throws prt::Error on bad options (cube_res, threshold, albedo, offset,
// threads, vertex_colors without colours, more than 2^32 - 1 vertices, a
// tracer under more than one process).
WaveletTransfer compute_wavelet_transfer(const Mesh& mesh, const WaveletOptions& options,
                                         const Progress& progress = {});

// The same at other points (a lightmap's texels: texel_points()): the
// points' positions, normals and (vertex_colors) colours, traced against
// `occluders`. mesh_hash is the occluders'; a caller with another identity
// for the points (a lightmap's scene hash) sets its own.
WaveletTransfer compute_wavelet_at_points(const Mesh& occluders, const Mesh& points, const WaveletOptions& options,
                                          const Progress& progress = {});

// Reference: the dense texel-domain transfer t_i (no albedo, double) of the
// listed vertices, [k][6 r^2], traced exactly as compute_wavelet_transfer
// does (by options.tracer when set). B_v = rho_v sum_i t_i l_i is the direct
// per-texel relighting.
std::vector<double> wavelet_texel_transfer(const Mesh& mesh, const WaveletOptions& options,
                                           std::span<const std::uint32_t> vertices);

// ---- probe volumes (prt/probes.h; docs/PROBES.md) ----------------------------------

struct ProbeOptions {
  TransferMode mode = TransferMode::Shadowed;  // shadowed or interreflected
  int bands = 3;              // of each probe's incident light (1 to 8)
  int cube_res = 64;          // visibility cube face size at its finest (power of two, 4 to 64)
  int depth_res = 8;          // octahedral depth moments (2 to 32)
  int rays_per_texel = 16;    // a k x k grid of rays in each texel of the base cube (cube_res / 4): 1, 4, 9, ... 64
  int bounces = 1;            // interreflected: diffuse bounces (1 to 8)
  int bounce_bands = 6;       // interreflected: environment bands the bounce matrices take (1 to 16, whatever the mode)
  bool override_albedo = false;
  glm::vec3 albedo{0.8f};     // with override_albedo: every surface's (else the scene's materials)
  std::uint64_t seed = 1;     // jitters the rays inside the texels and the bounce directions
  int threads = 0;            // 0: all cores; at most kMaxThreads
  double offset = 0;          // ray offset off surfaces; 0: 1e-4 x the scene's diagonal
  // The probes' rays traced by this tracer (PointTracer::trace_rays; prt/gpu_tracer.h's
  // GL compute tracer) instead of Embree on the CPU's threads; nullptr: Embree.
  // Either way the same code draws, takes and sums the same rays, a wavefront
  // of a block of probes at a time (its base rays, each bounce of its paths,
  // each stage of its refinement), so the volume differs from the CPU's only
  // where a ray is seen differently (grazing a triangle's edge; the probes'
  // placement off surfaces stays Embree's point query). The tracer's BVH is
  // the scene mesh's (build_flat_bvh(scene.mesh)); it must outlive the call.
  const PointTracer* tracer = nullptr;
};

// Traces every probe of `grid` (probe_grid(scene.mesh, dims)) against the
// scene: per probe 6 (r/4)^2 k^2 rays jittered in the texels of a base
// cube of face r/4, and again one ray per finest texel (16 per base
// texel) where a base texel is neither all visible nor all blocked. A probe
// lying on a surface (a hit nearer than 2% of the smallest spacing) is
// moved to 4% off it, on its front side (ProbeTransfer::positions); a probe
// whose rays strike back faces more often than not is Invalid; one whose
// every ray escapes is Sky. Interreflected: each front-face hit continues as
// a diffuse path (cosine-weighted, one direction per hit, `bounces` deep)
// whose escape adds albedo x Y_k(w1) omega x Y_j(w2) to the bounce matrix.
// Deterministic for any thread count: every random draw comes from a
// generator of its own purpose (per probe and base texel, bounce path,
// finest texel), whatever order the wavefronts trace the rays in.
// Progress: phase "probes"; cancellable (prt::Error("cancelled")).
ProbeTransfer compute_probe_transfer(const Scene& scene, const ProbeGrid& grid, const ProbeOptions& options,
                                     const Progress& progress = {});

// Exact segment visibility between query points and probes, traced against
// the scene (what prt relight --at weights the probes with; prt/probes.h
// ProbeVisibility): the fraction of 5 segments from p to the probe's
// position and to 4 points around it (a tenth of the smallest spacing
// away, perpendicular to the segment) that nothing blocks. Thread-safe.
class ProbeOcclusion {
 public:
  ProbeOcclusion(const Mesh& mesh, const ProbeGrid& grid);
  ~ProbeOcclusion();
  ProbeOcclusion(const ProbeOcclusion&) = delete;
  ProbeOcclusion& operator=(const ProbeOcclusion&) = delete;
  double operator()(const glm::dvec3& probe, const glm::dvec3& p) const;

 private:
  std::unique_ptr<detail::RayScene> rays_;
  double spread_ = 0, offset_ = 0;
};


// ---- subdividing coarse meshes (docs/PRECOMPUTE.md, "Subdividing coarse meshes") ----
// The converse of adaptive sample points (D3DX's ComputeDirectLightingSHAdaptive):
// a coarse mesh's per-vertex transfer cannot hold a shadow edge that crosses
// a big triangle. subdivide_for_transfer splits the edges whose two ends'
// transfer differs by more than the tolerance at their midpoints, round by
// round, and returns the refined mesh with its transfer.
struct SubdivideOptions {
  // Split an edge whose ends' transfer differs by more than this: the
  // band-weighted row difference sqrt(sum_c sum_k w_l (a - b)^2 / channels),
  // w_l = (l + 1)^-2, relative to the RMS over the input's vertices of
  // sqrt(sum_c sum_k w_l a^2 / channels) (the metric of AdaptiveOptions'
  // tolerance). In (0, 1).
  double tolerance = 0.02;
  std::size_t max_vertices = 0;  // cap on the refined mesh's vertex count; 0: 4x the input's
  int max_rounds = 8;            // rounds of splitting, at least 1
};

// What subdivide_for_transfer did: the vertex counts, the edges split (one
// new vertex each), the rounds that split any, whether the cap stopped it
// (edges over the tolerance were left), and its time.
struct SubdivideReport {
  std::size_t input_vertices = 0, vertices = 0, split_edges = 0;
  int rounds = 0;
  bool capped = false;
  double seconds = 0;
};

struct Subdivided {
  Mesh mesh;
  Transfer transfer;
};

// Each round: the transfer of the current mesh; the edges over the
// tolerance, split at their midpoints, largest difference first, until the
// next split would pass max_vertices (then `capped`, and no further round).
// A triangle with 1, 2 or 3 split edges becomes 2, 3 or 4 (winding kept; two
// split edges: the shorter diagonal of the quad left). An edge shared by
// triangles (by position: vertices a seam duplicates count as one edge) is
// split in all of them. A new vertex: the edge's midpoint, the normalised
// mean of its ends' normals, their mean colour, and per corner the mean UV
// (Mesh::corner_uvs). Every normal of the refined mesh is one make_mesh
// keeps as it is (within 2 ulps of the input's or the mean), so the mesh
// written and loaded again is the transfer's. It stops when no edge exceeds
// the tolerance, at the cap or after max_rounds. The transfer returned is
// compute_transfer(mesh, options) of the refined mesh, the same bits; when
// the report says neither capped nor max_rounds rounds, no edge of it
// exceeds the tolerance (edges with a vertex without a normal are not
// measured). Shadowed: new vertices are traced alone each round (the
// geometry rays hit is the input's), the whole refined mesh when they show
// no edge over the tolerance and at the end; interreflected and unshadowed:
// the whole mesh each round. Deterministic (the same bits for any thread
// count); with options.comm every rank makes the same choices, rank 0
// returns the transfer (the others an empty one) and every rank the mesh.
// Throws prt::Error on bad options (compute_transfer's, a tolerance outside
// (0, 1), max_vertices below the input's vertex count, max_rounds < 1).
Subdivided subdivide_for_transfer(const Mesh& mesh, const TransferOptions& options, const SubdivideOptions& s,
                                  const Progress& progress = {}, SubdivideReport* report = nullptr);

}  // namespace prt
