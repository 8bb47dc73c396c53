// prt/report.h - speed against error on one model and map: the settings grid
// behind `prt report` (docs/REPORT.md).
//
// Each setting is precomputed for the whole mesh (timed), relit on the CPU
// (timed per frame: rotation of the lighting plus the per-vertex sums, or the
// wavelet frame: resample, Haar, K terms, sparse sum), sized (the bytes its
// transfer file takes) and compared with the ground truth on an ErrorSet
// (prt/accuracy.h). Four one-dimensional sweeps around a base setting:
//   bands    SH bands at `bands_samples` samples, shadowed
//   samples  samples per vertex at `samples_bands` bands, shadowed; each row
//            also gives its error against the sweep's largest sample count
//            at the same bands (`self_rms`: the sampling error alone, which
//            the truncation error does not hide)
//   bounces  0 (shadowed) .. n interreflection bounces, against an
//            interreflected reference with `truth_bounces` bounces
//   terms    wavelet K (one precompute at `cube_res`, `threshold`)
//   glossy   glossy transfer (docs/GLOSSY.md) at `glossy_bands` x Phong
//            exponents `glossy_gloss`, shadowed, the glossy part alone seen
//            from `glossy_eye`, against a glossy reference per exponent; each
//            row also gives the intrinsic SH error: the same SH formula with
//            the matrices traced at `glossy_exact_samples` at the error
//            vertices (exact up to their own, much smaller, sampling error)
//   compression  clustered PCA (prt/compressed_transfer.h) of the shadowed
//            transfer at `compression_bands` (`bands_samples` samples; the
//            bands sweep's own when it has that band count) and, when the
//            glossy sweep runs at `compression_glossy_bands`, of that glossy
//            transfer: per K x N its bytes, its fit time, its relit error
//            against the uncompressed transfer (compression_error: under the
//            map; glossy: over `compression_eyes` eye_ring views), CPU
//            relight and, with a `frame_timer`, GPU frame time next to the
//            uncompressed transfer's. Rows keep the K and N asked for capped
//            at the stored rows and the row length; a cell that caps to an
//            earlier one is left out.
#pragma once

#include <prt/accuracy.h>
#include <prt/compressed_transfer.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/transfer.h>

#include <glm/vec3.hpp>

#include <cmath>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace prt {

// Median GPU frame time in ms of `t`, or of its compression `c` when not
// null (prt::Renderer in prt report; analysis does not link the runtime):
// the SH lighting `light` (t.bands^2 coefficients, unrotated) rotated anew
// each frame, then the frame drawn; glossy transfers with the lobe e =
// `gloss`, rho_s = `specular`. NaN when frames cannot be timed here (no GL:
// the caller says why).
using FrameTimer = std::function<double(const Transfer& t, const CompressedTransfer* c,
                                        std::span<const glm::dvec3> light, double gloss, double specular)>;

struct ReportOptions {
  std::vector<int> bands;           // bands sweep
  int bands_samples = 1024;
  std::vector<int> samples;         // samples sweep
  int samples_bands = 16;
  std::vector<int> bounces;         // bounces sweep (0 = shadowed)
  int bounce_bands = 5, bounce_samples = 1024;
  std::vector<int> terms;           // wavelet K sweep (empty: none)
  std::vector<int> glossy_bands;    // glossy sweep (empty: none), 1 to kMaxGlossyBands
  std::vector<double> glossy_gloss; // its Phong exponents
  int glossy_samples = 1024;        // the stored matrices' samples
  int glossy_exact_samples = 16384; // the intrinsic error's matrices
  int truth_glossy_samples = 65536; // glossy reference samples per vertex
  // The eye: NaN (default) puts it where prt render's default camera is
  // (in front of the mesh along +Z, framing its bounding sphere).
  glm::dvec3 glossy_eye{NAN, NAN, NAN};
  // Compression sweep (empty clusters or vectors: none): K x N, each K capped
  // at the stored rows, each N at the row length (0 allowed: the means alone).
  std::vector<int> compression_clusters;
  std::vector<int> compression_vectors;
  int compression_bands = 8;          // the diffuse transfer's bands (1 to 16)
  int compression_glossy_bands = 4;   // the glossy sweep's transfer compressed too (0 or not among glossy_bands: none)
  int compression_iterations = 4;     // CompressOptions::iterations (rounds of the fit; it stops earlier when settled)
  int compression_weight_bits = 16;   // 16 or 32
  int compression_eyes = 4;           // glossy error: eye_ring(mesh, compression_eyes); the lobe e is the middle
                                      // of glossy_gloss, rho_s 0.5 (Renderer's default), with the diffuse part
  FrameTimer frame_timer;             // null: no frame times (NaN)
  int cube_res = 32;
  double threshold = 1e-2;
  glm::vec3 albedo{0.8f};
  std::size_t truth_vertices = 2048;  // ErrorSet size
  int truth_samples = 131072;         // reference samples per vertex (shadowed)
  int truth_bounce_samples = 65536;   // the same, interreflected (each sample is a path)
  int truth_bounces = 6;              // interreflected reference bounces
  int image_samples = 1024;           // reference at every vertex for pictures, at least (0: no pictures)
  double relight_seconds = 0.25;      // time spent timing each relight (median of the frames)
  int threads = 0;                    // 0: all cores
};

