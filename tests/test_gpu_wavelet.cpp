// The wavelet transfer traced by a PointTracer (WaveletOptions::tracer;
// prt precompute --device gpu) against Embree on the CPU: the same texel
// directions and the same compression, so the transfers differ only where a
// ray grazes an edge and the two triangle tests disagree. test::ReferenceTracer
// needs no GL; the GL tracer runs on whatever EGL gives (llvmpipe here) and
// skips where no OpenGL 4.5 context can be made.
#include "test_meshes.h"
#include "test_scenes.h"
#include "test_tracers.h"

#include <prt/communicator.h>
#include <prt/error.h>
#include <prt/gpu_tracer.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/render.h>
#include <prt/wavelet.h>
#include <prt/wavelet_transfer.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

namespace prt {
namespace {

// The GL tracer of `mesh`, or nullptr (the test then skips) where this
// machine has no OpenGL 4.5 context.
std::unique_ptr<PointTracer> gpuw_gl_tracer(const Mesh& mesh) {
  try {
    return make_gl_point_tracer(build_flat_bvh(mesh));
  } catch (const NoGlContext&) {
    return nullptr;
  }
}

// The decoded dense transfer of every vertex ([v][6 r^2]): the dequantised
// coefficients, Haar-inverted face by face.
std::vector<float> gpuw_dense(const WaveletTransfer& t) {
  const std::size_t n = t.coeff_count(), rr = std::size_t(t.cube_res) * t.cube_res;
  std::vector<float> dense;
  dense.reserve(t.vertices * n);
  for (std::size_t v = 0; v < t.vertices; ++v) {
    std::vector<float> c = wavelet_vertex_coefficients(t, v);
    for (int f = 0; f < 6; ++f) wavelet::haar_inverse(c.data() + f * rr, t.cube_res);
    dense.insert(dense.end(), c.begin(), c.end());
  }
  return dense;
}

// Relative RMS of a's decoded dense transfer against b's.
double gpuw_relative_rms(const WaveletTransfer& a, const WaveletTransfer& b) {
  const std::vector<float> x = gpuw_dense(a), y = gpuw_dense(b);
  double e2 = 0, r2 = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    e2 += (double(x[i]) - y[i]) * (double(x[i]) - y[i]);
    r2 += double(y[i]) * y[i];
  }
  return std::sqrt(e2 / r2);
}

// Vertices whose stored transfer (count, scale or any entry) differs.
std::size_t gpuw_vertices_differing(const WaveletTransfer& a, const WaveletTransfer& b) {
  std::size_t differ = 0;
  for (std::size_t v = 0; v < b.vertices; ++v)
    differ += a.vertex_kept[v] != b.vertex_kept[v] || a.vertex_scale[v] != b.vertex_scale[v] ||
              wavelet_vertex_coefficients(a, v) != wavelet_vertex_coefficients(b, v);
  return differ;
}

// The bound on the decoded transfers' relative RMS (the SH path's,
// test_gpu_precompute.cpp kGpuRelativeRms). Everything but the triangle
// test is the same computation (directions, weights, compression, entry
// order), so the transfers differ only where a ray meets an edge exactly and
// one test sees a hit the other misses, moving that point's t_i by
// c omega_i / pi: about 1 / sqrt(lit rays of all points) of the norm per such
// ray, ~1.2e-3 on the floor and ball at cube 16 (891 points x ~770 lit
// rays). The vertex meshes here have no such ray (measured RMS 0, the same
// bits); a wrong visible test is order 1, one wrong texel per cube ~0.04.
constexpr double kWaveletRelativeRms = 1e-3;
// Vertices with a different stored transfer: at most this fraction (the
// vertices a grazing ray reaches).
constexpr double kWaveletVerticesDiffering = 0.02;

struct GpuwMatch {
  double rms = 0;
  std::size_t differ = 0;
  double cpu_s = 0, tracer_s = 0;
};

// compute_wavelet_at_points of `points` among `occluders` with Embree and
// with `tracer`, compared (and timed): relative RMS below `bound`.
GpuwMatch gpuw_match(const Mesh& occluders, const Mesh& points, WaveletOptions o, const PointTracer& tracer,
                     const std::string& what, double bound = kWaveletRelativeRms) {
  const auto t0 = std::chrono::steady_clock::now();
  const WaveletTransfer cpu = compute_wavelet_at_points(occluders, points, o);
  const auto t1 = std::chrono::steady_clock::now();
  o.tracer = &tracer;
  const WaveletTransfer traced = compute_wavelet_at_points(occluders, points, o);
  const auto t2 = std::chrono::steady_clock::now();
  GpuwMatch m;
  m.cpu_s = std::chrono::duration<double>(t1 - t0).count();
  m.tracer_s = std::chrono::duration<double>(t2 - t1).count();
  EXPECT_EQ(traced.vertices, cpu.vertices);
  EXPECT_EQ(traced.mesh_hash, cpu.mesh_hash);
  m.rms = gpuw_relative_rms(traced, cpu);
  m.differ = gpuw_vertices_differing(traced, cpu);
  EXPECT_LT(m.rms, bound) << what;
  EXPECT_LE(double(m.differ), kWaveletVerticesDiffering * double(cpu.vertices)) << what;
  ::testing::Test::RecordProperty(what + "_relative_rms", std::to_string(m.rms));
  std::printf("%s: %zu points, cube %d: relative RMS %.3g, %zu points differ; Embree %.3f s, %s %.3f s\n",
              what.c_str(), points.vertex_count(), o.cube_res, m.rms, m.differ, m.cpu_s, tracer.name().c_str(),
              m.tracer_s);
  return m;
}

WaveletOptions gpuw_options(int cube_res) {
  WaveletOptions o;
  o.cube_res = cube_res;
  return o;
}

TEST(GpuWavelet, ReferenceTracerGivesEmbreesTransferOnAFloorAndBall) {
  const Mesh mesh = test::floor_and_ball(24);
  const test::ReferenceTracer tracer(mesh);
  gpuw_match(mesh, mesh, gpuw_options(16), tracer, "floor and ball (reference tracer)");
}

// The ReferenceTracer's chunks of 100 points split the blocks of 32: the
// file is the same bits on one thread and on all of them, and the vertex
// transfer is compute_wavelet_at_points' at the vertices.
TEST(GpuWavelet, TracedTransferIsDeterministic) {
  const Mesh mesh = test::floor_and_ball(16);
  const test::ReferenceTracer tracer(mesh);
  WaveletOptions o = gpuw_options(8);
  o.tracer = &tracer;
  const WaveletTransfer all = compute_wavelet_transfer(mesh, o);
  o.threads = 1;
  const WaveletTransfer one = compute_wavelet_transfer(mesh, o);
  EXPECT_EQ(all.col_offsets, one.col_offsets);
  EXPECT_EQ(all.col_vertices, one.col_vertices);
  EXPECT_EQ(all.col_values, one.col_values);
  EXPECT_EQ(all.vertex_scale, one.vertex_scale);
  EXPECT_EQ(all.vertex_kept, one.vertex_kept);
  EXPECT_GT(all.kept(), 0u);
  EXPECT_EQ(gpuw_vertices_differing(compute_wavelet_at_points(mesh, mesh, o), all), 0u);
}

// wavelet_texel_transfer through the tracer: the dense t of each vertex,
// texel for texel Embree's but for grazing rays.
TEST(GpuWavelet, TexelTransferThroughTheTracerIsEmbrees) {
  const Mesh mesh = test::floor_and_ball(12);
  const test::ReferenceTracer tracer(mesh);
  WaveletOptions o = gpuw_options(8);
  std::vector<std::uint32_t> vs(mesh.vertex_count());
  std::iota(vs.begin(), vs.end(), 0u);
  const std::vector<double> cpu = wavelet_texel_transfer(mesh, o, vs);
  o.tracer = &tracer;
  const std::vector<double> traced = wavelet_texel_transfer(mesh, o, vs);
  ASSERT_EQ(traced.size(), cpu.size());
  std::size_t lit = 0, differ = 0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    lit += cpu[i] != 0;
    differ += traced[i] != cpu[i];
  }
  EXPECT_GT(lit, cpu.size() / 4);
  EXPECT_LE(differ, lit / 1000) << differ << " of " << lit << " lit texels differ";
}

