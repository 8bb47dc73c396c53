// The renderer at this OpenGL's limits (runtime/renderer.cpp, docs/RUNTIME.md
// "Limits"): it relights the mesh in runs of vertices, so a mesh larger than
// one dispatch (GL_MAX_COMPUTE_WORK_GROUP_COUNT) or one storage binding
// (GL_MAX_SHADER_STORAGE_BLOCK_SIZE) renders as one dispatch would, and
// refuses what cannot fit, naming the limit, the bytes needed and the limit's
// value. A 10-million-vertex mesh meets llvmpipe's real limits (65535 groups
// of 64 vertices, 128 MiB); here the test hook PRT_TEST_GL_LIMITS lowers them
// so that a mesh of a few hundred vertices meets them in milliseconds.
#include <prt/compressed_transfer.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/render.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "test_files.h"
#include "test_gl.h"
#include "test_meshes.h"
#include "test_renderer.h"

namespace prt {
namespace {

// Runs of vertices against one dispatch: the same shader arithmetic on the
// same values, so the same bits.
constexpr double kSameBits = 0.0;

// `text` with each "{}" replaced by the next number, in order.
std::string with(std::string text, std::initializer_list<std::size_t> numbers) {
  for (std::size_t n : numbers) text.replace(text.find("{}"), 2, std::to_string(n));
  return text;
}

// Sets PRT_TEST_GL_LIMITS while it lives (the renderer reads it in set_mesh).
class TestLimits {
 public:
  explicit TestLimits(const std::string& value) {
    if (const char* old = std::getenv(kName)) old_ = old;
    ::setenv(kName, value.c_str(), 1);
  }
  ~TestLimits() {
    if (old_) ::setenv(kName, old_->c_str(), 1);
    else ::unsetenv(kName);
  }
  TestLimits(const TestLimits&) = delete;
  TestLimits& operator=(const TestLimits&) = delete;