// The full grid (docs/REPORT.md gives its cost on bunny00) or the quick one
// (under a minute on two cores for a mesh of ~40k vertices).
ReportOptions report_options(bool quick);

struct ReportRow {
  std::string sweep;  // "bands", "samples", "bounces", "terms", "glossy", "compression"
  std::string basis;  // "sh", "wavelet"; compression: "cpca" (diffuse) or "cpca glossy"
  int bands = 0, samples = 0, bounces = 0, terms = 0, cube_res = 0;
  double precompute_s = 0;  // wall time of the precompute, whole mesh, all threads; compression: of the fit
  double relight_ms = 0;    // CPU, per frame, median
  std::uint64_t bytes = 0;  // transfer file size; compression: ClusteredSignal::bytes() of its signals
  Accuracy error;           // compression: rel_rms = rel_rms_raw = compression_error, noise 0, p99 NaN
  double self_rms = NAN;    // samples sweep: rel. RMS against the largest sample count
  double gloss = NAN;       // glossy sweep: the Phong exponent
  Accuracy intrinsic;       // glossy sweep: the SH formula with (nearly) exact matrices
  // Compression sweep: K and N as fitted (capped), the uncompressed rows'
  // bytes (4 per float of coefficients and glossy matrices), and frame
  // times (ms; NaN without a frame timer) of the compressed and of the
  // uncompressed transfer, measured in the same run.
  int clusters = 0, vectors = 0;
  std::uint64_t uncompressed_bytes = 0;
  double frame_ms = NAN, uncompressed_frame_ms = NAN;
};

// What a row's error is measured against: "shadowed", "interreflected",
// "glossy e=E", "uncompressed" or "uncompressed glossy".
std::string report_reference(const ReportRow& row);

// Per reference, whether each row is on the Pareto front: no other row of
// the same reference is no worse in both axes and strictly better in one.
// The axes: (bytes, error) for compression rows, (precompute time, error)
// for the others.
std::vector<bool> pareto_front(const std::vector<ReportRow>& rows);

// A setting's result at every vertex, for pictures.
struct ReportPicture {
  std::string label;
  std::vector<glm::vec3> radiance;
};

struct Report {
  ErrorSet shadowed_truth, interreflected_truth;
  std::vector<ErrorSet> glossy_truth;      // one per ReportOptions::glossy_gloss
  glm::dvec3 glossy_eye{0.0};              // the eye the glossy sweep used
  std::vector<ReportRow> rows;
  std::vector<glm::vec3> image_reference;  // every vertex (empty: no pictures)
  std::vector<glm::vec3> image_std_error;  // its standard error per vertex
  int image_samples = 0;                   // its samples per vertex: ReportOptions::image_samples, or more
                                           // when truth_vertices x truth_samples covers every vertex
  double image_reference_noise = 0;        // its noise floor (ErrorSet::noise_floor)
  std::vector<ReportPicture> pictures;     // shadowed settings, against image_reference
  std::vector<std::string> notes;          // what the caches did
  // The compression sweep's glossy error views (eye_ring) and lobe.
  std::vector<glm::dvec3> compression_eyes;
  double compression_gloss = NAN;
};

// One line per finished step ("bands 8: 4.1 s, error 0.012").
using ReportLog = std::function<void(const std::string&)>;

// Throws prt::Error on bad options and "cancelled" when `progress` says so.
// cache_dir: where references are kept between runs (empty: not kept).
Report run_report(const Mesh& mesh, const EnvMap& map, const ReportOptions& options, const std::string& cache_dir,
                  const Progress& progress = {}, const ReportLog& log = {});

// Relights `t` under the SH lighting `light` (unrotated) for timing: rotation
// by a fixed R plus relight(), median over frames for about `seconds`.
double time_sh_relight(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light, double seconds);

}  // namespace prt
