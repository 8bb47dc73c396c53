// The settings grid of `prt report` (prt/report.h).
#include <prt/report.h>

#include <prt/compression_error.h>
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/transfer_io.h>
#include <prt/wavelet.h>
#include <prt/wavelet_transfer.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <utility>

namespace prt {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A rotation with no special axis, for timing (a rotation about an axis or
// by 180 degrees has structured zeros the timing should not depend on).
glm::dmat3 timing_rotation() { return sh::rotation_from_euler(37.0, 23.0, 11.0); }

// Median frame time in ms of `frame`, run for about `seconds` (at least 3 frames).
template <class F>
double median_ms(double seconds, F&& frame) {
  std::vector<double> ms;
  const auto start = Clock::now();
  while (ms.size() < 3 || (seconds_since(start) < seconds && ms.size() < 1000)) {
    const auto t0 = Clock::now();
    frame();
    ms.push_back(seconds_since(t0) * 1e3);
  }
  std::nth_element(ms.begin(), ms.begin() + ms.size() / 2, ms.end());
  return ms[ms.size() / 2];
}

void validate(const ReportOptions& o) {
  const auto in = [](const std::vector<int>& v, int lo, int hi, const char* what) {
    for (int x : v)
      if (x < lo || x > hi)
        throw Error(fmt::format("report: {} {} is outside [{}, {}]", what, x, lo, hi));
  };
  in(o.bands, 1, 16, "bands");
  in({o.samples_bands, o.bounce_bands}, 1, 16, "bands");
  in(o.samples, 1, 1 << 24, "samples");
  in({o.bands_samples, o.bounce_samples}, 1, 1 << 24, "samples");
  in(o.bounces, 0, 64, "bounces");
  in(o.terms, 1, wavelet::kMaxTerms, "wavelet terms");
  in(o.glossy_bands, 1, kMaxGlossyBands, "glossy bands");
  in({o.glossy_samples, o.glossy_exact_samples}, 1, 1 << 24, "glossy samples");
  for (double e : o.glossy_gloss)
    if (!(e >= 0 && e <= glossy::kMaxGloss)) throw Error(fmt::format("report: gloss {:g} is outside [0, {:g}]", e, glossy::kMaxGloss));
  if (!o.glossy_bands.empty() && o.glossy_gloss.empty()) throw Error("report: the glossy sweep needs exponents");
  if (o.truth_glossy_samples < 2) throw Error("report: the glossy reference needs two samples");
  in(o.compression_clusters, 1, 1 << 24, "compression clusters");
  in(o.compression_vectors, 0, 1 << 16, "compression vectors");
  in({o.compression_bands}, 1, 16, "compression bands");
  in({o.compression_glossy_bands}, 0, kMaxGlossyBands, "compression glossy bands");
  in({o.compression_iterations}, 1, 1 << 16, "compression iterations");
  in({o.compression_eyes}, 1, 1 << 16, "compression eyes");
  if (o.compression_weight_bits != 16 && o.compression_weight_bits != 32)
    throw Error(fmt::format("report: compression weights are 16 or 32 bits, not {}", o.compression_weight_bits));
  if (o.compression_clusters.empty() != o.compression_vectors.empty())
    throw Error("report: the compression sweep needs both clusters and vectors");
  if (o.bands.empty() && o.samples.empty() && o.bounces.empty() && o.terms.empty() && o.glossy_bands.empty() &&
      o.compression_clusters.empty())
    throw Error("report: every sweep is empty");
  if (o.truth_vertices == 0 || o.truth_samples < 2 || o.truth_bounce_samples < 2)
    throw Error("report: the reference needs at least one vertex and two samples");
}

struct Runner {
  const Mesh& mesh;
  const EnvMap& map;
  const ReportOptions& o;
  const std::string& cache_dir;
  const Progress& progress;
  const ReportLog& log;
  Report& report;
  std::vector<glm::dvec3> light;  // the map's SH projection, 16 bands (all sweeps use a prefix)
  std::optional<Transfer> diffuse_base, glossy_base;  // kept for the compression sweep

  bool compression() const { return !o.compression_clusters.empty() && !o.compression_vectors.empty(); }

  void say(const std::string& line) const {
    if (log) log(line);
  }

  ErrorSet truth(TransferMode mode, int samples, int bounces, std::size_t vertices, const std::string& what,
                 const ReferenceOptions* glossy = nullptr) {
    ErrorSetOptions e;
    if (glossy) e.reference = *glossy;
    e.reference.mode = mode;
    e.reference.bounces = bounces;
    if (!glossy) e.reference.albedo = o.albedo;
    e.reference.samples = samples;
    e.vertices = vertices;
    std::string note;
    ErrorSet set = cached_error_set(mesh, map, e, cache_dir, progress, &note);
    if (!note.empty()) report.notes.push_back(what + ": " + note);
    say(fmt::format("{}: {} vertices x {} samples, noise floor {:.3g}{}", what, set.vertices.size(), samples,
                    set.noise_floor(), set.seconds > 0 ? fmt::format(", {:.3g} s", set.seconds) : ", from the cache"));
    return set;
  }

  Transfer precompute(TransferMode mode, int bands, int samples, int bounces, double& seconds) const {
    TransferOptions t;
    t.mode = mode;
    t.bands = bands;
    t.samples = samples;
    t.bounces = bounces;
    t.albedo = o.albedo;
    t.threads = o.threads;
    const auto t0 = Clock::now();
    Transfer transfer = compute_transfer(mesh, t, progress);
    seconds = seconds_since(t0);
    return transfer;
  }

  ReportRow sh_row(const char* sweep, const Transfer& t, double seconds, const ErrorSet& truth,
                   std::vector<glm::vec3>* radiance_out = nullptr) const {
    ReportRow row;
    row.sweep = sweep;
    row.basis = "sh";
    row.bands = t.bands;
    row.samples = t.samples;
    row.bounces = t.mode == TransferMode::Interreflected ? t.bounces : 0;
    row.precompute_s = seconds;
    row.bytes = transfer_file_size(t);
    const std::vector<glm::dvec3> l(light.begin(), light.begin() + std::size_t(t.bands) * t.bands);
    row.relight_ms = time_sh_relight(t, mesh, l, o.relight_seconds);
    std::vector<glm::vec3> rgb = relight(t, mesh, l);
    row.error = measure_accuracy(truth, rgb);
    say(fmt::format("{}: {} bands, {} samples, {} bounces: precompute {:.3g} s, relight {:.3g} ms, error {:.3g}", sweep,
                    t.bands, t.samples, row.bounces, seconds, row.relight_ms, row.error.rel_rms));
    if (radiance_out) *radiance_out = std::move(rgb);
    return row;
  }

  // The glossy sweep: per band count one precompute (timed), per exponent
  // its relighting (the glossy part alone, timed) against that exponent's
  // reference, and the intrinsic error with near-exact matrices at the error
  // vertices.
  void glossy_sweep() {
    const std::vector<std::uint32_t>& at = report.glossy_truth.front().vertices;
    for (int bands : o.glossy_bands) {
      TransferOptions t;
      t.mode = TransferMode::Shadowed;
      t.bands = bands;
      t.samples = o.glossy_samples;
      t.albedo = o.albedo;
      t.threads = o.threads;
      t.glossy = true;
      auto t0 = Clock::now();
      const Transfer transfer = compute_transfer(mesh, t, progress);
      const double seconds = seconds_since(t0);
      if (compression() && bands == o.compression_glossy_bands && !glossy_base) glossy_base = transfer;
      t.samples = o.glossy_exact_samples;
      const std::vector<double> exact = glossy_vertex_matrices(mesh, t, at);
      const std::size_t nc = std::size_t(bands) * bands;
      const std::vector<glm::dvec3> l(light.begin(), light.begin() + std::ptrdiff_t(nc));
      for (std::size_t g = 0; g < o.glossy_gloss.size(); ++g) {
        GlossyShading shading;
        shading.eye = report.glossy_eye;
        shading.gloss = o.glossy_gloss[g];
        shading.specular = 1.0;
        shading.diffuse = glm::dvec3(0.0);
        ReportRow row;
        row.sweep = "glossy";
        row.basis = "sh";
        row.bands = bands;
        row.samples = o.glossy_samples;
        row.gloss = shading.gloss;
        row.precompute_s = seconds;
        row.bytes = transfer_file_size(transfer);
        std::vector<glm::vec3> rgb;
        row.relight_ms = median_ms(o.relight_seconds, [&] { rgb = relight_glossy(transfer, mesh, l, shading); });
        const ErrorSet& truth = report.glossy_truth[g];
        row.error = measure_accuracy(truth, rgb);
        // The same formula with the near-exact matrices at the error vertices.
        const std::vector<double> lambda = glossy::phong_lobe_factors(shading.gloss, bands);
        std::vector<double> transferred(nc);
        for (std::size_t i = 0; i < at.size(); ++i) {
          const std::uint32_t v = at[i];
          const glm::dvec3 n = glm::normalize(glm::dvec3(mesh.normals[v]));
          glm::dvec3 value(0.0);
          if (const auto mirror = glossy::mirror_direction(n, glm::dvec3(mesh.positions[v]), shading.eye)) {
            const glm::dvec3 r = *mirror;
            const double* M = exact.data() + i * nc * nc;
            for (int c = 0; c < 3; ++c) {
              for (std::size_t p = 0; p < nc; ++p) {
                double a = 0;
                for (std::size_t q = 0; q < nc; ++q) a += M[p * nc + q] * l[q][c];
                transferred[p] = a;
              }
              value[c] = glossy::glossy_radiance(transferred, lambda, bands, r, 1.0);
            }
          }
          rgb[v] = glm::vec3(value);
        }
        row.intrinsic = measure_accuracy(truth, rgb);
        say(fmt::format("glossy: {} bands, e {:g}: precompute {:.3g} s, relight {:.3g} ms, error {:.3g} (intrinsic "
                        "{:.3g})",
                        bands, shading.gloss, seconds, row.relight_ms, row.error.rel_rms, row.intrinsic.rel_rms));
        report.rows.push_back(row);
      }
    }
  }

  void picture(const std::string& label, std::vector<glm::vec3> rgb) {
    if (o.image_samples > 0) report.pictures.push_back({label, std::move(rgb)});
  }

  void bands_sweep() {
    for (std::size_t i = 0; i < o.bands.size(); ++i) {
      double s = 0;
      const Transfer t = precompute(TransferMode::Shadowed, o.bands[i], o.bands_samples, 0, s);
      if (compression() && t.bands == o.compression_bands && !diffuse_base) diffuse_base = t;
      std::vector<glm::vec3> rgb;
      report.rows.push_back(sh_row("bands", t, s, report.shadowed_truth, &rgb));
      if (i == 0 || i + 1 == o.bands.size()) picture(fmt::format("SH {} bands", t.bands), std::move(rgb));
    }
  }

  void samples_sweep() {
    std::vector<std::vector<glm::vec3>> at_truth;  // each row's result at the error vertices
    const std::size_t first = report.rows.size();
    for (int samples : o.samples) {
      double s = 0;
      const Transfer t = precompute(TransferMode::Shadowed, o.samples_bands, samples, 0, s);
      std::vector<glm::vec3> rgb;
      report.rows.push_back(sh_row("samples", t, s, report.shadowed_truth, &rgb));
      std::vector<glm::vec3> sub;
      for (std::uint32_t v : report.shadowed_truth.vertices) sub.push_back(rgb[v]);
      at_truth.push_back(std::move(sub));
    }
    // The sampling error alone: against the largest sample count.
    const auto best = std::max_element(o.samples.begin(), o.samples.end()) - o.samples.begin();
    const std::vector<glm::vec3>& b = at_truth[std::size_t(best)];
    double ref = 0;
    for (const glm::vec3& x : b) ref += glm::dot(glm::dvec3(x), glm::dvec3(x));
    for (std::size_t i = 0; i < at_truth.size(); ++i) {
      if (std::ptrdiff_t(i) == best || ref == 0) continue;
      double err = 0;
      for (std::size_t k = 0; k < b.size(); ++k) {
        const glm::dvec3 d = glm::dvec3(at_truth[i][k]) - glm::dvec3(b[k]);
        err += glm::dot(d, d);
      }
      report.rows[first + i].self_rms = std::sqrt(err / ref);
    }
  }

  void bounces_sweep() {
    for (int k : o.bounces) {
      double s = 0;
      const Transfer t = k == 0 ? precompute(TransferMode::Shadowed, o.bounce_bands, o.bounce_samples, 0, s)
                                : precompute(TransferMode::Interreflected, o.bounce_bands, o.bounce_samples, k, s);
      report.rows.push_back(sh_row("bounces", t, s, report.interreflected_truth));
    }
  }

  void terms_sweep() {
    WaveletOptions w;
    w.cube_res = o.cube_res;
    w.threshold = o.threshold;
    w.albedo = o.albedo;
    w.threads = o.threads;
    const auto t0 = Clock::now();
    const WaveletTransfer t = compute_wavelet_transfer(mesh, w, progress);
    const double seconds = seconds_since(t0);
    wavelet::FrameLighting lighting(map, o.cube_res);
    const int mid = o.terms[o.terms.size() / 2];
    for (int K : o.terms) {
      ReportRow row;
      row.sweep = "terms";
      row.basis = "wavelet";
      row.terms = K;
      row.cube_res = o.cube_res;
      row.precompute_s = seconds;
      row.bytes = t.bytes();
      std::vector<glm::vec3> rgb;
      const glm::dmat3 R = timing_rotation();
      row.relight_ms = median_ms(o.relight_seconds, [&] {
        lighting.update(R, K, wavelet::Selection::AreaWeighted);
        wavelet_relight(t, lighting.coefficients().data(), lighting.terms(), rgb);
      });
      lighting.update(glm::dmat3(1.0), K, wavelet::Selection::AreaWeighted);
      wavelet_relight(t, lighting.coefficients().data(), lighting.terms(), rgb);
      row.error = measure_accuracy(report.shadowed_truth, rgb);
      say(fmt::format("terms: wavelet K={}: precompute {:.3g} s, relight {:.3g} ms, error {:.3g}", K, seconds,
                      row.relight_ms, row.error.rel_rms));
      report.rows.push_back(row);
      if (K == mid) picture(fmt::format("wavelet K={}", K), std::move(rgb));
    }
  }

  // The compression sweep: the diffuse base transfer (the bands sweep's, or
  // computed here) and the glossy sweep's at compression_glossy_bands.
  void compression_sweep() {
    if (!diffuse_base) {
      double s = 0;
      diffuse_base = precompute(TransferMode::Shadowed, o.compression_bands, o.bands_samples, 0, s);
      say(fmt::format("compression: {} bands, {} samples precomputed in {:.3g} s", o.compression_bands,
                      o.bands_samples, s));
    }
    compress_rows(*diffuse_base);
    if (glossy_base) compress_rows(*glossy_base);
  }

  // One row per K x N (capped; a cell that caps to an earlier one is left out).
  void compress_rows(const Transfer& t) {
    const char* what = t.glossy ? "glossy" : "diffuse";
    const std::size_t rows = t.stored_vertices();
    if (rows == 0) {
      report.notes.push_back(fmt::format("compression ({}): every vertex is analytic, nothing to compress", what));
      return;
    }
    const std::size_t dim = std::max(t.stride(), t.glossy ? t.glossy_stride() : std::size_t(0));
    const std::vector<glm::dvec3> l(light.begin(), light.begin() + std::ptrdiff_t(t.bands) * t.bands);
    CompressionErrorOptions errors;
    errors.lights = {l};
    const double specular = 0.5;
    if (t.glossy) {
      errors.eyes = report.compression_eyes;
      errors.gloss = report.compression_gloss;
      errors.specular = specular;
    }
    GlossyShading shading;  // the CPU timing's view: the first eye (prt render's default camera)
    shading.eye = report.compression_eyes.front();
    shading.gloss = errors.gloss;
    shading.specular = specular;
    const std::uint64_t raw = 4 * std::uint64_t(t.coeffs.size() + t.glossy_matrices.size());
    const double raw_frame = o.frame_timer ? o.frame_timer(t, nullptr, l, errors.gloss, specular) : NAN;
    sh::Rotation rot(t.bands, glm::dmat3(1.0));
    std::vector<glm::dvec3> rotated(l.size());
    std::set<std::pair<int, int>> done;
    for (int K : o.compression_clusters)
      for (int N : o.compression_vectors) {
        const int k = int(std::min<std::size_t>(std::size_t(K), rows)), n = int(std::min<std::size_t>(std::size_t(N), dim));
        if (!done.insert({k, n}).second) continue;
        CompressOptions c;
        c.clusters = k;
        c.vectors = n;
        c.iterations = o.compression_iterations;
        c.weight_bits = o.compression_weight_bits;
        c.progress = progress;
        const auto t0 = Clock::now();
        const CompressedTransfer ct = compress_transfer(t, c);
        ReportRow row;
        row.precompute_s = seconds_since(t0);
        row.sweep = "compression";
        row.basis = t.glossy ? "cpca glossy" : "cpca";
        row.bands = t.bands;
        row.samples = t.samples;
        row.gloss = t.glossy ? errors.gloss : NAN;
        row.clusters = k;
        row.vectors = n;
        row.bytes = ct.coeffs.bytes() + (t.glossy ? ct.glossy.bytes() : 0);
        row.uncompressed_bytes = raw;
        row.error.rel_rms = row.error.rel_rms_raw = compression_error(t, ct, mesh, errors);
        row.error.noise_floor = 0;
        row.error.p99_rel = NAN;
        const glm::dmat3 R = timing_rotation();
        std::vector<glm::vec3> rgb;
        row.relight_ms = median_ms(o.relight_seconds, [&] {
          rot.set(R);
          rot.apply(l, rotated);
          rgb = t.glossy ? relight_glossy(ct, mesh, rotated, shading) : relight(ct, mesh, rotated);
        });
        row.uncompressed_frame_ms = raw_frame;
        row.frame_ms = o.frame_timer ? o.frame_timer(t, &ct, l, errors.gloss, specular) : NAN;
        say(fmt::format("compression: {} {} bands, {} x {}: {:.1f} B/vertex (uncompressed {:.1f}), fit {:.3g} s, "
                        "error {:.3g}, frame {:.3g} ms (uncompressed {:.3g})",
                        what, t.bands, k, n, double(row.bytes) / double(mesh.vertex_count()),
                        double(raw) / double(mesh.vertex_count()), row.precompute_s, row.error.rel_rms, row.frame_ms,
                        raw_frame));
        report.rows.push_back(std::move(row));
      }
  }
};

}  // namespace

std::string report_reference(const ReportRow& r) {
  if (r.sweep == "glossy") return fmt::format("glossy e={:g}", r.gloss);
  if (r.sweep == "compression") return r.basis == "cpca glossy" ? "uncompressed glossy" : "uncompressed";
  return r.sweep == "bounces" ? "interreflected" : "shadowed";
}

std::vector<bool> pareto_front(const std::vector<ReportRow>& rows) {
  std::vector<bool> front(rows.size(), true);
  std::vector<std::string> ref;
  for (const ReportRow& r : rows) ref.push_back(report_reference(r));
  // Compression rows trade bytes for error; the others precompute time.
  const auto cost = [](const ReportRow& r) { return r.sweep == "compression" ? double(r.bytes) : r.precompute_s; };
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = 0; j < rows.size() && front[i]; ++j) {
      if (i == j || ref[i] != ref[j]) continue;
      const ReportRow &a = rows[i], &b = rows[j];
      const bool no_worse = cost(b) <= cost(a) && b.error.rel_rms <= a.error.rel_rms;
      const bool better = cost(b) < cost(a) || b.error.rel_rms < a.error.rel_rms;
      if (no_worse && better) front[i] = false;
    }
  return front;
}