TEST(GpuWavelet, GlTracerGivesEmbreesTransferOnAFloorAndBall) {
  const Mesh mesh = test::floor_and_ball(24);
  const std::unique_ptr<PointTracer> gl = gpuw_gl_tracer(mesh);
  if (!gl) GTEST_SKIP() << "no OpenGL 4.5 context";
  gpuw_match(mesh, mesh, gpuw_options(16), *gl, "floor and ball (GL tracer)");
}

TEST(GpuWavelet, GlTracerGivesEmbreesTransferOnTheSharedKnot) {
  const std::filesystem::path knot = PRT_SHARED_DIR "/meshes/knot1.off";
  if (!std::filesystem::exists(knot)) GTEST_SKIP() << "no ../shared/meshes/knot1.off";
  const Mesh mesh = load_mesh(knot.string());
  const std::unique_ptr<PointTracer> gl = gpuw_gl_tracer(mesh);
  if (!gl) GTEST_SKIP() << "no OpenGL 4.5 context";
  gpuw_match(mesh, mesh, gpuw_options(8), *gl, "knot1.off (GL tracer)");
}

// The lightmap's bound. Its 640 texels include floor texels under the box
// (inside it), placed symmetrically about the box's vertical edges: a few of
// their rays meet an edge exactly, where Embree's test lets them slip
// between the two faces and flat_bvh_closest's (barycentrics in [0, 1])
// does not. Measured: 3 texel rays of 2 texels (~5 10^5 traced), relative
// RMS 1.9e-3, the GL tracer's the reference tracer's bit for bit. One such
// ray moves the RMS by ~1.4e-3 here (1 / sqrt(lit rays)); 5e-3 allows about
// a dozen, while one wrong texel in every texel's cube is ~0.04 and a wrong
// visible test order 1.
constexpr double kLightmapRelativeRms = 5e-3;

