// Error sets (prt/accuracy.h), the report grid (prt/report.h) and the
// error-target search (prt/tuning.h); `prt report` and
// `prt precompute --target-error` on the command line.
#include <prt/precompute.h>
#include <prt/accuracy.h>
#include <prt/compression_error.h>
#include <prt/error.h>
#include <prt/projection.h>
#include <prt/report.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/tuning.h>

#include "test_files.h"
#include "test_gl.h"
#include "test_meshes.h"
#include "test_util.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cstring>
#include <random>
#include <set>
#include <utility>

namespace prt {
namespace {

using test::TempDir;

// A dim sky with a small bright sun: the case where errors are large.
EnvMap sky_with_sun() {
  const glm::dvec3 sun = glm::normalize(glm::dvec3(0.4, 0.8, 0.3));
  return test::latlong_of(64, 32, [&](const glm::dvec3& d) {
    const double s = glm::dot(d, sun) > 0.97 ? 20.0 : 0.0;
    return glm::dvec3(0.3 + s, 0.35 + s, 0.45 + 0.8 * s) * (d.y > 0 ? 1.0 : 0.3);
  });
}

// A ball over a floor (~430 vertices): contact shadows and interreflection,
// small enough for the searches to run in a few seconds.
Mesh small_scene() { return test::ball_over_floor(16, 8, 16, 0.35f, {0.1f, 0.45f, 0.0f}); }

TEST(ErrorSet, ChoosesDistinctUsableVerticesDeterministically) {
  Mesh m = test::sphere(8, 16);
  m.normals[3] = glm::vec3(0.0f);  // unusable: no normal
  const auto a = choose_error_vertices(m, 20, 7), b = choose_error_vertices(m, 20, 7);
  EXPECT_EQ(a, b);
  ASSERT_EQ(a.size(), 20u);
  EXPECT_TRUE(std::is_sorted(a.begin(), a.end()));
  EXPECT_EQ(std::adjacent_find(a.begin(), a.end()), a.end());
  EXPECT_EQ(std::find(a.begin(), a.end(), 3u), a.end());
  EXPECT_NE(a, choose_error_vertices(m, 20, 8));
  // More than there are: every usable vertex.
  EXPECT_EQ(choose_error_vertices(m, 1u << 20, 7).size(), m.vertex_count() - 1);
}

TEST(ErrorSet, SubsetReferenceIsTheFullReferenceAtThoseVertices) {
  const Mesh m = test::open_box(0.7f);
  const EnvMap map = sky_with_sun();
  ErrorSetOptions o;
  o.reference.samples = 64;
  o.vertices = 4;
  const ErrorSet set = make_error_set(m, map, o);
  const ReferenceResult full = render_reference(m, map, o.reference);
  ASSERT_EQ(set.vertices.size(), 4u);
  for (std::size_t i = 0; i < set.vertices.size(); ++i) {
    EXPECT_EQ(set.radiance[i], full.radiance[set.vertices[i]]) << i;  // bit-identical: per-vertex generators
    EXPECT_EQ(set.std_error[i], full.std_error[set.vertices[i]]) << i;
  }
}

// The noise correction: a reference with known Gaussian noise, a result with
// a known 5% error. The raw error mixes both; the corrected one finds 5%.
TEST(Accuracy, SubtractsTheReferenceNoise) {
  const std::size_t n = 20000;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> gauss;
  ErrorSet set;
  set.mesh_vertices = n;
  std::vector<glm::vec3> truth(n), result(n);
  const double se = 0.05;  // per channel, on values ~1: noise floor ~0.05
  for (std::size_t v = 0; v < n; ++v) {
    truth[v] = glm::vec3(float(1 + 0.5 * std::sin(0.01 * double(v))));
    result[v] = truth[v] * 1.05f;
    set.vertices.push_back(std::uint32_t(v));
    set.radiance.push_back(truth[v] + glm::vec3(float(se * gauss(rng)), float(se * gauss(rng)), float(se * gauss(rng))));
    set.std_error.push_back(glm::vec3(float(se)));
  }
  const Accuracy a = measure_accuracy(set, result);
  // Tolerance: the corrected estimate's own spread over 20000 vertices x 3
  // channels is about 0.05 x sqrt(2 / 60000) / 0.05 relative ~ 1e-3 absolute; 3e-3 is 3 sigma.
  EXPECT_NEAR(a.rel_rms, 0.05, 3e-3);
  EXPECT_GT(a.rel_rms_raw, 0.065);  // sqrt(0.05^2 + 0.05^2 x ~0.93) ~ 0.07
  EXPECT_NEAR(a.noise_floor, set.noise_floor(), 1e-12);
  EXPECT_THROW(measure_accuracy(set, std::vector<glm::vec3>(n - 1)), Error);
}

TEST(ErrorSetCache, RoundTripsAndRefusesDamage) {
  TempDir dir;
  const Mesh m = test::open_box(0.7f);
  const EnvMap map = sky_with_sun();
  ErrorSetOptions o;
  o.reference.samples = 32;
  std::string note;
  const ErrorSet a = cached_error_set(m, map, o, dir.file("cache"), {}, &note);
  EXPECT_NE(note.find("cached in"), std::string::npos) << note;
  note.clear();
  const ErrorSet b = cached_error_set(m, map, o, dir.file("cache"), {}, &note);
  EXPECT_NE(note.find("read from"), std::string::npos) << note;
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.radiance, b.radiance);
  EXPECT_EQ(a.std_error, b.std_error);

