// The cheapest transfer settings meeting an error target (prt/tuning.h).
#include <prt/tuning.h>

#include <prt/error.h>
#include <prt/projection.h>
#include <prt/wavelet.h>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <tuple>

namespace prt {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kPilotSamples = 1024;  // reference samples of the noise pilot
constexpr int kFirstProbe = 1024;    // samples of the first bands probe
constexpr int kFewestSamples = 64;   // the samples ladder starts here


struct Search {
  const Mesh& mesh;
  const EnvMap& map;
  const TargetOptions& o;
  const Progress& progress;
  const TargetLog& log;
  ErrorSet truth;
  std::vector<glm::dvec3> light;  // max bands
  TargetResult result;

  bool meets(const Accuracy& e) const { return e.rel_rms <= kTargetMargin * o.target; }

  std::vector<glm::dvec3> truncated(int bands) const {
    std::vector<glm::dvec3> l = light;
    std::fill(l.begin() + std::size_t(bands) * bands, l.end(), glm::dvec3(0.0));
    return l;
  }

  Transfer run(int bands, int samples, int bounces, double& seconds) const {
    TransferOptions t = o.transfer;
    t.bands = bands;
    t.samples = samples;
    t.bounces = bounces;
    t.bounce_tolerance = 0;
    if (t.mode == TransferMode::Interreflected && bounces == 0) t.mode = TransferMode::Shadowed;
    const auto t0 = Clock::now();
    Transfer transfer;
    if (o.adaptive) {
      AdaptiveOptions a = o.adaptive_options;
      if (a.tolerance <= 0) a.tolerance = o.target / 2;
      transfer = compute_adaptive_transfer(mesh, t, a, progress);
    } else {
      transfer = compute_transfer(mesh, t, progress);
    }
    seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return transfer;
  }

  TargetTrial trial(const char* step, const Transfer& t, int bands, double seconds) {
    TargetTrial tr;
    tr.step = step;
    tr.bands = bands;
    tr.samples = t.samples;
    tr.bounces = t.mode == TransferMode::Interreflected ? t.bounces : 0;
    tr.seconds = seconds;
    tr.error = measure_accuracy(truth, relight(t, mesh, truncated(bands)));
    tr.meets = meets(tr.error);
    result.trials.push_back(tr);
    if (log)
      log(fmt::format("{}: {} bands, {} samples, {} bounces: error {:.3g}{}", step, bands, tr.samples, tr.bounces,
                      tr.error.rel_rms, tr.meets ? " (meets)" : ""));
    return tr;
  }
};

ErrorSetOptions truth_options(const TargetOptions& o, int samples) {
  ErrorSetOptions e;
  e.reference.mode = o.transfer.mode == TransferMode::Interreflected ? TransferMode::Interreflected
                                                                     : TransferMode::Shadowed;
  e.reference.bounces = o.truth_bounces;
  e.reference.albedo = o.transfer.albedo;
  e.reference.vertex_colors = o.transfer.vertex_colors;
  e.reference.offset = o.transfer.offset;
  e.reference.samples = samples;
  e.vertices = o.truth_vertices;
  return e;
}

// Step 0: a reference whose noise floor is at most target / kTargetNoiseRatio.
ErrorSet target_reference(const Mesh& mesh, const EnvMap& map, const TargetOptions& o, const std::string& cache_dir,
                          const Progress& progress, const TargetLog& log, int& samples) {
  const ErrorSet pilot = cached_error_set(mesh, map, truth_options(o, kPilotSamples), cache_dir, progress);
  const double want = o.target / kTargetNoiseRatio;
  const double pilot_noise = pilot.noise_floor();
  samples = kPilotSamples;
  if (pilot_noise > want) {
    const double needed = kPilotSamples * (pilot_noise / want) * (pilot_noise / want);
    if (needed > o.max_truth_samples)
      throw Error(fmt::format("--target-error {:.3g} would need a reference of {:.3g} samples per vertex (its noise at "
                              "{} is {:.3g}); the most allowed is {}: ask for a larger target",
                              o.target, needed, kPilotSamples, pilot_noise, o.max_truth_samples));
    samples = int(std::ceil(needed / 256.0)) * 256;
  }
  ErrorSet truth = samples == kPilotSamples
                       ? pilot
                       : cached_error_set(mesh, map, truth_options(o, samples), cache_dir, progress);
  if (log)
    log(fmt::format("reference: {} vertices x {} samples, noise floor {:.3g}", truth.vertices.size(), samples,
                    truth.noise_floor()));
  return truth;
}

void check_target(double target) {
  if (!(target > 0 && target < 1)) throw Error(fmt::format("--target-error must be in (0, 1), got {:.3g}", target));
}

}  // namespace