 private:
  static constexpr const char* kName = "PRT_TEST_GL_LIMITS";
  std::optional<std::string> old_;
};

std::vector<glm::dvec3> lighting(int bands) {
  std::vector<glm::dvec3> l(std::size_t(bands) * bands, glm::dvec3(0.0));
  l[0] = {3.0, 2.5, 2.0};
  for (std::size_t k = 1; k < l.size(); ++k) l[k] = {0.3 / double(k), -0.2 / double(k), 0.25 / double(k)};
  return l;
}

// floor_and_ball(6): 49 floor and 12 x 24 ball vertices, stored and analytic.
Transfer transfer_of(const Mesh& mesh, bool rgb, bool glossy) {
  TransferOptions o;
  o.mode = TransferMode::Shadowed;
  o.bands = 3;
  o.samples = 32;
  o.albedo = rgb ? glm::vec3(0.8f, 0.6f, 0.4f) : glm::vec3(0.7f);
  o.glossy = glossy;
  return compute_transfer(mesh, o);
}

// The radiance of every vertex with the limits as they are and with
// `limits`, for `shading`.
std::pair<std::vector<glm::vec3>, std::vector<glm::vec3>> both(Renderer& r, const Mesh& mesh, const Transfer& t,
                                                              Shading shading, const std::string& limits) {
  const glm::dvec3 eye(0.7, 2.2, 2.4);
  r.set_mesh(mesh, t);
  r.set_shading(shading);
  r.set_lighting(lighting(t.bands));
  const std::vector<glm::vec3> whole = r.vertex_radiance(eye);
  TestLimits cap(limits);
  r.set_mesh(mesh, t);
  r.set_shading(shading);
  r.set_lighting(lighting(t.bands));
  return {whole, r.vertex_radiance(eye)};
}

// Runs of 64 vertices (a storage block of 1 KiB: 64 x 16 bytes of radiance)
// and of 128 (2 work groups of 64): every path of the relighting pass
// (stored rows only, stored and analytic, every vertex analytic, vertex
// colours) and the glossy pass give the bits of one dispatch, and relight()
// within the renderer's tolerance.
TEST(RenderLimits, RunsOfVerticesShadeAsOneDispatch) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(6);
  ASSERT_GT(mesh.vertex_count(), 2 * 128u);  // three runs or more, the last one partial
  ASSERT_NE(mesh.vertex_count() % 64, 0u);
  for (const char* limits : {"GL_MAX_SHADER_STORAGE_BLOCK_SIZE=1024", "GL_MAX_COMPUTE_WORK_GROUP_COUNT=2"}) {
    for (bool rgb : {false, true}) {
      SCOPED_TRACE(std::string(limits) + (rgb ? ", rgb" : ", grey"));
      const Transfer mixed = transfer_of(mesh, rgb, true);
      ASSERT_GT(mixed.analytic_vertices(), 0u);
      Transfer dense = mixed;  // every row stored
      dense.coeffs = dense_transfer(mixed, mesh);
      dense.slots.clear();
      dense.glossy = false;
      dense.glossy_matrices.clear();
      using Case = std::tuple<const Transfer*, Shading, const char*>;
      for (const auto& [t, shading, name] :
           {Case{&dense, Shading::Transfer, "stored"}, Case{&mixed, Shading::Transfer, "mixed"},
            Case{&mixed, Shading::Unshadowed, "analytic"}, Case{&mixed, Shading::Glossy, "glossy"}}) {
        const auto [whole, runs] = both(*r, mesh, *t, shading, limits);
        EXPECT_EQ(test::relative_difference(runs, whole), kSameBits) << name;
      }
    }
  }
  // Vertex colours as albedo (their storage buffer is bound by runs too).
  Mesh coloured = mesh;
  coloured.colors.resize(coloured.vertex_count());
  for (std::size_t v = 0; v < coloured.colors.size(); ++v)
    coloured.colors[v] = glm::vec3(0.3f + 0.5f * float(v % 7) / 6.0f, 0.6f, 0.9f - 0.4f * float(v % 5) / 4.0f);
  TransferOptions o;
  o.mode = TransferMode::Unshadowed;  // every vertex analytic: shaded from its normal and colour
  o.bands = 3;
  o.vertex_colors = true;
  const Transfer t = compute_transfer(coloured, o);
  const auto [whole, runs] = both(*r, coloured, t, Shading::Transfer, "GL_MAX_COMPUTE_WORK_GROUP_COUNT=1");
  EXPECT_EQ(test::relative_difference(runs, whole), kSameBits);
  test::expect_radiance_near(runs, relight(t, coloured, lighting(3)), 1e-3, "vertex_colours");
}

// What cannot be split is refused by set_mesh, before anything is uploaded,
// naming the limit, what needed it, the bytes and the limit's value.
TEST(RenderLimits, WhatDoesNotFitIsRefusedNamingTheLimit) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(6);
  const std::size_t V = mesh.vertex_count();
  const Transfer t = transfer_of(mesh, false, false);
  const std::size_t rows = t.stored_vertices();
  ASSERT_LT(rows, V);
  const auto message = [&](const auto& upload) {
    try {
      upload();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  {
    // The rows of the buffer texture: 3 texels of 16 bytes each (9 coefficients padded to 12).
    TestLimits cap("GL_MAX_TEXTURE_BUFFER_SIZE=100");
    EXPECT_EQ(message([&] { r->set_mesh(mesh, t); }),
              with("transfer of {} vertices x 1 channel x 9 coefficients (each channel padded to 12) needs {} "
                   "bytes on the GPU in one buffer texture ({} texels of 16 bytes); this OpenGL's "
                   "GL_MAX_TEXTURE_BUFFER_SIZE is 100 texels (1600 bytes): use fewer bands (prt precompute "
                   "--bands) or a smaller mesh",
                   {rows, rows * 48, rows * 3}));
  }
  {
    // Glossy matrices: 3 bands, the packed triangle of 9 x 9 is 45 floats, padded to 48: 12 texels per vertex.
    const Transfer g = transfer_of(mesh, false, true);
    TestLimits cap("GL_MAX_TEXTURE_BUFFER_SIZE=" + std::to_string(12 * V - 1));
    EXPECT_EQ(message([&] { r->set_mesh(mesh, g); }),
              with("glossy matrices of {} vertices at 3 bands (192 bytes per vertex) needs {} bytes on the GPU "
                   "in one buffer texture ({} texels of 16 bytes); this OpenGL's GL_MAX_TEXTURE_BUFFER_SIZE is "
                   "{} texels ({} bytes): use fewer bands (prt precompute --bands) or a smaller mesh",
                   {V, V * 192, V * 12, 12 * V - 1, (12 * V - 1) * 16}));
  }
  {
    // A compressed glossy transfer's glossy pass goes by cluster and binds
    // its per-vertex buffers whole: the radiance, 16 bytes per vertex.
    CompressOptions o;
    o.clusters = 4;
    o.vectors = 2;
    const CompressedTransfer c = compress_transfer(transfer_of(mesh, false, true), o);
    TestLimits cap("GL_MAX_SHADER_STORAGE_BLOCK_SIZE=" + std::to_string(16 * V - 16));
    EXPECT_EQ(message([&] { r->set_mesh(mesh, c); }),
              with("compressed glossy shading of {} vertices binds its radiance (16 bytes per vertex) whole: "
                   "{} bytes; this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes: use a smaller mesh, "
                   "or the uncompressed file",
                   {V, 16 * V, 16 * V - 16}));
  }
  {
    // Compressed rows: one storage buffer, 4 bytes of cluster and 2 of each of 2 weights (16-bit) per row.
    CompressOptions o;
    o.clusters = 4;
    o.vectors = 2;
    o.weight_bits = 16;
    const CompressedTransfer c = compress_transfer(t, o);
    TestLimits cap("GL_MAX_SHADER_STORAGE_BLOCK_SIZE=1024");
    EXPECT_EQ(message([&] { r->set_mesh(mesh, c); }),
              with("compressed coefficients of {} rows need {} bytes on the GPU in one storage buffer (8 per "
                   "row); this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE is 1024 bytes",
                   {rows, rows * 8}));
  }
  {
    // Limits that leave no run at all (16 bytes: one vertex of radiance, not 64).
    TestLimits cap("GL_MAX_SHADER_STORAGE_BLOCK_SIZE=16");
    EXPECT_NE(message([&] { r->set_mesh(mesh, t); }).find("this OpenGL's limits leave no room for a run of the "
                                                           "relighting pass: GL_MAX_COMPUTE_WORK_GROUP_COUNT"),
              std::string::npos);
  }
  {
    TestLimits cap("GL_MAX_TEXTURE_BUFFER_SIZE=lots");
    EXPECT_NE(message([&] { r->set_mesh(mesh, t); }).find("PRT_TEST_GL_LIMITS: 'GL_MAX_TEXTURE_BUFFER_SIZE=lots' is "
                                                           "not NAME=VALUE"),
              std::string::npos);
  }
  // Nothing was left half-uploaded: the renderer takes the mesh afterwards.
  r->set_mesh(mesh, t);
  r->set_lighting(lighting(3));
  test::expect_radiance_near(r->vertex_radiance({0.7, 2.2, 2.4}), relight(t, mesh, lighting(3)), 1e-3, "after");
}

// prt render: a mesh over the dispatch limit renders; one whose transfer
// exceeds the buffer texture limit exits 1 with the renderer's message
// after the transfer file's name, and writes nothing.
TEST(RenderLimits, PrtRenderRendersInRunsOrRefuses) {
  std::string why;
  if (!test::try_renderer(why)) PRT_SKIP_WITHOUT_GL(why);
  test::TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(6));
  const std::string mesh = dir.file("fb.off"), prt = dir.file("fb.prt");
  const auto pre = test::run_prt(dir, {"precompute", mesh, "-o", prt, "-b", "3", "-s", "32", "-q"});
  ASSERT_EQ(pre.code, 0) << test::describe_run(pre);
  const std::string env = PRT_SOURCE_DIR "/envmaps/forest.exr";
  const auto whole = test::run_prt(dir, {"render", mesh, prt, env, "-o", dir.file("whole.exr"), "--width", "48",
                                         "--height", "32", "-q"});
  ASSERT_EQ(whole.code, 0) << test::describe_run(whole);
  const auto runs = test::run_prt(dir, {"render", mesh, prt, env, "-o", dir.file("runs.exr"), "--width", "48",
                                        "--height", "32", "-q"},
                                  {{"PRT_TEST_GL_LIMITS", "GL_MAX_COMPUTE_WORK_GROUP_COUNT=1"}});
  ASSERT_EQ(runs.code, 0) << test::describe_run(runs);
  EXPECT_EQ(test::read_file(dir.file("runs.exr")), test::read_file(dir.file("whole.exr")));
  const auto no = test::run_prt(dir, {"render", mesh, prt, env, "-o", dir.file("no.png"), "-q"},
                                {{"PRT_TEST_GL_LIMITS", "GL_MAX_TEXTURE_BUFFER_SIZE=64"}});
  EXPECT_EQ(no.code, 1) << test::describe_run(no);
  EXPECT_NE(no.err.find("prt render: error: " + prt + ": transfer of "), std::string::npos) << no.err;
  EXPECT_NE(no.err.find("this OpenGL's GL_MAX_TEXTURE_BUFFER_SIZE is 64 texels (1024 bytes)"), std::string::npos)
      << no.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("no.png")));
}

}  // namespace
}  // namespace prt