  // Other inputs, other key.
  ErrorSetOptions o2 = o;
  o2.reference.samples = 33;
  const std::string key = error_set_key(m, map, o), key2 = error_set_key(m, map, o2);
  EXPECT_NE(key, key2);
  const std::string path = dir.file("cache") + "/" + key + ".prte";
  EXPECT_THROW(read_error_set(path, key2), Error);
  EXPECT_FALSE(read_error_set(dir.file("missing.prte"), key).has_value());
  // Truncated, and a bad value: refused with the file named; the cache re-renders.
  const std::string bytes = test::read_file(path);
  test::write_file(path, bytes.substr(0, bytes.size() - 5));
  try {
    read_error_set(path, key);
    ADD_FAILURE() << "truncated cache accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  note.clear();
  const ErrorSet c = cached_error_set(m, map, o, dir.file("cache"), {}, &note);
  EXPECT_NE(note.find("rendering it again"), std::string::npos) << note;
  EXPECT_EQ(c.radiance, a.radiance);
  std::string nan_bytes = test::read_file(path);
  const float nan = NAN;
  std::memcpy(nan_bytes.data() + 40 + a.vertices.size() * 4, &nan, 4);
  test::write_file(path, nan_bytes);
  EXPECT_THROW(read_error_set(path, key), Error);
}

// A small grid: every sweep's rows, errors that fall with bands on a smooth
// map, the sampling-alone error where it belongs, pictures.
// The glossy sweep: a row per (bands, e); with the "exact" matrices traced at
// the stored matrices' own samples the intrinsic error is the error itself
// (the same rays; float storage of the stored ones: 1e-4 relative), and with
// more samples it differs; more bands are more accurate at e = 4, whose lobe
// needs about 5.
TEST(Report, GlossySweep) {
  const Mesh m = small_scene();
  const EnvMap map = sky_with_sun();
  ReportOptions o;
  o.glossy_bands = {2, 5};
  o.glossy_gloss = {4, 30};
  o.glossy_samples = 128;
  o.glossy_exact_samples = 128;
  o.truth_vertices = 200;
  o.truth_glossy_samples = 2048;
  o.image_samples = 0;
  o.relight_seconds = 0;
  const Report r = run_report(m, map, o, "");
  ASSERT_EQ(r.rows.size(), 4u);
  ASSERT_EQ(r.glossy_truth.size(), 2u);
  for (const ReportRow& row : r.rows) {
    EXPECT_EQ(row.sweep, "glossy");
    EXPECT_NEAR(row.error.rel_rms, row.intrinsic.rel_rms, 1e-4 * row.error.rel_rms) << row.bands << " " << row.gloss;
  }
  EXPECT_LT(r.rows[2].error.rel_rms, 0.5 * r.rows[0].error.rel_rms);  // 5 bands vs 2 at e = 4
  o.glossy_exact_samples = 2048;
  const Report more = run_report(m, map, o, "");
  EXPECT_NE(more.rows[3].intrinsic.rel_rms, more.rows[3].error.rel_rms);
  o.glossy_gloss.clear();
  EXPECT_THROW(run_report(m, map, o, ""), Error);
}

// The compression sweep: a row per K x N (capped; duplicates left out),
// each row's bytes, error and frame times what compress_transfer,
// compression_error and the frame timer give for that cell (recomputed
// here), the Pareto flags a brute-force dominance check, N = the row length
// nearly lossless; the glossy transfer of the glossy sweep compressed too.
TEST(Report, CompressionSweep) {
  const Mesh m = small_scene();
  const EnvMap map = sky_with_sun();
  ReportOptions o;
  o.compression_clusters = {1, 4, 16};
  o.compression_vectors = {0, 1, 4, 16, 40};  // 40 caps to 16 (4 bands, grey: 16 values a row): left out
  o.compression_bands = 4;
  o.bands_samples = 64;
  o.glossy_bands = {2};
  o.glossy_gloss = {8};
  o.glossy_samples = 64;
  o.glossy_exact_samples = 64;
  o.truth_vertices = 50;
  o.truth_glossy_samples = 64;
  o.compression_glossy_bands = 2;
  o.compression_eyes = 2;
  o.image_samples = 0;
  o.relight_seconds = 0;
  // A frame timer that says which transfer it was given.
  int calls = 0;
  o.frame_timer = [&](const Transfer& t, const CompressedTransfer* c, std::span<const glm::dvec3> light, double gloss,
                      double specular) {
    ++calls;
    EXPECT_EQ(light.size(), std::size_t(t.bands) * t.bands);
    if (t.glossy) {
      EXPECT_EQ(gloss, 8.0);
      EXPECT_EQ(specular, 0.5);
    }
    return c ? 1000.0 * (t.glossy ? 2 : 1) + 10.0 * c->coeffs.clusters + (t.glossy ? c->glossy : c->coeffs).vectors
             : t.glossy ? 7.0 : 3.0;
  };
  const Report r = run_report(m, map, o, "");
  std::vector<const ReportRow*> diffuse, glossy;
  for (const ReportRow& x : r.rows) {
    if (x.sweep != "compression") continue;
    (x.basis == "cpca glossy" ? glossy : diffuse).push_back(&x);
  }
  ASSERT_EQ(diffuse.size(), 3u * 4u);
  ASSERT_EQ(glossy.size(), 3u * 4u);  // glossy_stride() = 10 at 2 bands: 16 and 40 cap to 10, one left out
  EXPECT_EQ(calls, 2 + 24);           // each uncompressed transfer once, each row once
  ASSERT_EQ(r.compression_eyes.size(), 2u);
  EXPECT_EQ(r.compression_eyes, eye_ring(m, 2));

  TransferOptions to;
  to.mode = TransferMode::Shadowed;
  to.bands = 4;
  to.samples = 64;
  to.albedo = o.albedo;
  const Transfer td = compute_transfer(m, to);
  to.bands = 2;
  to.glossy = true;
  const Transfer tg = compute_transfer(m, to);
  ASSERT_EQ(td.stride(), 16u);
  ASSERT_EQ(tg.glossy_stride(), 10u);
  ASSERT_GE(td.stored_vertices(), 16u);
  for (const auto& [t, rows] : {std::pair{&td, diffuse}, std::pair{&tg, glossy}}) {
    CompressionErrorOptions e;
    e.lights = {project(map, t->bands)};
    if (t->glossy) {
      e.eyes = eye_ring(m, 2);
      e.gloss = 8;
      e.specular = 0.5;
    }
    std::set<std::pair<int, int>> cells;
    for (const ReportRow* row : rows) {
      EXPECT_TRUE(cells.insert({row->clusters, row->vectors}).second) << row->clusters << " x " << row->vectors;
      CompressOptions c;
      c.clusters = row->clusters;
      c.vectors = row->vectors;
      c.iterations = o.compression_iterations;
      c.weight_bits = 16;
      const CompressedTransfer ct = compress_transfer(*t, c);
      const std::string at = row->basis + " " + std::to_string(row->clusters) + " x " + std::to_string(row->vectors);
      EXPECT_EQ(row->bytes, ct.coeffs.bytes() + (t->glossy ? ct.glossy.bytes() : 0)) << at;
      EXPECT_EQ(row->uncompressed_bytes, 4 * (t->coeffs.size() + t->glossy_matrices.size())) << at;
      // Tolerance: the same deterministic fit and sums; only summation order could differ.
      EXPECT_NEAR(row->error.rel_rms, compression_error(*t, ct, m, e), 1e-12) << at;
      EXPECT_EQ(row->frame_ms, 1000.0 * (t->glossy ? 2 : 1) + 10.0 * row->clusters + row->vectors) << at;
      EXPECT_EQ(row->uncompressed_frame_ms, t->glossy ? 7.0 : 3.0) << at;
      EXPECT_GT(row->precompute_s, 0) << at;
      EXPECT_EQ(row->bands, t->bands) << at;
    }
    for (int K : {1, 4, 16})
      for (int N : {0, 1, 4, int(std::max(t->stride(), t->glossy ? t->glossy_stride() : 0))})
        EXPECT_TRUE(cells.count({K, N})) << K << " x " << N;
    // N = the row length: lossless up to the 16-bit weights (each within
    // max |w| / 65534 of its value: relative errors ~1e-5; 1e-3 is the budget).
    for (const ReportRow* row : rows) {
      if (row->vectors == int(t->glossy ? t->glossy_stride() : t->stride())) {
        EXPECT_LT(row->error.rel_rms, 1e-3) << row->clusters;
      } else if (row->vectors == 0) {
        EXPECT_GT(row->error.rel_rms, 1e-3) << row->clusters;
      }
    }
  }
  // The Pareto flags: brute force over (bytes, error), per transfer.
  const std::vector<bool> front = pareto_front(r.rows);
  ASSERT_EQ(front.size(), r.rows.size());
  int on_front = 0;
  for (std::size_t i = 0; i < r.rows.size(); ++i) {
    const ReportRow& a = r.rows[i];
    if (a.sweep != "compression") continue;
    bool dominated = false;
    for (const ReportRow& b : r.rows)
      if (b.sweep == "compression" && b.basis == a.basis && &a != &b)
        dominated |= (b.bytes < a.bytes && b.error.rel_rms <= a.error.rel_rms) ||
                     (b.bytes <= a.bytes && b.error.rel_rms < a.error.rel_rms);
    EXPECT_EQ(front[i], !dominated) << a.basis << " " << a.clusters << " x " << a.vectors;
    on_front += front[i];
  }
  EXPECT_GE(on_front, 2);
  // The smallest row of each transfer is on the front, and so is the most accurate.
  for (const auto* rows : {&diffuse, &glossy}) {
    const auto smallest = std::min_element(rows->begin(), rows->end(), [](auto a, auto b) { return a->bytes < b->bytes; });
    EXPECT_TRUE(front[std::size_t(*smallest - r.rows.data())]);
  }

  // Without a frame timer: no frame times. Without the glossy sweep: diffuse only.
  o.frame_timer = nullptr;
  o.glossy_bands.clear();
  o.compression_vectors = {2};
  const Report plain = run_report(m, map, o, "");
  ASSERT_EQ(plain.rows.size(), 3u);
  for (const ReportRow& x : plain.rows) {
    EXPECT_EQ(x.basis, "cpca");
    EXPECT_TRUE(std::isnan(x.frame_ms));
    EXPECT_TRUE(std::isnan(x.uncompressed_frame_ms));
  }
  o.compression_vectors.clear();
  EXPECT_THROW(run_report(m, map, o, ""), Error);  // clusters without vectors
  o.compression_vectors = {2};
  o.compression_weight_bits = 8;
  EXPECT_THROW(run_report(m, map, o, ""), Error);
}

TEST(Report, SmallGrid) {
  const Mesh m = small_scene();
  const EnvMap map = sky_with_sun();
  ReportOptions o;
  o.bands = {2, 6};
  o.bands_samples = 128;
  o.samples = {32, 128};
  o.samples_bands = 4;
  o.bounces = {0, 1};
  o.bounce_bands = 3;
  o.bounce_samples = 64;
  o.terms = {10, 200};
  o.cube_res = 8;
  o.truth_vertices = 200;
  o.truth_samples = 1024;
  o.truth_bounce_samples = 256;
  o.truth_bounces = 2;
  o.image_samples = 4;
  o.relight_seconds = 0;
  std::vector<std::string> lines;
  const Report r = run_report(m, map, o, "", {}, [&](const std::string& l) { lines.push_back(l); });
  ASSERT_EQ(r.rows.size(), 8u);
  EXPECT_GE(lines.size(), r.rows.size());
  const auto row = [&](const char* sweep, int i) {
    std::vector<const ReportRow*> v;
    for (const ReportRow& x : r.rows)
      if (x.sweep == sweep) v.push_back(&x);
    return *v.at(std::size_t(i));
  };
  EXPECT_LT(row("bands", 1).error.rel_rms, 0.7 * row("bands", 0).error.rel_rms);
  EXPECT_LT(row("bounces", 1).error.rel_rms, row("bounces", 0).error.rel_rms);  // bounces add missing light
  EXPECT_LT(row("terms", 1).error.rel_rms, row("terms", 0).error.rel_rms);
  EXPECT_GT(row("samples", 0).self_rms, 0);
  EXPECT_TRUE(std::isnan(row("samples", 1).self_rms));  // the comparison itself
  EXPECT_TRUE(std::isnan(row("bands", 0).self_rms));
  for (const ReportRow& x : r.rows) {
    EXPECT_GT(x.precompute_s, 0) << x.sweep;
    EXPECT_GT(x.relight_ms, 0) << x.sweep;
    EXPECT_GT(x.bytes, 0u) << x.sweep;
    EXPECT_GE(x.error.rel_rms_raw, x.error.rel_rms) << x.sweep;
  }
  EXPECT_EQ(r.interreflected_truth.vertices.size(), 200u);
  ASSERT_EQ(r.pictures.size(), 3u);  // fewest bands, most bands, the middle K
  EXPECT_EQ(r.image_reference.size(), m.vertex_count());
  EXPECT_EQ(r.image_samples, int(200.0 * 1024 / double(m.vertex_count())));  // more than the 4 asked for
  EXPECT_THROW(run_report(m, map, ReportOptions{}, ""), Error);  // every sweep empty

  // Independent of run_report's pipeline: the rows' errors, self RMS and
  // sizes recomputed here from the transfers themselves and the formulas of
  // prt/accuracy.h and prt/report.h, against the truth the report used.
  const ErrorSet& truth = r.shadowed_truth;
  ASSERT_FALSE(truth.vertices.empty());
  TempDir dir;
  const auto transfer = [&](int bands, int samples) {
    TransferOptions t;
    t.mode = TransferMode::Shadowed;
    t.bands = bands;
    t.samples = samples;
    t.albedo = o.albedo;
    return compute_transfer(m, t);
  };
  const auto at_truth = [&](const Transfer& t) {
    const std::vector<glm::vec3> all = relight(t, m, project(map, t.bands));
    std::vector<glm::dvec3> sub;
    for (std::uint32_t v : truth.vertices) sub.emplace_back(all[v]);
    return sub;
  };
  // rel_rms_raw = sqrt(sum |a - ref|^2 / sum |ref|^2); rel_rms subtracts sum |se|^2 first.
  const auto check_row = [&](const ReportRow& got, const std::vector<glm::dvec3>& a) {
    double err = 0, ref = 0, se = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const glm::dvec3 b(truth.radiance[i]), e(truth.std_error[i]), d = a[i] - b;
      err += glm::dot(d, d);
      ref += glm::dot(b, b);
      se += glm::dot(e, e);
    }
    // Tolerance: the same float results summed in double in another order.
    EXPECT_NEAR(got.error.rel_rms_raw, std::sqrt(err / ref), 1e-9) << got.sweep << " " << got.bands;
    EXPECT_NEAR(got.error.rel_rms, std::sqrt(std::max(0.0, err - se) / ref), 1e-9) << got.sweep << " " << got.bands;
  };
  for (int i : {0, 1}) {
    const ReportRow& b = row("bands", i);
    const Transfer t = transfer(b.bands, o.bands_samples);
    check_row(b, at_truth(t));
    write_transfer(dir.file("bands.prt"), t);
    EXPECT_EQ(b.bytes, std::filesystem::file_size(dir.file("bands.prt"))) << "the transfer file's size";
  }
  const std::vector<glm::dvec3> few = at_truth(transfer(o.samples_bands, 32)),
                                many = at_truth(transfer(o.samples_bands, 128));
  check_row(row("samples", 0), few);
  check_row(row("samples", 1), many);
  double self = 0, norm = 0;  // self_rms: against the largest sample count
  for (std::size_t i = 0; i < few.size(); ++i) {
    self += glm::dot(few[i] - many[i], few[i] - many[i]);
    norm += glm::dot(many[i], many[i]);
  }
  EXPECT_NEAR(row("samples", 0).self_rms, std::sqrt(self / norm), 1e-9);
}

// --target-error meets its target against a reference it never saw (another
// seed, four times the samples, every vertex).
TEST(Tuning, MeetsTheTargetOnAnIndependentReference) {
  const Mesh m = small_scene();
  const EnvMap map = sky_with_sun();
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    TargetOptions o;
    o.target = 0.06;
    o.transfer.mode = mode;
    o.transfer.albedo = glm::vec3(0.8f);
    o.transfer.bands = 10;
    o.transfer.samples = 2048;
    o.transfer.bounces = 2;
    o.truth_bounces = 4;
    o.truth_vertices = 256;
    const TargetResult r = choose_transfer(m, map, o, "");
    SCOPED_TRACE(r.explanation);
    EXPECT_LE(r.error.rel_rms, kTargetMargin * o.target);
    EXPECT_EQ(r.transfer.bands, r.bands);
    EXPECT_EQ(r.transfer.samples, r.samples);
    // Cheapest along each axis: one band fewer misses the target at the probe.
    if (r.bands > 1) {
      bool found = false;
      for (const TargetTrial& t : r.trials)
        if (t.step == "bands" && t.bands == r.bands - 1) {
          found = true;
          EXPECT_FALSE(t.meets);
        }
      EXPECT_TRUE(found);
    }
    ErrorSetOptions check;
    check.reference.mode = mode;
    check.reference.bounces = o.truth_bounces;
    check.reference.albedo = glm::vec3(0.8f);
    check.reference.samples = 4 * r.truth_samples;
    check.reference.seed = 99;
    check.vertices = m.vertex_count();
    check.seed = 99;
    const ErrorSet independent = make_error_set(m, map, check);
    const Accuracy a = measure_accuracy(independent, relight(r.transfer, m, project(map, r.bands)));
    EXPECT_LE(a.rel_rms, o.target) << transfer_mode_name(mode) << " noise " << a.noise_floor;
  }
}