ReportOptions report_options(bool quick) {
  ReportOptions o;
  if (!quick) {
    o.bands = {3, 4, 5, 6, 8, 10, 12, 14, 16};
    o.samples = {64, 128, 256, 512, 1024, 2048, 4096};
    o.bounces = {0, 1, 2, 3};
    o.terms = {10, 30, 100, 300, 1000};
    o.glossy_bands = {4, 6, 8, 10};
    o.glossy_gloss = {4, 16, 64};
    o.compression_clusters = {1, 16, 64, 256};
    o.compression_vectors = {1, 2, 4, 8, 16};
    return o;
  }
  o.bands = {3, 5, 8, 12, 16};
  o.bands_samples = 256;
  o.samples = {64, 256, 1024};
  o.samples_bands = 8;
  o.bounces = {0, 1, 2};
  o.bounce_bands = 4;
  o.bounce_samples = 256;
  o.terms = {10, 100, 1000};
  o.glossy_bands = {4, 6};
  o.glossy_gloss = {16};
  o.compression_clusters = {1, 16, 64};
  o.compression_vectors = {1, 4, 16};
  o.glossy_samples = 256;
  o.glossy_exact_samples = 4096;
  o.truth_glossy_samples = 8192;
  o.cube_res = 16;
  o.truth_vertices = 512;
  o.truth_samples = 16384;
  o.truth_bounce_samples = 8192;
  o.truth_bounces = 4;
  o.image_samples = 128;
  o.relight_seconds = 0.05;
  return o;
}

