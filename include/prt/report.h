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
#pragma once

#include <prt/accuracy.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/transfer.h>

#include <glm/vec3.hpp>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace prt {

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
  std::string sweep;  // "bands", "samples", "bounces", "terms"
  std::string basis;  // "sh", "wavelet"
  int bands = 0, samples = 0, bounces = 0, terms = 0, cube_res = 0;
  double precompute_s = 0;  // wall time of the precompute, whole mesh, all threads
  double relight_ms = 0;    // CPU, per frame, median
  std::uint64_t bytes = 0;  // transfer file size
  Accuracy error;
  double self_rms = NAN;    // samples sweep: rel. RMS against the largest sample count
  double gloss = NAN;       // glossy sweep: the Phong exponent
  Accuracy intrinsic;       // glossy sweep: the SH formula with (nearly) exact matrices
};

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