// --target-error with --adaptive: every trial adaptive (TOL = target / 2),
// so the error the search measures includes what interpolation adds; the
// result still meets the target on an independent reference, and some of
// its vertices are interpolated.
TEST(Tuning, AdaptiveTrialsMeetTheTargetToo) {
  const Mesh m = test::ball_over_floor(48, 8, 16, 0.35f, {0.1f, 0.45f, 0.0f});
  const EnvMap map = sky_with_sun();
  TargetOptions o;
  o.target = 0.06;
  o.transfer.albedo = glm::vec3(0.8f);
  o.transfer.bands = 8;
  o.transfer.samples = 1024;
  o.truth_vertices = 256;
  o.adaptive = true;
  const TargetResult r = choose_transfer(m, map, o, "");
  SCOPED_TRACE(r.explanation);
  EXPECT_LE(r.error.rel_rms, kTargetMargin * o.target);
  EXPECT_GT(r.transfer.interpolated_vertices(), 0u);
  ErrorSetOptions check;
  check.reference.albedo = glm::vec3(0.8f);
  check.reference.samples = 4 * r.truth_samples;
  check.reference.seed = 99;
  check.vertices = m.vertex_count();
  check.seed = 99;
  const ErrorSet independent = make_error_set(m, map, check);
  const Accuracy a = measure_accuracy(independent, relight(r.transfer, m, project(map, r.bands)));
  EXPECT_LE(a.rel_rms, o.target) << "noise " << a.noise_floor;
}

