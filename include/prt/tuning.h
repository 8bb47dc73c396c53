// prt/tuning.h - the cheapest SH transfer settings that meet an error target
// on a given model and map (`prt precompute --target-error`; docs/REPORT.md).
//
// Error is the relative RMS of the relit result against the Monte Carlo
// reference on an ErrorSet (prt/accuracy.h), noise-corrected. Cost, in the
// order it is minimised: bands first (storage and per-frame work grow as
// bands^2, paid by every frame at run time), then bounces (interreflected:
// each costs a gather pass and changes the stored transfer), then samples
// (precompute time only). The search:
//   0. the reference: its samples per vertex are raised until its noise floor
//      is at most target / kTargetNoiseRatio (a pilot of 1024 samples
//      measures the noise; it falls as 1/sqrt(samples)).
//   1. bands: a transfer at max_bands (and max_bounces) at a probe sample
//      count (1024, then max_samples) is relit with the lighting truncated
//      to each band count b: exactly the error a b-band transfer from the
//      same directions has, since each coefficient is computed independently
//      of the band count. b* = the fewest bands that meet the target.
//   2. bounces (interreflected): 0, 1, ... at b* bands and the probe count,
//      until one meets it.
//   3. samples: 64, 128, ... up to the probe count at b* bands and the
//      chosen bounces, until one meets it.
// "Meets" means error <= kTargetMargin x target: the error is estimated on a
// random subset of vertices, so a margin keeps the whole mesh's error
// within the target (docs/REPORT.md says how this was checked).
#pragma once

#include <prt/accuracy.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/transfer.h>
#include <prt/wavelet_transfer.h>

#include <functional>
#include <string>
#include <vector>

namespace prt {

// Chosen settings must estimate at most this fraction of the target.
inline constexpr double kTargetMargin = 0.9;
// The reference's noise floor must be at most target / this.
inline constexpr double kTargetNoiseRatio = 3.0;

struct TargetOptions {
  double target = 0.02;           // relative RMS against the reference, in (0, 1)
  TransferOptions transfer;       // mode, albedo, vertex colours, threads, seed, offset; bands, samples and
                                  // bounces are the most the search may choose
  int truth_bounces = 6;          // interreflected reference bounces (light beyond is below 1e-3 at albedo 0.8
                                  // on closed meshes: docs/REPORT.md)
  std::size_t truth_vertices = 1024;
  int max_truth_samples = 1 << 18;  // refuse targets whose reference would need more
  // Every trial (and so the result) computed with adaptive sample points
  // (compute_adaptive_transfer): the error measured includes what
  // interpolation adds. Its tolerance 0: target / 2 (the target picks TOL).
  bool adaptive = false;
  AdaptiveOptions adaptive_options;
};

struct TargetTrial {
  std::string step;  // "bands", "bounces", "samples"
  int bands = 0, samples = 0, bounces = 0;
  double seconds = 0;  // precompute time of the run it came from (bands step: the max-bands run)
  Accuracy error;
  bool meets = false;
};

struct TargetResult {
  Transfer transfer;  // computed with the chosen settings
  int bands = 0, samples = 0, bounces = 0;
  Accuracy error;     // of `transfer`
  std::vector<TargetTrial> trials;
  int truth_samples = 0;
  double truth_noise = 0;
  std::string explanation;  // one paragraph: what was chosen and why
};

using TargetLog = std::function<void(const std::string&)>;

// Throws prt::Error when the target is out of range, when the reference
// would need more than max_truth_samples, and when no setting within the
// maxima meets it (the message gives the best error reached), and as
// compute_transfer does. cache_dir: where references are kept (empty: not kept).
TargetResult choose_transfer(const Mesh& mesh, const EnvMap& map, const TargetOptions& options,
                             const std::string& cache_dir, const Progress& progress = {}, const TargetLog& log = {});

// The wavelet basis: K, the terms kept per frame, is a run-time choice, so
// the transfer is computed once (cube_res, threshold as given) and K climbs
// 10, 20, 50, 100, ... until the error under the unrotated map meets the
// target (same reference, margin and refusals as choose_transfer).
struct WaveletTargetTrial {
  int terms = 0;
  Accuracy error;
  bool meets = false;
};
struct WaveletTargetResult {
  WaveletTransfer transfer;
  int terms = 0;
  Accuracy error;
  std::vector<WaveletTargetTrial> trials;
  int truth_samples = 0;
  double truth_noise = 0;
  std::string explanation;
};
WaveletTargetResult choose_wavelet_terms(const Mesh& mesh, const EnvMap& map, const TargetOptions& options,
                                         const WaveletOptions& wavelet_options, const std::string& cache_dir,
                                         const Progress& progress = {}, const TargetLog& log = {});

}  // namespace prt
