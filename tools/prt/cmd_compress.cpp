// prt compress: a transfer file -> the same transfer compressed by clustered
// PCA (docs/COMPRESSION.md), by a given K x N or by a relit-error target.
#include "commands.h"
#include "progress.h"

#include <prt/compression_error.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/transfer_io.h>

#include <fmt/core.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

namespace prt::cli {

namespace {

struct CompressArgs {
  std::string input, output, mesh;
  std::vector<std::string> envs;
  // Defaults: the smallest K x N measured to meet issue 16's targets on
  // bunny00 (docs/COMPRESSION.md): diffuse 256 x 8, glossy matrices 128 x 8.
  CompressOptions opt{.clusters = 256, .vectors = 8, .glossy_clusters = 128, .glossy_vectors = 8, .iterations = 20,
                      .seed = 1, .weight_bits = 16, .progress = {}};
  double target = 0;
  int views = 8;
  double gloss = 16, specular = 0.5;
  bool quiet = false;
  const CLI::Option *clusters_opt = nullptr, *pca_opt = nullptr, *glossy_clusters_opt = nullptr,
                    *glossy_pca_opt = nullptr, *target_opt = nullptr, *mesh_opt = nullptr,
                    *env_opt = nullptr, *views_opt = nullptr, *gloss_opt = nullptr, *specular_opt = nullptr;
};

void check_usage(const CompressArgs& a) {
  const bool target = a.target_opt->count() > 0, measure = a.mesh_opt->count() > 0 || a.env_opt->count() > 0;
  for (const CLI::Option* o : {a.clusters_opt, a.pca_opt, a.glossy_clusters_opt, a.glossy_pca_opt})
    if (target && o->count() > 0)
      throw UsageError("--target-error chooses " + o->get_name() + " (and the other clusters and vectors); give the "
                       "target or the sizes, not both");
  if ((target || measure) && (a.mesh.empty() || a.envs.empty()))
    throw UsageError(std::string(target ? "--target-error" : a.mesh.empty() ? "--env" : "--mesh") +
                     " needs --mesh MESH and --env MAP (at least one): the relit error is measured on the mesh under "
                     "those maps");
  for (const CLI::Option* o : {a.views_opt, a.gloss_opt, a.specular_opt})
    if (o->count() > 0 && !measure)
      throw UsageError(o->get_name() + " shapes the views the glossy error is measured from; give --mesh and --env "
                       "(and --target-error to choose by it)");
  std::vector<Input> inputs = {{"IN", a.input}};
  if (!a.mesh.empty()) inputs.push_back({"--mesh", a.mesh});
  for (const auto& e : a.envs) inputs.push_back({"--env", e});
  check_not_input("--output", a.output, std::span<const Input>(inputs));
}

std::string bytes_text(double b) { return b >= 1e6 ? fmt::format("{:.2f} MB", b / 1e6) : fmt::format("{:.1f} KB", b / 1e3); }

int run_compress(CompressArgs& a) {
  check_usage(a);
  for_path("--output", [&] { check_writable(a.output); });
  if (transfer_is_compressed(a.input))
    throw Error(a.input + ": already compressed (prt info shows its clusters); compress the uncompressed transfer "
                          "prt precompute wrote");
  const Transfer t = read_transfer(a.input);
  if (!t.glossy)  // an option that does not fit the file: the file's mismatch
    for (const CLI::Option* o : {a.glossy_clusters_opt, a.glossy_pca_opt})
      if (o->count() > 0)
        throw Error(a.input + ": " + o->get_name() + " needs glossy matrices, which this transfer does not have "
                    "(prt precompute --material glossy makes them)");
  const bool measure = !a.mesh.empty();
  Mesh mesh;
  CompressionErrorOptions errors;
  if (measure) {
    mesh = load_mesh(a.mesh);
    check_matches(t, mesh, a.input);
    for (const auto& path : a.envs) {
      const EnvMap env = load_envmap(path);
      require_finite(env);
      errors.lights.push_back(project(env, t.bands));
    }
    if (t.glossy) {
      errors.eyes = eye_ring(mesh, a.views);
      errors.gloss = a.gloss;
      errors.specular = a.specular;
    }
  }

  Outputs out("compress");  // from here Ctrl-C stops cleanly, the write step included
  const auto t0 = std::chrono::steady_clock::now();
  std::string explanation;
  double error = -1;
  const std::optional<CompressedTransfer> c = run_with_progress(a.quiet, "compress", [&](const Progress& progress) {
    if (a.target_opt->count() > 0) {
      CompressionChoice choice = choose_compression(t, mesh, errors, a.target, a.opt.weight_bits, progress);
      explanation = choice.explanation;
      error = choice.error;
      return std::move(choice.compressed);
    }
    CompressOptions o = a.opt;
    o.progress = progress;
    CompressedTransfer r = compress_transfer(t, o);
    if (measure) error = compression_error(t, r, mesh, errors);
    return r;
  });
  if (!c) return 130;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.write([&] { write_compressed_transfer(a.output, *c); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (!a.quiet) {
    const double before = double(transfer_file_size(t)), after = double(transfer_file_size(*c));
    std::size_t rows = 4 * t.coeffs.size() + 4 * t.glossy_matrices.size() + 4 * t.direct.size();
    const std::size_t packed = c->coeffs.bytes() + (t.glossy ? c->glossy.bytes() : 0);
    fmt::print(stderr, "{}", describe_transfer(*c));
    if (!explanation.empty()) fmt::print(stderr, "{}\n", explanation);
    fmt::print(stderr,
               "compress: {:.1f} s; rows {} -> {} ({:.1f}x fewer bytes{}); file {} -> {}\n", seconds,
               bytes_text(double(rows)), bytes_text(double(packed)), packed ? double(rows) / double(packed) : 0.0,
               t.direct.empty() ? "" : ", the direct part dropped", bytes_text(before), bytes_text(after));
    if (error >= 0)
      fmt::print(stderr, "relit error (relative RMS against the uncompressed transfer, {} map{}{}): {:.4g}\n",
                 errors.lights.size(), errors.lights.size() == 1 ? "" : "s",
                 t.glossy ? fmt::format(", {} views at e = {:g}", errors.eyes.size(), errors.gloss) : "", error);
    fmt::print(stderr, "wrote {}\n", a.output);
  }
  return 0;
}

}  // namespace

Run add_compress(CLI::App& app) {
  auto a = std::make_shared<CompressArgs>();
  CLI::App* s = app.add_subcommand("compress", "Compress a transfer file by clustered PCA (fewer bytes per vertex)");
  s->footer(
      "Each stored row (a vertex's diffuse coefficients, all channels; or its glossy matrices: each signal with its\n"
      "own K x N, --clusters/--pca and --glossy-clusters/--glossy-pca) becomes its cluster's\n"
      "mean plus N weighted principal vectors (Sloan et al. 2003): per vertex a cluster index (8 bits up to 256\n"
      "clusters) and N weights. Relighting then needs the lighting through each cluster's mean and vectors once per\n"
      "frame and N weights per vertex. prt relight, render, view and info take the output; the direct part of an\n"
      "interreflected file is dropped. 16-bit weights (the default) cost no relit error in the third digit on the\n"
      "measured meshes and half the per-vertex bytes of float ones (docs/COMPRESSION.md).\n"
      "--target-error e chooses the smallest K x N (in bytes) whose relit error, the relative RMS radiance against\n"
      "the uncompressed transfer under the --env maps (glossy: from --views eye points around the mesh), is at most\n"
      "e, and says why. With --mesh and --env and a fixed K x N it prints that error.\n"
      "Example: prt compress glossy.prt -o glossy.cprt --clusters 128 --pca 8\n"
      "         prt compress bunny.prt -o bunny.cprt --target-error 0.005 --mesh bunny.off --env envmaps/forest.exr");
  s->add_option("IN", a->input, "Transfer file from prt precompute")->required();
  s->add_option("-o,--output", a->output, "Compressed transfer file to write")->required();
  a->clusters_opt = s->add_option("-k,--clusters", a->opt.clusters, "Clusters K (at most the stored vertices)")
                        ->check(int_range(1, 1 << 24))
                        ->capture_default_str();
  a->pca_opt = s->add_option("-n,--pca", a->opt.vectors, "Principal vectors N per cluster (0 to the row length)")
                   ->check(int_range(0, 1 << 20))
                   ->capture_default_str();
  a->glossy_clusters_opt = s->add_option("--glossy-clusters", a->opt.glossy_clusters,
                                         "Glossy files: clusters of the glossy matrices")
                               ->check(int_range(1, 1 << 24))
                               ->capture_default_str();
  a->glossy_pca_opt = s->add_option("--glossy-pca", a->opt.glossy_vectors,
                                    "Glossy files: principal vectors per cluster of the glossy matrices")
                          ->check(int_range(0, 1 << 20))
                          ->capture_default_str();
  s->add_option("--weights", a->opt.weight_bits, "Bits per weight: 16 (one scale per cluster and vector) or 32 (float)")
      ->check(CLI::IsMember({16, 32}))
      ->capture_default_str();
  s->add_option("--iterations", a->opt.iterations, "Rounds of assignment and refit at most")
      ->check(int_range(1, 1000))
      ->capture_default_str();
  add_shared(s, SharedOption::Seed, a->opt.seed, "Seed of the k-means++ seeding");
  a->target_opt = add_shared(s, SharedOption::TargetError, a->target,
                             "Choose K x N: the smallest whose relit error is at most this");
  a->mesh_opt = s->add_option("--mesh", a->mesh, "The mesh the transfer was computed for (to measure the error)");
  a->env_opt = s->add_option("--env", a->envs, "Environment map the error is measured under (repeatable)");
  a->views_opt = s->add_option("--views", a->views, "Glossy: eye points on a ring around the mesh")
                     ->check(int_range(1, 1024))
                     ->capture_default_str();
  a->gloss_opt = add_shared(s, SharedOption::Gloss, a->gloss, "Glossy: the measured lobe's exponent");
  a->specular_opt = add_shared(s, SharedOption::Specular, a->specular, "Glossy: the measured lobe's strength");
  s->add_flag("-q,--quiet", a->quiet, "No progress or summary on stderr");
  return [a] { return run_compress(*a); };
}

}  // namespace prt::cli