// The wavelet basis: the fewest terms K that meet the target; K / 2 or the
// previous rung of the ladder does not.
TEST(Tuning, WaveletTermsMeetTheTarget) {
  const Mesh m = small_scene();
  const EnvMap map = sky_with_sun();
  TargetOptions o;
  o.target = 0.03;
  o.transfer.albedo = glm::vec3(0.8f);
  o.truth_vertices = 256;
  WaveletOptions w;
  w.cube_res = 16;
  w.albedo = glm::vec3(0.8f);
  const WaveletTargetResult r = choose_wavelet_terms(m, map, o, w, "");
  SCOPED_TRACE(r.explanation);
  ASSERT_GE(r.trials.size(), 2u);  // the sun needs more than 10 terms
  EXPECT_TRUE(r.trials.back().meets);
  EXPECT_EQ(r.trials.back().terms, r.terms);
  EXPECT_FALSE(r.trials[r.trials.size() - 2].meets);
  EXPECT_LE(r.error.rel_rms, kTargetMargin * o.target);
  w.cube_res = 2;  // 24 texels cannot hold the sun: refused, even with every term
  try {
    choose_wavelet_terms(m, map, o, w, "");
    ADD_FAILURE() << "an unreachable target was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not reached"), std::string::npos) << e.what();
  }
}