TargetResult choose_transfer(const Mesh& mesh, const EnvMap& map, const TargetOptions& o,
                             const std::string& cache_dir, const Progress& progress, const TargetLog& log) {
  check_target(o.target);
  if (o.transfer.mode == TransferMode::Unshadowed)
    throw Error("--target-error: the unshadowed transfer has no sampling to choose (use shadowed or interreflected)");
  const int max_bands = o.transfer.bands, max_samples = o.transfer.samples;
  const int max_bounces = o.transfer.mode == TransferMode::Interreflected ? o.transfer.bounces : 0;
  Search s{mesh, map, o, progress, log, {}, project(map, max_bands), {}};

  // 0. The reference, precise enough for the target.
  s.truth = target_reference(mesh, map, o, cache_dir, progress, log, s.result.truth_samples);
  s.result.truth_noise = s.truth.noise_floor();

  // 1. Bands, from one max-bands run per probe sample count.
  std::vector<int> probes;
  if (kFirstProbe < max_samples) probes.push_back(kFirstProbe);
  probes.push_back(max_samples);
  int bands = 0, probe = 0;
  double best = INFINITY;
  for (int p : probes) {
    double seconds = 0;
    const Transfer t = s.run(max_bands, p, max_bounces, seconds);
    for (int b = 1; b <= max_bands && !bands; ++b) {
      const TargetTrial tr = s.trial("bands", t, b, seconds);
      best = std::min(best, tr.error.rel_rms);
      if (tr.meets) bands = b, probe = p;
    }
    if (bands) break;
  }
  if (!bands)
    throw Error(fmt::format("--target-error {:.3g} is not reached within {} bands, {} samples{}: the best error is "
                            "{:.3g} (more bands, or the wavelet basis for sharp lighting; `prt report` shows the "
                            "trade-off)",
                            o.target, max_bands, max_samples,
                            max_bounces ? fmt::format(", {} bounces", max_bounces) : std::string(), best));

  // The last run that met the target, reused when it has the final settings.
  std::optional<Transfer> kept;
  double kept_seconds = 0;
  Accuracy kept_error;
  // Runs settings(x) for each rung x of a ladder until one meets the target;
  // returns that rung, or `otherwise` when none does.
  const auto climb = [&](const char* step, const std::vector<int>& ladder, int otherwise, auto settings) {
    for (int x : ladder) {
      const auto [b, n, k] = settings(x);
      double seconds = 0;
      Transfer t = s.run(b, n, k, seconds);
      if (const TargetTrial tr = s.trial(step, t, bands, seconds); tr.meets) {
        kept = std::move(t), kept_seconds = seconds, kept_error = tr.error;
        return x;
      }
    }
    return otherwise;
  };

  // 2. Bounces: 0, 1, ... below the most (known to meet).
  std::vector<int> bounce_ladder;
  for (int k = 0; k < max_bounces; ++k) bounce_ladder.push_back(k);
  const int bounces = climb("bounces", bounce_ladder, max_bounces,
                            [&](int k) { return std::tuple{bands, probe, k}; });

  // 3. Samples: 64, 128, ... below the probe count (known to meet).
  std::vector<int> samples_ladder;
  for (int n = kFewestSamples; n < probe; n *= 2) samples_ladder.push_back(n);
  const int chosen_samples = climb("samples", samples_ladder, probe,
                                   [&](int n) { return std::tuple{bands, n, bounces}; });
  if (!kept || kept->samples != chosen_samples || kept->bands != bands) {
    kept = s.run(bands, chosen_samples, bounces, kept_seconds);
    kept_error = s.trial("final", *kept, bands, kept_seconds).error;
  }
  TargetResult& r = s.result;
  r.bands = bands;
  r.samples = chosen_samples;
  r.bounces = bounces;
  r.error = kept_error;
  r.transfer = std::move(*kept);

  // Why: the next-cheaper setting on each axis and its error.
  const auto error_of = [&](const char* step, int b, int n, int k) -> std::string {
    for (const TargetTrial& t : r.trials)
      if (t.step == step && t.bands == b && (n == 0 || t.samples == n) && t.bounces == k)
        return fmt::format("{:.3g}", t.error.rel_rms);
    return "";
  };
  std::string why = fmt::format("chose {} bands, {} samples{}: error {:.3g} <= {:.3g} x target {:.3g} (reference {} "
                                "samples, noise {:.3g})",
                                bands, chosen_samples, max_bounces ? fmt::format(", {} bounces", bounces) : std::string(),
                                r.error.rel_rms, kTargetMargin, o.target, r.truth_samples, r.truth_noise);
  if (bands > 1) {
    const std::string e = error_of("bands", bands - 1, probe, max_bounces);
    if (!e.empty()) why += fmt::format("; {} bands reach only {}", bands - 1, e);
  }
  if (bounces > 0) {
    const std::string e = error_of("bounces", bands, probe, bounces - 1);
    if (!e.empty()) why += fmt::format("; {} bounces only {}", bounces - 1, e);
  }
  if (chosen_samples > kFewestSamples) {
    const std::string e = error_of("samples", bands, chosen_samples / 2, bounces);
    if (!e.empty()) why += fmt::format("; {} samples only {}", chosen_samples / 2, e);
  }
  r.explanation = why;
  return r;
}

