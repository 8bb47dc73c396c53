// Adaptive sample points against tracing every vertex (docs/PRECOMPUTE.md,
// "Adaptive sample points"): both runs in this process, the adaptive one
// timed against the full one; the relit error of each against the full run
// and, given prt reference's CSV (--albedo 1,1,1 or the run's albedo), against
// the reference.
//   prt_adaptive_bench MESH ENV [--tol T] [--bands N] [--samples S] [--mode M]
//                      [--reference REF.csv] [--full FULL.prt] [--verify F] [--glossy]
//                      [--probe-fraction F] [--min-probes N]
//   prt_adaptive_bench SCENE ENV --lightmap WxH [the same] [--reference REF.exr]
// --lightmap: the texels of SCENE's atlas (as prt precompute --lightmap: its
// lightmap UV set, texels moved out of geometry, the materials' albedo);
// REF.exr from prt reference SCENE ENV --lightmap WxH.
// --full FILE: the full run read from FILE when it exists (written there
// otherwise), so that repeated runs compare against one full run; its time
// is then the one recorded beside it (FILE.seconds).
#include <prt/envmap.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/scene.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/vertex_csv.h>

#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace prt;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Relative RMS of a's relit radiance against b's (or the reference's) over every vertex and channel.
double relit_error(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  double num = 0, den = 0;
  for (std::size_t v = 0; v < a.size(); ++v)
    for (int c = 0; c < 3; ++c) {
      num += double(a[v][c] - b[v][c]) * (a[v][c] - b[v][c]);
      den += double(b[v][c]) * b[v][c];
    }
  return std::sqrt(num / den);
}

// The sample points' transfer both ways and its relit radiance.
struct Runs {
  std::size_t points = 0;
  double full_s = 0, adaptive_s = 0;
  AdaptiveReport report;
  std::vector<glm::vec3> full, adaptive;  // relit
};

// --lightmap: full and adaptive lightmaps of the scene's atlas, relit.
Runs lightmap_runs(const std::string& path, const std::string& size, const TransferOptions& o,
                   const AdaptiveOptions& a, const std::vector<glm::dvec3>& light) {
  const Scene scene = load_scene(path);
  int w = 0, h = 0;
  parse_lightmap_size(size, w, h);
  LightmapTexels texels = lightmap_texels(scene, w, h, scene.lightmap_uv_set(-1));
  move_texels_out_of_geometry(scene.mesh, texels, o.offset);
  Runs r;
  r.points = texels.layout.texels.size();
  auto t0 = std::chrono::steady_clock::now();
  const LightmapTransfer full = compute_lightmap_transfer(scene, texels, o);
  r.full_s = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const LightmapTransfer t = compute_adaptive_lightmap_transfer(scene, texels, o, a, {}, &r.report);
  r.adaptive_s = seconds_since(t0);
  r.full = relight_lightmap(full, texels, light);
  r.adaptive = relight_lightmap(t, texels, light);
  return r;
}