// A wavelet lightmap's transfer (compute_wavelet_at_points at the texels,
// what prt precompute --lightmap --basis wavelet computes) through the
// tracers.
TEST(GpuWavelet, WaveletLightmapThroughTheTracersIsEmbrees) {
  const Scene scene = test::floor_and_box(false);
  LightmapTexels texels = lightmap_texels(scene, 32, 32, 0);
  move_texels_out_of_geometry(scene.mesh, texels);
  const Mesh points = texel_points(texels);
  const test::ReferenceTracer reference(scene.mesh);
  gpuw_match(scene.mesh, points, gpuw_options(16), reference, "wavelet lightmap (reference tracer)",
             kLightmapRelativeRms);
  const std::unique_ptr<PointTracer> gl = gpuw_gl_tracer(scene.mesh);
  if (!gl) GTEST_SKIP() << "no OpenGL 4.5 context";
  gpuw_match(scene.mesh, points, gpuw_options(16), *gl, "wavelet lightmap (GL tracer)", kLightmapRelativeRms);
}

// Two ranks that never exchange anything: the tracer is refused first.
class GpuwTwoRanks final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 2; }
  void all_gather(void*, std::span<const std::size_t>) const override { ADD_FAILURE() << "all_gather"; }
  void gather_to_root(const void*, void*, std::span<const std::size_t>) const override {
    ADD_FAILURE() << "gather_to_root";
  }
};

TEST(GpuWavelet, TracerUnderManyProcessesIsRefused) {
  const Mesh mesh = test::floor_and_ball(4);
  const test::ReferenceTracer tracer(mesh);
  const GpuwTwoRanks ranks;
  WaveletOptions o = gpuw_options(4);
  o.tracer = &tracer;
  o.comm = &ranks;
  try {
    compute_wavelet_transfer(mesh, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--device gpu runs in one process"), std::string::npos) << e.what();
  }
  EXPECT_THROW(compute_wavelet_at_points(mesh, mesh, o), Error);
}

}  // namespace
}  // namespace prt