TEST(Tuning, RefusesWhatItCannotMeet) {
  const Mesh m = test::open_box(0.7f);
  const EnvMap map = sky_with_sun();
  TargetOptions o;
  o.transfer.bands = 2;
  o.transfer.samples = 64;
  o.target = 0.01;
  o.truth_vertices = 9;
  o.max_truth_samples = 1 << 20;
  try {
    choose_transfer(m, map, o, "");
    ADD_FAILURE() << "an unreachable target was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not reached"), std::string::npos) << e.what();
  }
  o.max_truth_samples = 2048;  // too few for a 1% reference under a sun
  EXPECT_THROW(choose_transfer(m, map, o, ""), Error);
  o.target = 0;
  EXPECT_THROW(choose_transfer(m, map, o, ""), Error);
  o.target = 0.5;
  o.transfer.mode = TransferMode::Unshadowed;
  EXPECT_THROW(choose_transfer(m, map, o, ""), Error);
}

// ---- command line -----------------------------------------------------------

TEST(ReportCli, WritesTablesCsvAndPlots) {
  TempDir dir;
  const std::string out = dir.file("rep"), mesh = dir.file("scene.off");
  test::write_off(mesh, small_scene());
  const auto r = test::run_prt(dir, {"report", mesh,
                                     std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr", "--quick", "-o", out, "-q"});
  ASSERT_EQ(r.code, 0) << test::describe_run(r);
  const std::string md = test::read_file(out + "/report.md"), csv = test::read_file(out + "/report.csv");
  for (const char* s : {"## SH bands", "## Samples per vertex", "## Interreflection bounces", "## Wavelet terms K",
                        "Fitted slope", "## Compression (clustered PCA)"})
    EXPECT_NE(md.find(s), std::string::npos) << s;
  // Header plus the quick grid's rows: 5 bands, 3 samples, 3 bounces, 3 K,
  // glossy 2 bands x 1 exponent, compression 3 K x 3 N of the diffuse and
  // of the glossy transfer.
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 5 + 3 + 3 + 3 + 2 + 9 + 9) << csv;
  EXPECT_NE(md.find("### Glossy, 4 bands"), std::string::npos) << md;
  EXPECT_NE(md.find("## Glossy transfer"), std::string::npos) << md;
  EXPECT_NE(csv.find("pareto"), std::string::npos);
  // Whether the plots can be made here is asked of the interpreter prt uses
  // (cmd_report.cpp: $PRT_PYTHON, else /usr/bin/python3), not read from the report.
  const char* env_python = std::getenv("PRT_PYTHON");
  const std::string python = env_python && *env_python ? env_python
                             : ::access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3"
                                                                        : "python3";
  const bool matplotlib =
      std::system((test::shell_quote(python) + " -c 'import matplotlib, numpy' >/dev/null 2>&1").c_str()) == 0;
  if (matplotlib) {
    for (const char* png : {"error_vs_time.png", "error_vs_settings.png", "error_vs_samples.png", "compression.png"}) {
      ASSERT_TRUE(std::filesystem::exists(out + "/" + png)) << png << "\n" << md;
      EXPECT_GT(std::filesystem::file_size(out + "/" + png), 10000u) << png;
    }
    EXPECT_EQ(md.find(" failed (see "), std::string::npos) << md;
  } else {
    // The report says why there are no plots, and where the log is.
    EXPECT_NE(md.find("plots.py' '" + out + "' failed (see " + out + "/plots.log)"), std::string::npos) << md;
  }
  // A second run reads the cached references.
  const auto again = test::run_prt(dir, {"report", mesh,
                                         std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr", "--quick", "-o", out,
                                         "-q", "--no-plots"});
  ASSERT_EQ(again.code, 0) << test::describe_run(again);
  const std::string md2 = test::read_file(out + "/report.md");
  EXPECT_NE(md2.find("reference read from"), std::string::npos);
  EXPECT_NE(md2.find("plots skipped (--no-plots)"), std::string::npos) << md2;
  if (!matplotlib) GTEST_SKIP() << python << " has no matplotlib: tables and the failure note checked, plots not";
}

// --sweeps compression alone: no reference, the diffuse transfer's K x N
// rows with bytes, error and (with GL) frame times, or the reason there are
// none; the CSV's Pareto column is the library's front.
TEST(ReportCli, CompressionSweepAlone) {
  TempDir dir;
  const std::string out = dir.file("rep"), mesh = dir.file("scene.off");
  test::write_off(mesh, small_scene());
  const auto r = test::run_prt(dir, {"report", mesh, std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr", "--quick",
                                     "--sweeps", "compression", "-o", out, "-q", "--no-plots"});
  ASSERT_EQ(r.code, 0) << test::describe_run(r);
  const std::string md = test::read_file(out + "/report.md"), csv = test::read_file(out + "/report.csv");
  EXPECT_NE(md.find("### Diffuse, 8 bands"), std::string::npos) << md;
  EXPECT_EQ(md.find("## SH bands"), std::string::npos) << md;
  EXPECT_EQ(md.find("shadowed reference:"), std::string::npos) << md;  // no reference computed
  EXPECT_NE(md.find("No reference: the compression sweep's errors are against the uncompressed"), std::string::npos)
      << md;
  EXPECT_NE(md.find("`prt report --quick --sweeps compression "), std::string::npos) << md;
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> header;
  for (std::size_t at = 0; at < csv.size();) {
    const std::size_t end = csv.find('\n', at);
    std::vector<std::string> cells;
    const std::string line = csv.substr(at, end - at);
    for (std::size_t c = 0; c <= line.size();) {
      const std::size_t comma = std::min(line.find(',', c), line.size());
      cells.push_back(line.substr(c, comma - c));
      c = comma + 1;
    }
    (header.empty() ? header : rows.emplace_back()) = cells;
    at = end + 1;
  }
  ASSERT_EQ(rows.size(), 9u) << csv;  // the quick grid: 3 K x 3 N
  const auto col = [&](const char* name) {
    const auto it = std::find(header.begin(), header.end(), name);
    EXPECT_NE(it, header.end()) << name;
    return std::size_t(it - header.begin());
  };
  const std::size_t frame = col("frame_ms"), raw_frame = col("uncompressed_frame_ms"), k = col("clusters"),
                    pareto = col("pareto"), bpv = col("bytes_per_vertex"), raw = col("uncompressed_bytes_per_vertex");
  bool timed = false;
  int front = 0;
  for (const auto& row : rows) {
    ASSERT_EQ(row.size(), header.size());
    EXPECT_EQ(row[0], "compression");
    EXPECT_EQ(row[2], "uncompressed");
    EXPECT_GE(std::stoi(row[k]), 1);
    EXPECT_GT(std::stod(row[bpv]), 0);  // on ~430 vertices 64 clusters' bases outweigh the rows: no upper bound
    EXPECT_EQ(std::stod(row[raw]), std::stod(rows[0][raw]));
    timed = row[frame] != "nan";
    if (timed) {
      EXPECT_GT(std::stod(row[frame]), 0);
      EXPECT_GT(std::stod(row[raw_frame]), 0);
    }
    front += row[pareto] == "1";
  }
  EXPECT_GE(front, 1);
  if (!timed) {
    EXPECT_NE(md.find("No frame times: "), std::string::npos) << md;
    if (test::gl_required()) ADD_FAILURE() << "PRT_REQUIRE_GL is set, but the report has no frame times:\n" << md;
  } else {
    EXPECT_EQ(md.find("No frame times"), std::string::npos) << md;
  }
}

TEST(ReportCli, BadInputIsRefusedByName) {
  TempDir dir;
  const std::string mesh = std::string(PRT_SOURCE_DIR) + "/models/scene.obj";
  auto r = test::run_prt(dir, {"report", mesh, dir.file("nope.exr"), "-o", dir.file("rep")});
  EXPECT_EQ(r.code, 1) << test::describe_run(r);
  EXPECT_NE(r.err.find("nope.exr"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("rep") + "/report.md"));
  // Rules across options are usage errors (exit 2), found before any work.
  r = test::run_prt(dir, {"precompute", mesh, "-o", dir.file("t.prt"), "--target-error", "0.05"});
  EXPECT_EQ(r.code, 2) << test::describe_run(r);
  EXPECT_NE(r.err.find("--env"), std::string::npos) << r.err;
  r = test::run_prt(dir, {"precompute", mesh, "-o", dir.file("t.prt"), "--target-error", "0.05", "--env",
                          std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr", "--bounce-tolerance", "0.1"});
  EXPECT_EQ(r.code, 2) << test::describe_run(r);
  EXPECT_FALSE(std::filesystem::exists(dir.file("t.prt")));
  r = test::run_prt(dir, {"report", mesh, std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr", "-o", dir.file("rep"),
                          "--sweeps", "bands,shiny"});
  EXPECT_EQ(r.code, 2) << test::describe_run(r);
  EXPECT_NE(r.err.find("unknown sweep 'shiny'"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("rep") + "/report.md"));
}

TEST(PrecomputeCli, TargetErrorWritesTheChosenTransfer) {
  TempDir dir;
  test::write_off(dir.file("scene.off"), small_scene());
  const auto r = test::run_prt(dir, {"precompute", dir.file("scene.off"), "-o",
                                     dir.file("t.prt"), "--target-error", "0.08", "--env",
                                     std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr", "--cache",
                                     dir.file("cache")});
  ASSERT_EQ(r.code, 0) << test::describe_run(r);
  EXPECT_NE(r.err.find("chose "), std::string::npos) << r.err;
  const auto info = test::run_prt(dir, {"info", dir.file("t.prt")});
  EXPECT_EQ(info.code, 0) << test::describe_run(info);
}

}  // namespace
}  // namespace prt
