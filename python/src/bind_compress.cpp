// python/src/bind_compress.cpp - prt's Python module: clustered PCA of a
// transfer (compress), its relit error (compression_error), and the timing
// hook of relight's C++ call (_time_relight).
#include "module.h"

#include <prt/compressed_transfer.h>
#include <prt/compression_error.h>
#include <prt/mesh.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include <algorithm>
#include <chrono>

namespace prt::python {
namespace {

// prt compress --rotations and --eyes's ranges (make_error_distribution refuses the rest too).
void check_measure(int rotations, int eyes) {
  if (rotations < 1 || rotations > prt::kMaxErrorRotations)
    throw Error("rotations: must be 1 to " + std::to_string(prt::kMaxErrorRotations) + ", got " +
                std::to_string(rotations));
  if (eyes < 1 || eyes > prt::kMaxErrorEyes)
    throw Error("eyes: must be 1 to " + std::to_string(prt::kMaxErrorEyes) + ", got " + std::to_string(eyes));
}

// The distribution prt compress measures under, from the keyword arguments.
prt::ErrorDistribution distribution(const prt::Transfer& t, const py::object& envs, const py::object& spectra,
                                    bool own_spectra, bool sun, int rotations, int eyes) {
  prt::DistributionSpec spec;
  const auto paths = [](const py::object& list, const char* what) {
    std::vector<std::string> out;
    if (list.is_none()) return out;
    if (is_path(list)) return std::vector<std::string>{path_of(list, what)};
    for (const py::handle item : list) {
      if (!is_path(item)) throw Error(std::string(what) + ": expected map files (str or os.PathLike)");
      out.push_back(path_of(item, what));
    }
    return out;
  };
  spec.maps = paths(envs, "envs");
  spec.spectra = paths(spectra, "spectra");
  if (own_spectra && !spec.spectra.empty())
    throw Error("own_spectra: leaves the maps' spectra as they are; spectra= adds others': give one of them");
  spec.own_spectra = own_spectra;
  spec.sun = sun;
  check_measure(rotations, eyes);
  spec.rotations = rotations;
  spec.eyes = eyes;
  return prt::make_error_distribution(spec, t.bands);
}

py::dict stats_dict(const prt::ErrorStats& e) {
  py::dict d;
  d["mean"] = e.mean;
  d["p95"] = e.p95;
  d["max"] = e.max;
  d["samples"] = e.samples;
  d["bound"] = e.bound;
  return d;
}

}  // namespace

// compress, compression_error, _time_relight.
void bind_compress(py::module_& m) {
  // ---- compression (prt compress; docs/COMPRESSION.md) ----
  m.def(
      "compress",
      [](const PyTransfer& p, int clusters, int pca, int glossy_clusters, int glossy_pca, int weights,
         int iterations, std::uint64_t seed, const py::object& target_error, const py::object& mesh,
         const py::object& envs, const py::object& spectra, bool own_spectra, bool sun, int rotations,
         int eyes, const std::string& statistic, const std::string& metric, bool exhaustive,
         py::object progress) {
        if (p.compressed)
          throw Error(p.source + ": already compressed; compress the uncompressed transfer precompute made");
        if (weights != 16 && weights != 32) throw Error("weights: 16 or 32 (bits per stored weight)");
        if (statistic != "p95" && statistic != "mean") throw Error("statistic: 'p95' or 'mean', got '" + statistic + "'");
        if (metric != "band" && metric != "plain") throw Error("metric: 'band' or 'plain', got '" + metric + "'");
        check_measure(rotations, eyes);  // whether or not a target uses them, as the command's options
        PyTransfer out;
        out.source = "<compressed>";
        if (target_error.is_none()) {
          if (!p.t.glossy && (glossy_clusters != 128 || glossy_pca != 8))
            throw Error(p.source + ": glossy_clusters and glossy_pca need glossy matrices, which this transfer does "
                        "not have");
          prt::CompressOptions o{.clusters = clusters, .vectors = pca, .glossy_clusters = glossy_clusters,
                                 .glossy_vectors = glossy_pca, .iterations = iterations, .seed = seed,
                                 .weight_bits = weights, .progress = {}};
          out.compressed = run_released(std::move(progress), [&](const prt::Progress& pr) {
            prt::CompressOptions oo = o;
            oo.progress = pr;
            return prt::compress_transfer(p.t, oo);
          });
        } else {
          if (mesh.is_none()) throw Error("mesh: target_error measures the relit error on the mesh: give mesh=");
          if (!py::isinstance<prt::Mesh>(mesh))
            throw Error("mesh: expected a prt.Mesh (load_mesh, make_mesh), got " +
                        std::string(py::str(py::type::of(mesh).attr("__name__"))));
          const DArray te = real_array<double>(target_error, "target_error");
          if (te.ndim() != 0) throw Error("target_error: a relative RMS error in (0, 1), a number");
          const double target = te.data()[0];
          if (!(target > 0 && target < 1))
            throw Error("target_error: a relative RMS error in (0, 1), got " + number_text(target));
          const auto& target_mesh = mesh.cast<const prt::Mesh&>();
          prt::check_matches(p.t, target_mesh, p.source);
          const prt::ErrorDistribution d = distribution(p.t, envs, spectra, own_spectra, sun, rotations, eyes);
          prt::ChoiceOptions o;
          o.target = target;
          o.statistic = statistic == "mean" ? prt::ErrorStatistic::Mean : prt::ErrorStatistic::P95;
          o.metric = metric == "plain" ? prt::CompressionMetric::Plain : prt::CompressionMetric::Band;
          o.weight_bits = weights;
          o.iterations = iterations;
          o.seed = seed;
          o.exhaustive = exhaustive;
          out.compressed = run_released(std::move(progress), [&](const prt::Progress& pr) {
            prt::ChoiceOptions oo = o;
            oo.progress = pr;
            return prt::choose_compression(p.t, target_mesh, d, oo).compressed;
          });
        }
        out.t = prt::decompress(*out.compressed);
        return out;
      },
      py::arg("transfer"), py::kw_only(), py::arg("clusters") = 256, py::arg("pca") = 8,
      py::arg("glossy_clusters") = 128, py::arg("glossy_pca") = 8, py::arg("weights") = 16, py::arg("iterations") = 20,
      py::arg("seed") = 1, py::arg("target_error") = py::none(), py::arg("mesh") = py::none(),
      py::arg("envs") = py::none(), py::arg("spectra") = py::none(), py::arg("own_spectra") = false,
      py::arg("sun") = true, py::arg("rotations") = 24, py::arg("eyes") = 32, py::arg("statistic") = "p95",
      py::arg("metric") = "band", py::arg("exhaustive") = false, py::arg("progress") = py::none(),
      "Clustered PCA of a transfer (Sloan et al. 2003), as prt compress does (the same bits): .compressed is True, relight() uses its per-cluster products, .write() writes the file prt compress writes. docs/COMPRESSION.md. Releases the GIL.\n"
      "\n"
      "Arguments (prt compress's option in brackets):\n"
      "  transfer: a Transfer (not compressed).\n"
      "  clusters, pca: K clusters of N principal vectors [--clusters, --pca]; glossy_clusters, glossy_pca: the glossy matrices' own [--glossy-clusters, --glossy-pca].\n"
      "  weights: 16 or 32 bits per weight [--weights].\n"
      "  iterations: k-means rounds [--iterations]; seed [--seed].\n"
      "  target_error: instead of sizes, the smallest K x N whose relit error meets it (relative RMS, with mesh=) [--target-error]:\n"
      "    statistic 'p95' or 'mean'; metric 'band' or 'plain'; exhaustive: try every size, not the search [--exhaustive];\n"
      "    envs (map files; None: the bundled maps) under `rotations` rotations taking on the spectra of `spectra`\n"
      "    (None: the bundled maps'; own_spectra=True: none), the sun unless sun=False, and glossy: `eyes` views.\n"
      "  mesh: the Mesh the transfer was computed for (target_error).\n"
      "  progress: as precompute's.\n"
      "\n"
      "Returns a Transfer (compressed).");

  m.def(
      "compression_error",
      [](const PyTransfer& p, const PyTransfer& c, const prt::Mesh& mesh, const py::object& envs,
         int rotations, int eyes) {
        if (p.compressed) throw Error("transfer: " + p.source + " is compressed; give the uncompressed one it came from");
        if (!c.compressed) throw Error("compressed: " + c.source + " is not compressed (compress() or prt compress)");
        const prt::Transfer& ct = c.compressed->transfer;
        if (ct.vertices != p.t.vertices || ct.bands != p.t.bands || ct.glossy != p.t.glossy ||
            c.compressed->coeffs.rows() != p.t.coeffs.size() / std::max<std::size_t>(p.t.stride(), 1))
          throw Error("compressed: " + c.source + " is not a compression of " + p.source +
                      " (other vertices, bands or signals)");
        prt::check_matches(p.t, mesh, p.source);
        const prt::ErrorDistribution d = distribution(p.t, envs, py::none(), true, false, rotations, eyes);
        prt::ErrorStats e;
        {
          py::gil_scoped_release release;
          e = prt::CompressionErrorMeter(p.t, mesh, d)(*c.compressed, true);
        }
        return stats_dict(e);
      },
      py::arg("transfer"), py::arg("compressed"), py::arg("mesh"), py::kw_only(), py::arg("envs") = py::none(),
      py::arg("rotations") = 24, py::arg("eyes") = 32,
      "The relit error of a compressed transfer against the one it came from, as prt compress --measure.\n"
      "\n"
      "Arguments:\n"
      "  transfer: the Transfer it came from; compressed: the compressed Transfer; mesh: the Mesh both were computed for.\n"
      "  envs: map files (None: the bundled ones), each under `rotations` rotations; eyes: glossy views per rotation.\n"
      "\n"
      "Returns a dict: mean, p95, max (relative RMS over the vertices, per sample), samples, bound (the transfer-space bound no lighting exceeds).");

  // The C++ call relight() wraps, timed here (median seconds a call over
  // `repeats`), so a benchmark compares the module's call with it in one
  // process (bench/python_relight_overhead.py). Not part of the API.
  m.def(
      "_time_relight",
      [](const PyTransfer& p, const prt::Mesh& mesh, const py::object& lighting, int repeats) {
        const std::vector<glm::dvec3> light = to_coeffs(lighting, "lighting");
        if (repeats < 1) throw Error("repeats: must be at least 1");
        prt::check_matches(p.t, mesh, p.source);
        std::vector<double> t(static_cast<std::size_t>(repeats));
        py::gil_scoped_release release;
        for (double& s : t) {
          const auto t0 = std::chrono::steady_clock::now();
          const std::vector<glm::vec3> rgb = prt::relight(p.t, mesh, light);
          s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          if (rgb.empty()) s = 0;  // keeps the call
        }
        std::sort(t.begin(), t.end());
        return t[t.size() / 2];
      },
      py::arg("transfer"), py::arg("mesh"), py::arg("lighting"), py::arg("repeats") = 200);
}

}  // namespace prt::python