// The reference lightmap's covered texels (prt reference --lightmap's RGBA EXR, A = 1 where covered), in texel order.
std::vector<glm::vec3> covered_texels(const std::string& path) {
  const RgbaImage img = read_exr_rgba(path);
  std::vector<glm::vec3> out;
  for (std::size_t i = 0; i < std::size_t(img.width) * img.height; ++i)
    if (img.rgba[4 * i + 3] == 1.0f) out.emplace_back(img.rgba[4 * i], img.rgba[4 * i + 1], img.rgba[4 * i + 2]);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    fmt::print(stderr, "usage: prt_adaptive_bench MESH ENV [--tol T] [--bands N] [--samples S] [--mode M] "
                       "[--reference REF.csv] [--full FULL.prt] [--verify F] [--glossy]\n");
    return 2;
  }
  TransferOptions o;
  o.bands = 6;
  AdaptiveOptions a;
  std::string reference, full_path, lightmap;
  for (int i = 3; i < argc; ++i) {
    const std::string k = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        fmt::print(stderr, "{} needs a value\n", k);
        std::exit(2);
      }
      return argv[++i];
    };
    if (k == "--tol") a.tolerance = std::stod(next());
    else if (k == "--bands") o.bands = std::stoi(next());
    else if (k == "--samples") o.samples = std::stoi(next());
    else if (k == "--mode") o.mode = parse_transfer_mode(next());
    else if (k == "--reference") reference = next();
    else if (k == "--full") full_path = next();
    else if (k == "--verify") a.verify_fraction = std::stod(next());
    else if (k == "--glossy") o.glossy = true;
    else if (k == "--probe-fraction") a.probe_fraction = std::stod(next());
    else if (k == "--min-probes") a.min_probes = std::stoi(next());
    else if (k == "--lightmap") lightmap = next();
    else {
      fmt::print(stderr, "unknown argument {}\n", k);
      return 2;
    }
  }
  const EnvMap env = load_envmap(argv[2]);
  const std::vector<glm::dvec3> light = project(env, o.bands);
  if (!lightmap.empty()) {
    const Runs r = lightmap_runs(argv[1], lightmap, o, a, light);
    const AdaptiveReport& q = r.report;
    fmt::print("{}: lightmap {}, {} texels, {} bands, {} samples, {}; TOL {:.4g}\n", argv[1], lightmap, r.points,
               o.bands, o.samples, transfer_mode_name(o.mode), q.tolerance);
    fmt::print("full run: {:.2f} s; adaptive: {:.2f} s ({:.2f}x faster; selecting {:.2f} s, tracing {:.2f} s, "
               "predicting {:.2f} s)\n",
               r.full_s, r.adaptive_s, r.full_s / r.adaptive_s, q.seconds_selecting, q.seconds_tracing,
               q.seconds_predicting);
    fmt::print("traced {} of {} texels ({:.1f}%), {} texel traces ({:.2f}x fewer rays); {} patches, {} traced whole\n",
               q.traced, q.vertices, 100.0 * double(q.traced) / double(q.vertices), q.traces,
               double(q.vertices) / double(q.traces), q.patches, q.failed_patches);
    fmt::print("relit error of the adaptive run against the full run: {:.5f}\n", relit_error(r.adaptive, r.full));
    if (!reference.empty()) {
      const std::vector<glm::vec3> ref = covered_texels(reference);
      if (ref.size() != r.points) {
        fmt::print(stderr, "{}: {} covered texels for {}\n", reference, ref.size(), r.points);
        return 1;
      }
      const double ef = relit_error(r.full, ref), ea = relit_error(r.adaptive, ref);
      fmt::print("against the reference: full {:.5f}, adaptive {:.5f} ({:.3f}x the full run's)\n", ef, ea, ea / ef);
    }
    return 0;
  }
  const Mesh mesh = load_mesh(argv[1]);

  Transfer full;
  double full_s = 0;
  if (!full_path.empty() && std::filesystem::exists(full_path) && std::filesystem::exists(full_path + ".seconds")) {
    full = read_transfer(full_path);
    std::ifstream(full_path + ".seconds") >> full_s;
  } else {
    const auto t0 = std::chrono::steady_clock::now();
    full = compute_transfer(mesh, o);
    full_s = seconds_since(t0);
    if (!full_path.empty()) {
      write_transfer(full_path, full);
      std::ofstream(full_path + ".seconds") << full_s;
    }
  }
  AdaptiveReport r;
  const auto t0 = std::chrono::steady_clock::now();
  const Transfer t = compute_adaptive_transfer(mesh, o, a, {}, &r);
  const double adaptive_s = seconds_since(t0);

  const std::vector<glm::vec3> bf = relight(full, mesh, light), ba = relight(t, mesh, light);
  fmt::print("{}: {} vertices, {} bands, {} samples, {}; TOL {:.4g}\n", argv[1], mesh.vertex_count(), o.bands,
             o.samples, transfer_mode_name(o.mode), r.tolerance);
  fmt::print("full run: {:.2f} s; adaptive: {:.2f} s ({:.2f}x faster; selecting {:.2f} s, tracing {:.2f} s, predicting "
             "{:.2f} s)\n",
             full_s, adaptive_s, full_s / adaptive_s, r.seconds_selecting, r.seconds_tracing, r.seconds_predicting);
  fmt::print("traced {} of {} vertices ({:.1f}%), {} vertex traces ({:.2f}x fewer rays); {} patches, {} traced whole\n",
             r.traced, r.vertices, 100.0 * double(r.traced) / double(r.vertices), r.traces,
             double(r.vertices) / double(r.traces), r.patches, r.failed_patches);
  fmt::print("relit error of the adaptive run against the full run: {:.5f}\n", relit_error(ba, bf));
  if (r.verified)
    fmt::print("verify: {} vertices, error RMS {:.4f}, p95 {:.4f}, max {:.4f}, {} above TOL\n", r.verified,
               r.verified_rms, r.verified_p95, r.verified_max, r.verified_over);
  if (!reference.empty()) {
    const std::vector<glm::vec3> ref = read_vertex_csv(reference);
    if (ref.size() != mesh.vertex_count()) {
      fmt::print(stderr, "{}: {} rows for {} vertices\n", reference, ref.size(), mesh.vertex_count());
      return 1;
    }
    // The reference is computed with albedo 1: scale the runs' radiance to it.
    std::vector<glm::vec3> sf = bf, sa = ba;
    for (std::size_t v = 0; v < sf.size(); ++v) {
      sf[v] /= glm::max(o.albedo, glm::vec3(1e-6f));
      sa[v] /= glm::max(o.albedo, glm::vec3(1e-6f));
    }
    const double ef = relit_error(sf, ref), ea = relit_error(sa, ref);
    fmt::print("against the reference: full {:.5f}, adaptive {:.5f} ({:.3f}x the full run's)\n", ef, ea, ea / ef);
  }
  return 0;
}