double time_sh_relight(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light, double seconds) {
  sh::Rotation rot(t.bands, glm::dmat3(1.0));
  std::vector<glm::dvec3> rotated(light.size());
  const glm::dmat3 R = timing_rotation();
  std::vector<glm::vec3> rgb;
  return median_ms(seconds, [&] {
    rot.set(R);
    rot.apply(light, rotated);
    rgb = relight(t, mesh, rotated);
  });
}

Report run_report(const Mesh& mesh, const EnvMap& map, const ReportOptions& options, const std::string& cache_dir,
                  const Progress& progress, const ReportLog& log) {
  validate(options);
  if (map.is_cube()) throw Error("report: the reference needs a lat-long map (" + map.source + " is a cube map)");
  Report report;
  Runner run{mesh, map, options, cache_dir, progress, log, report, project(map, 16)};
  const bool shadowed = !options.bands.empty() || !options.samples.empty() || !options.terms.empty();
  if (shadowed)
    report.shadowed_truth = run.truth(TransferMode::Shadowed, options.truth_samples, 0, options.truth_vertices,
                                      "shadowed reference");
  if (!options.bounces.empty())
    report.interreflected_truth = run.truth(TransferMode::Interreflected, options.truth_bounce_samples,
                                            options.truth_bounces, options.truth_vertices, "interreflected reference");
  if (options.image_samples > 0 && shadowed) {
    // At least image_samples; more when the error set's budget of vertex
    // samples covers them (a small mesh gets the error set's precision).
    const double budget = double(options.truth_vertices) * options.truth_samples / double(mesh.vertex_count());
    report.image_samples = int(std::max<double>(options.image_samples, std::min<double>(options.truth_samples, budget)));
    const ErrorSet all = run.truth(TransferMode::Shadowed, report.image_samples, 0, mesh.vertex_count(),
                                   "reference for pictures");
    report.image_reference.assign(mesh.vertex_count(), glm::vec3(0.0f));
    report.image_std_error.assign(mesh.vertex_count(), glm::vec3(0.0f));
    for (std::size_t i = 0; i < all.vertices.size(); ++i) {
      report.image_reference[all.vertices[i]] = all.radiance[i];
      report.image_std_error[all.vertices[i]] = all.std_error[i];
    }
    report.image_reference_noise = all.noise_floor();
  }
  if (!options.bands.empty()) run.bands_sweep();
  if (!options.samples.empty()) run.samples_sweep();
  if (!options.bounces.empty()) run.bounces_sweep();
  if (!options.terms.empty()) run.terms_sweep();
  if (!options.glossy_bands.empty()) {
    report.glossy_eye = options.glossy_eye;
    // NaN: prt render's default camera (prt/render.h: default_camera, 40 degrees).
    if (std::isnan(report.glossy_eye.x)) report.glossy_eye = eye_ring(mesh, 1).front();
    for (double e : options.glossy_gloss) {
      ReferenceOptions r;
      r.glossy = true;
      r.eye = report.glossy_eye;
      r.gloss = e;
      r.specular = 1.0;
      r.albedo = glm::vec3(0.0f);  // the glossy part alone
      report.glossy_truth.push_back(run.truth(TransferMode::Shadowed, options.truth_glossy_samples, 0,
                                              options.truth_vertices, fmt::format("glossy reference e={:g}", e), &r));
    }
    run.glossy_sweep();
  }
  if (run.compression()) {
    report.compression_eyes = eye_ring(mesh, options.compression_eyes);
    if (run.glossy_base) report.compression_gloss = options.glossy_gloss[options.glossy_gloss.size() / 2];
    run.compression_sweep();
  }
  return report;
}

}  // namespace prt
