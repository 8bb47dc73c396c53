// prt_gpu_bench: the transfer of one mesh (or one lightmap's texels),
// shadowed (the tracer's sums) or interreflected (its closest hits), on the CPU (Embree, every core) and on the GPU (OpenGL compute
// over the flat BVH, prt/gpu_tracer.h), in one run: the same rays, their
// time, rays per second, the ratio, and how far the two files are apart
// (docs/PRECOMPUTE.md "On the GPU"; scripts/gpu_precompute.sh runs it on a
// lent GPU machine).
//
// Usage: prt_gpu_bench [--vertices N] [--texels N] [--samples S] [--bands B] [--mesh FILE] [--gpu-only]
//                      [--mode shadowed|interreflected]
//   --vertices N: a floor under a ball, N vertices in all (default 100000)
//   --texels N:   instead, a lightmap of a floor with boxes, about N covered texels
//   --mesh FILE:  instead, a mesh file (its vertices)
// Prints one line per device and one JSON line with every figure.
#include <prt/error.h>
#include <prt/gpu_tracer.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/transfer.h>

#include "../tests/test_meshes.h"
#include "../tests/test_scenes.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace {

struct BenchArgs {
  std::size_t vertices = 100000, texels = 0;
  int samples = 1024, bands = 3;
  std::string mesh;
  std::string mode = "shadowed";
  bool gpu_only = false;
};

BenchArgs parse(int argc, char** argv) {
  BenchArgs a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw prt::Error(s + ": expected a value");
      return argv[++i];
    };
    if (s == "--vertices") a.vertices = std::stoull(next());
    else if (s == "--texels") a.texels = std::stoull(next());
    else if (s == "--samples") a.samples = std::stoi(next());
    else if (s == "--bands") a.bands = std::stoi(next());
    else if (s == "--mesh") a.mesh = next();
    else if (s == "--gpu-only") a.gpu_only = true;
    else if (s == "--mode") a.mode = next();
    else throw prt::Error("unknown argument " + s + " (--vertices N, --texels N, --samples S, --bands B, --mesh FILE, "
                          "--gpu-only, --mode shadowed|interreflected)");
  }
  return a;
}

// A floor of k x k vertices under a ball of rings x 2 rings, about n vertices.
prt::Mesh floor_and_ball_of(std::size_t n) {
  const int k = std::max(2, int(std::sqrt(double(n) / 2.0)));
  const int rings = std::max(4, int(std::sqrt(double(n) / 4.0)));
  return prt::test::ball_over_floor(k, rings, 2 * rings, 0.4f, {0.0f, 0.9f, 0.0f});
}

// A ground with boxes, its atlas sized for about n covered texels.
struct TexelJob {
  prt::Scene scene;
  prt::LightmapTexels texels;
};
TexelJob texels_of(std::size_t n) {
  TexelJob j{prt::test::boxes_scene(64), {}};
  int side = 64;
  while (side < 16384 && prt::lightmap_texels_at_least(j.scene, side, side, 0) < n) side *= 2;
  j.texels = prt::lightmap_texels(j.scene, side, side, 0);
  prt::move_texels_out_of_geometry(j.scene.mesh, j.texels);
  return j;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double relative_rms(const std::vector<float>& a, const std::vector<float>& b) {
  double e2 = 0, r2 = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    e2 += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
    r2 += double(b[i]) * b[i];
  }
  return r2 > 0 ? std::sqrt(e2 / r2) : 0.0;
}

// One device's run: the dense rows (analytic ones evaluated) and its time.
struct Run {
  std::vector<float> rows;
  double seconds = 0;
};

int run(const BenchArgs& a) {
  prt::TransferOptions o;
  o.mode = prt::parse_transfer_mode(a.mode);
  o.bands = a.bands;
  o.samples = a.samples;
  const bool texels = a.texels > 0;
  TexelJob tj;
  prt::Mesh mesh;
  if (texels) tj = texels_of(a.texels);
  else mesh = a.mesh.empty() ? floor_and_ball_of(a.vertices) : prt::load_mesh(a.mesh);
  const prt::Mesh& occluders = texels ? tj.scene.mesh : mesh;
  const prt::Mesh points = texels ? prt::texel_points(tj.texels) : mesh;
  const std::size_t count = points.vertex_count();
  const auto once = [&](const prt::PointTracer* tracer) {
    o.tracer = tracer;
    const auto t0 = std::chrono::steady_clock::now();
    Run r;
    if (texels) {
      const prt::LightmapTransfer t = prt::compute_lightmap_transfer(tj.scene, tj.texels, o);
      r.seconds = seconds_since(t0);
      r.rows = prt::dense_transfer(t.transfer, points);
    } else {
      const prt::Transfer t = prt::compute_transfer(mesh, o);
      r.seconds = seconds_since(t0);
      r.rows = prt::dense_transfer(t, points);
    }
    return r;
  };
  const auto t0 = std::chrono::steady_clock::now();
  const prt::FlatBvh bvh = prt::build_flat_bvh(occluders);
  const double bvh_s = seconds_since(t0);
  const std::unique_ptr<prt::PointTracer> gpu = prt::make_gl_point_tracer(bvh);
  const double rays = double(count) * double(a.samples);  // half of 2 x samples directions above each horizon
  fmt::print("{} {}: {} triangles, BVH {} nodes (depth {}) in {:.2f} s; {}, {} bands, {} samples, about {:.3g} "
             "rays\n", texels ? "texels" : "vertices", count, occluders.triangles.size(), bvh.nodes.size(), bvh.depth,
             bvh_s, a.mode, a.bands, a.samples, rays);
  const Run g = once(gpu.get());
  fmt::print("gpu ({}): {:.2f} s, {:.3g} rays/s\n", gpu->name(), g.seconds, rays / g.seconds);
  Run c;
  if (!a.gpu_only) {
    c = once(nullptr);
    fmt::print("cpu (Embree): {:.2f} s, {:.3g} rays/s; gpu / cpu speed {:.2f}x; relative RMS gpu vs cpu {:.3g}\n",
               c.seconds, rays / c.seconds, c.seconds / g.seconds, relative_rms(g.rows, c.rows));
  }
  fmt::print("{{\"points\": {}, \"texels\": {}, \"mode\": \"{}\", \"triangles\": {}, \"bands\": {}, \"samples\": {}, \"rays\": {:.6g}, "
             "\"bvh_nodes\": {}, \"bvh_seconds\": {:.4g}, \"gpu\": \"{}\", \"gpu_seconds\": {:.4g}, "
             "\"cpu_seconds\": {:.4g}, \"relative_rms\": {:.4g}}}\n",
             count, texels, a.mode, occluders.triangles.size(), a.bands, a.samples, rays, bvh.nodes.size(), bvh_s,
             gpu->name(), g.seconds, a.gpu_only ? 0.0 : c.seconds, a.gpu_only ? 0.0 : relative_rms(g.rows, c.rows));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "prt_gpu_bench: %s\n", e.what());
    return 1;
  }
}