WaveletTargetResult choose_wavelet_terms(const Mesh& mesh, const EnvMap& map, const TargetOptions& o,
                                         const WaveletOptions& wavelet_options, const std::string& cache_dir,
                                         const Progress& progress, const TargetLog& log) {
  check_target(o.target);
  TargetOptions shadowed = o;
  shadowed.transfer.mode = TransferMode::Shadowed;
  WaveletTargetResult r;
  const ErrorSet truth = target_reference(mesh, map, shadowed, cache_dir, progress, log, r.truth_samples);
  r.truth_noise = truth.noise_floor();
  r.transfer = compute_wavelet_transfer(mesh, wavelet_options, progress);
  wavelet::FrameLighting lighting(map, wavelet_options.cube_res);
  const int all = int(r.transfer.coeff_count());
  std::vector<int> ladder;
  for (int K : {10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000})
    if (K < all) ladder.push_back(K);
  ladder.push_back(all);
  std::vector<glm::vec3> rgb;
  double best = INFINITY;
  for (int K : ladder) {
    lighting.update(glm::dmat3(1.0), K, wavelet::Selection::AreaWeighted);
    wavelet_relight(r.transfer, lighting.coefficients().data(), lighting.terms(), rgb);
    const Accuracy e = measure_accuracy(truth, rgb);
    best = std::min(best, e.rel_rms);
    const bool ok = e.rel_rms <= kTargetMargin * o.target;
    r.trials.push_back({K, e, ok});
    if (log) log(fmt::format("terms: K={}: error {:.3g}{}", K, e.rel_rms, ok ? " (meets)" : ""));
    if (ok) {
      r.terms = K;
      r.error = e;
      break;
    }
  }
  if (!r.terms)
    throw Error(fmt::format("--target-error {:.3g} is not reached by the wavelet transfer at --cube-res {}, "
                            "--threshold {:.3g} even with all {} terms: the best error is {:.3g} (a larger --cube-res "
                            "or a smaller --threshold)",
                            o.target, wavelet_options.cube_res, wavelet_options.threshold, all, best));
  r.explanation = fmt::format("relight with --terms {}: error {:.3g} <= {:.3g} x target {:.3g} (reference {} samples, "
                              "noise {:.3g})",
                              r.terms, r.error.rel_rms, kTargetMargin, o.target, r.truth_samples, r.truth_noise);
  if (r.trials.size() > 1)
    r.explanation += fmt::format("; K={} reaches only {:.3g}", r.trials[r.trials.size() - 2].terms,
                                 r.trials[r.trials.size() - 2].error.rel_rms);
  return r;
}

}  // namespace prt
