// prt precompute / relight / info end to end through the real executable.
#include "test_child.h"
#include "test_files.h"
#include "test_meshes.h"

#include <prt/vertex_csv.h>
#include <prt/compare.h>
#include <prt/render.h>
#include <prt/color.h>
#include <prt/ply.h>
#include <prt/precompute.h>
#include <prt/compression_error.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/subsurface_reference.h>
#include <prt/subsurface_scatter.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <regex>
#include <thread>
#include <tuple>

namespace prt {
namespace {

using namespace prt::test;

// A 4x4-cell quad facing +Y as an OFF file.
std::string write_quad(const TempDir& dir) {
  const std::string path = dir.file("quad.off");
  test::write_off(path, test::quad(4));
  return path;
}

TEST(PrecomputeCli, WhiteFurnaceThroughTheCommandLine) {
  // Albedo 1, unshadowed, constant map of 1: every vertex's radiance is 1
  // (float storage of the transfer: 1e-6).
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  for (const char* mode : {"unshadowed", "shadowed"}) {
    const Result p = run_prt(dir, {"precompute", mesh, "-o", dir.file("q.prt"), "--mode", mode, "--albedo", "1,1,1",
                                   "--samples", "64", "-q"});
    ASSERT_EQ(p.code, 0) << describe_run(p);
    const Result r = run_prt(dir, {"relight", mesh, dir.file("q.prt"), env, "-o", dir.file("q.csv"), "-q"});
    ASSERT_EQ(r.code, 0) << describe_run(r);
    for (const glm::vec3& b : read_vertex_csv(dir.file("q.csv"))) {
      EXPECT_NEAR(b.x, 1.0f, 1e-6f) << mode;
      EXPECT_NEAR(b.z, 1.0f, 1e-6f) << mode;
    }
  }
  // PLY output: written, with the header of a float-colour mesh.
  const Result ply = run_prt(dir, {"relight", mesh, dir.file("q.prt"), env, "-o", dir.file("q.ply"), "-q"});
  ASSERT_EQ(ply.code, 0) << describe_run(ply);
  EXPECT_NE(read_file(dir.file("q.ply")).find("property float red"), std::string::npos);
  const Result info = run_prt(dir, {"info", dir.file("q.prt")});
  EXPECT_EQ(info.code, 0);
  // quad(4) has 5 x 5 = 25 vertices; the last precompute was shadowed, 64 rays, albedo 1.
  for (const char* line : {R"(^  vertices +25$)", R"(^  mode +shadowed$)", R"(^  samples +64$)", R"(^  albedo +1 1 1$)"})
    EXPECT_TRUE(std::regex_search(info.out, std::regex(line, std::regex::multiline))) << line << "\n" << info.out;
}

// --device gpu (docs/PRECOMPUTE.md "On the GPU"): the shadowed transfer of
// the bundled scene traced in OpenGL compute, the file's rows within the
// issue's 1e-3 relative RMS of the CPU's (GpuPrecompute.* measures 4.3e-5:
// rays grazing an edge), rays per second printed; what the GPU does not
// trace refused by name before any work. Skips where EGL gives no context.
// Relative RMS of the transfers in files a and b (dense, over `mesh`).
double pcli_file_rms(const std::string& a, const std::string& b, const Mesh& mesh) {
  const std::vector<float> g = dense_transfer(read_transfer(a), mesh);
  const std::vector<float> c = dense_transfer(read_transfer(b), mesh);
  double e2 = 0, r2 = 0;
  for (std::size_t i = 0; i < g.size(); ++i) e2 += (double(g[i]) - c[i]) * (double(g[i]) - c[i]), r2 += double(c[i]) * c[i];
  return std::sqrt(e2 / r2);
}

// --device gpu against the CPU on the bundled scene, shadowed (the sums
// path) and interreflected (the hits path), within the issue's 1e-3
// relative RMS (rays differ only where they graze an edge); what the GPU
// does not trace is refused before any work; every kind is made.
TEST(PrecomputeCli, DeviceGpuTracesTheTransferAsTheCpu) {
  TempDir dir;
  const std::string mesh = PRT_SOURCE_DIR "/models/scene.obj";
  const Mesh m = load_mesh(mesh);
  for (const char* mode : {"shadowed", "interreflected"}) {
    SCOPED_TRACE(mode);
    const std::vector<std::string> common = {"precompute", mesh, "--mode", mode, "--samples", "32", "--bands", "3"};
    std::vector<std::string> args = common;
    args.insert(args.end(), {"--device", "gpu", "-o", dir.file("g.prt")});
    Result r = run_prt(dir, args);
    if (r.code != 0 && r.err.find("no OpenGL 4.5 context") != std::string::npos) GTEST_SKIP() << r.err;
    ASSERT_EQ(r.code, 0) << describe_run(r);
    EXPECT_NE(r.err.find("device: OpenGL compute on"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("rays/s"), std::string::npos) << r.err;
    args = common;
    args.insert(args.end(), {"-q", "-o", dir.file("c.prt")});
    ASSERT_EQ(run_prt(dir, args).code, 0);
    EXPECT_LT(pcli_file_rms(dir.file("g.prt"), dir.file("c.prt"), m), 1e-3);
  }
  // The kinds not traced per vertex above: a probe volume, a wavelet transfer.
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{PRT_SOURCE_DIR "/models/room.gltf", "--probes", "3x2x3", "--probe-cube", "16"},
        {mesh, "--basis", "wavelet", "--cube-res", "8"}}) {
    std::vector<std::string> args = {"precompute"};
    args.insert(args.end(), extra.begin(), extra.end());
    args.insert(args.end(), {"--device", "gpu", "-o", dir.file("k.prt")});
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 0) << describe_run(r);
    EXPECT_NE(r.err.find("rays/s"), std::string::npos) << r.err;
  }
  const std::vector<std::pair<std::vector<std::string>, std::string>> refused = {
      {{"--subdivide", "0.02"}, "--device gpu: --subdivide"},
      {{"--material", "subsurface", "--sss", "skin1"}, "--device gpu: --material subsurface"},
  };
  for (const auto& [extra, why] : refused) {
    std::vector<std::string> args = {"precompute", mesh, "--device", "gpu", "-o", dir.file("x.prt")};
    args.insert(args.end(), extra.begin(), extra.end());
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 2) << extra.front() << ": " << describe_run(r);
    EXPECT_NE(r.err.find(why), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.prt")));
  }
}

TEST(PrecomputeCli, TransferForAnotherMeshIsRefused) {
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("q.prt"), "-q", "--mode", "unshadowed"}).code, 0);
  test::write_off(dir.file("other.off"), test::quad(3));
  const Result r = run_prt(dir, {"relight", dir.file("other.off"), dir.file("q.prt"), env, "-o", dir.file("o.csv")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("different mesh"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.csv")));
}

TEST(PrecomputeCli, BadOptionsFailBeforeAnyWork) {
  TempDir dir;
  const std::string mesh = write_quad(dir);
  // 2: a bad option value; 1: a bad file (or one an option does not fit).
  const std::vector<std::pair<std::vector<std::string>, int>> cases = {
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--bands", "0"}, 2},
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--bands", "17"}, 2},
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--samples", "0"}, 2},
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--albedo", "2,0,0"}, 2},
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--mode", "ambient"}, 2},
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--vertex-colors"}, 1},  // the mesh has none
      {{"precompute", dir.file("missing.obj"), "-o", dir.file("x.prt")}, 1},
      {{"precompute", mesh, "-o", dir.file("nodir/x.prt")}, 1},
      {{"relight", mesh, dir.file("missing.prt"), dir.file("constant.exr"), "-o", dir.file("x.csv")}, 1},
      {{"relight", mesh, mesh, mesh, "-o", dir.file("x.txt")}, 2},
  };
  for (const auto& [args, code] : cases) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, code) << describe_run(r);
    EXPECT_FALSE(r.err.empty());
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.prt")));
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.csv")));
  }
}

// Counts and choices that were CLI11's own conversions (or none): each
// refused while parsing with what it takes, in prt precompute and prt
// compress. --subdivide-max-vertices took -1 (as 2^64 - 1), '' and 1e20;
// --probe-cube and the weights' bits took '' and named no range; --compress ''
// was taken as not given.
TEST(PrecomputeCli, CountsAndChoicesAreRangeChecked) {
  TempDir dir;
  const std::string missing = dir.file("missing.off"), out = dir.file("x.prt");
  const std::string vertices = "must be a whole number from 0 to 4294967295 (0: 4x the mesh's; a mesh's vertex "
                               "indices are 32-bit), got ";
  struct Option {
    std::vector<std::string> context;  // what the option needs beside it
    std::string option;
    std::vector<std::pair<std::string, std::string>> bad;  // value, message after "--option: "
    std::vector<std::string> good;
  };
  const std::vector<Option> options = {
      {{"precompute", missing, "-o", out, "--subdivide", "0.1"},
       "--subdivide-max-vertices",
       {{"-1", vertices + "'-1'"},
        {"", vertices + "''"},
        {"1e20", vertices + "'1e20'"},
        {"4294967296", vertices + "'4294967296'"},
        {"18446744073709551616", vertices + "'18446744073709551616'"},
        {"2.5", vertices + "'2.5'"},
        {"+5", vertices + "'+5'"}},
       {"0", "1000", "4294967295"}},
      {{"precompute", missing, "-o", out, "--probes", "2x2x2"},
       "--probe-cube",
       {{"3", "must be 4, 8, 16, 32 or 64, got '3'"},
        {"", "must be 4, 8, 16, 32 or 64, got ''"},
        {"1e20", "must be 4, 8, 16, 32 or 64, got '1e20'"},
        {"-4", "must be 4, 8, 16, 32 or 64, got '-4'"},
        {"128", "must be 4, 8, 16, 32 or 64, got '128'"}},
       {"4", "64"}},
      {{"precompute", missing, "-o", out, "--compress", "8x2"},
       "--compress-weights",
       {{"8", "must be 16 or 32, got '8'"}, {"", "must be 16 or 32, got ''"}, {"16.0", "must be 16 or 32, got '16.0'"}},
       {"16", "32"}},
      {{"compress", dir.file("missing.prt"), "-o", out},
       "--weights",
       {{"8", "must be 16 or 32, got '8'"}, {"", "must be 16 or 32, got ''"}},
       {"16", "32"}},
      {{"precompute", missing, "-o", out, "--adaptive"},
       "--verify-adaptive",
       {{"", "must be a number in [0, 1], got ''"},
        {"1.5", "must be a number in [0, 1], got 1.5"},
        {"nan", "must be a number in [0, 1], got nan"}},
       {"0", "0.25", "1"}},
      {{"precompute", missing, "-o", out},
       "--compress",
       {{"", "expected KxN, clusters x principal vectors (e.g. 128x8), got ''"},
        {"16", "expected KxN, clusters x principal vectors (e.g. 128x8), got '16'"},
        {"-1x2", "expected KxN, clusters x principal vectors (e.g. 128x8), got '-1x2'"},
        {"99999999999x2", "expected KxN, clusters x principal vectors (e.g. 128x8), got '99999999999x2'"},
        {"0x8", "K must be 1 to 16777216 and N 0 to 1048576, got '0x8'"},
        {"8x2000000", "K must be 1 to 16777216 and N 0 to 1048576, got '8x2000000'"}},
       {"8x2", "1x0", "128x8"}},
  };
  for (const Option& o : options) {
    for (const auto& [value, message] : o.bad) {
      std::vector<std::string> args = o.context;
      args.insert(args.end(), {o.option, value});
      const Result r = run_prt(dir, args);
      EXPECT_EQ(r.code, 2) << o.option << " '" << value << "'\n" << describe_run(r);
      EXPECT_NE(r.err.find("prt " + o.context[0] + ": error: " + o.option + ": " + message), std::string::npos)
          << o.option << " '" << value << "'\n" << r.err;
    }
    for (const std::string& value : o.good) {  // past the parser: the missing input is what stops it
      std::vector<std::string> args = o.context;
      args.insert(args.end(), {o.option, value});
      const Result r = run_prt(dir, args);
      EXPECT_EQ(r.code, 1) << o.option << " '" << value << "'\n" << describe_run(r);
      EXPECT_NE(r.err.find("missing"), std::string::npos) << o.option << " '" << value << "'\n" << r.err;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(out));
}

// --memory-limit plans an SH transfer's memory: refused where nothing would
// plan with it (it was taken and ignored with --probes and with a wavelet
// lightmap), taken where the plan is.
TEST(PrecomputeCli, MemoryLimitIsRefusedWhereItWouldBeIgnored) {
  TempDir dir;
  const std::string room = PRT_SOURCE_DIR "/models/room.gltf", out = dir.file("x.prt");
  const std::vector<std::pair<std::vector<std::string>, std::string>> refused = {
      {{"precompute", room, "-o", out, "--probes", "3x3x3", "--memory-limit", "4G"},
       "--memory-limit does not apply to --probes: it plans the memory of an SH transfer at vertices or texels"},
      {{"precompute", room, "-o", out, "--lightmap", "16x16", "--basis", "wavelet", "--memory-limit", "4G"},
       "--memory-limit does not apply to --basis wavelet: it plans the memory of an SH transfer at vertices or texels"},
      {{"precompute", room, "-o", out, "--basis", "wavelet", "--memory-limit", "4G"},
       "--memory-limit does not apply to --basis wavelet"},
  };
  for (const auto& [args, message] : refused) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 2) << describe_run(r);
    EXPECT_NE(r.err.find("prt precompute: error: " + message), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("leave --memory-limit out"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(out));
  // Vertices, lightmaps and zonal harmonics plan with it.
  const std::string quad = write_quad(dir);
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"precompute", quad, "-o", out, "--samples", "16", "--memory-limit", "2G", "-q"},
        std::vector<std::string>{"precompute", quad, "-o", out, "--samples", "16", "--memory-limit", "2G", "--basis",
                                 "zh", "-q"},
        std::vector<std::string>{"precompute", room, "-o", out, "--lightmap", "16x16", "--samples", "16",
                                 "--memory-limit", "2G", "-q"}}) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 0) << describe_run(r);
  }
}

// A lightmap's memory is planned from its atlas before the atlas is
// rasterised: a 16384x16384 atlas of the room (200M covered texels) ran past
// 20 s and 17 GB before its plan refused the limit, 8192x8192 under 100M
// peaked at 1.6 GB. Now both are refused in prt's start-up memory, naming the
// smallest limit that could work; that limit passes this check (the plan
// after rasterising, with the exact texels, may still ask for more).
TEST(PrecomputeCli, LightmapMemoryIsPlannedBeforeRasterising) {
  TempDir dir;
  const std::string room = PRT_SOURCE_DIR "/models/room.gltf", out = dir.file("x.prt");
  const std::string early = "refused before the texels are rasterised";
  const std::vector<std::vector<std::string>> refused = {
      {"--lightmap", "16384x16384", "--memory-limit", "16G"},
      {"--lightmap", "8192x8192", "--memory-limit", "100M"},
      {"--lightmap", "8192x8192", "--memory-limit", "100M", "--adaptive"},
      {"--lightmap", "8192x8192", "--memory-limit", "1G", "--mode", "interreflected"},
  };
  for (const std::vector<std::string>& extra : refused) {
    std::vector<std::string> args = {"precompute", room, "-o", out, "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const BoundedResult r = run_prt_bounded(dir, args, 60);
    const std::string what = extra[1] + " " + extra[3] + (extra.size() > 4 ? " " + extra[4] : "");
    EXPECT_FALSE(r.timed_out) << what;
    EXPECT_EQ(r.code, 1) << what << "\n" << describe_run(r);
    EXPECT_NE(r.err.find("prt precompute: error: --memory-limit "), std::string::npos) << what << "\n" << r.err;
    EXPECT_NE(r.err.find(": too small for a " + extra[1] + " lightmap of " + room + " (at least "), std::string::npos)
        << what << "\n" << r.err;
    EXPECT_NE(r.err.find(early), std::string::npos) << what << "\n" << r.err;
    EXPECT_LT(r.max_rss_kb, kRefusalRssKb) << what << ": peak RSS " << r.max_rss_kb << " KiB";
    EXPECT_FALSE(std::filesystem::exists(out)) << what;
  }
  // The limit the refusal names passes the check before rasterising.
  for (const char* mode : {"shadowed", "interreflected"}) {
    const Result small = run_prt(dir, {"precompute", room, "-o", out, "--lightmap", "256x256", "--memory-limit", "1M",
                                       "--mode", mode, "--samples", "16", "-q"});
    ASSERT_EQ(small.code, 1) << describe_run(small);
    std::smatch m;
    ASSERT_TRUE(std::regex_search(small.err, m, std::regex(R"(\(--memory-limit (\d+)M, or a smaller atlas\))")))
        << small.err;
    const Result at = run_prt(dir, {"precompute", room, "-o", out, "--lightmap", "256x256", "--memory-limit",
                                    m[1].str() + "M", "--mode", mode, "--samples", "16", "-q"});
    EXPECT_EQ(at.err.find(early), std::string::npos) << mode << " at " << m[1] << "M:\n" << at.err;
    // Done, or refused by the plan with the exact texels (after rasterising).
    EXPECT_TRUE(at.code == 0 || at.err.find("too small for " + room + " (") != std::string::npos)
        << mode << "\n" << describe_run(at);
  }
}

// Glossy end to end: precompute --material glossy writes a version 3 file
// whose relighting through `prt relight --eye` is the library's
// relight_glossy of the same inputs (float CSV: 1e-6 relative).
TEST(PrecomputeCli, GlossyThroughTheCommandLine) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(6));
  const std::string mesh = dir.file("fb.off"), env = write_constant_map(dir, 1.0f);
  for (const char* mode : {"shadowed", "interreflected"}) {
    const Result p = run_prt(dir, {"precompute", mesh, "-o", dir.file("g.prt"), "--material", "glossy", "--mode", mode,
                                   "--bands", "4", "--samples", "128", "--albedo", "0.9,0.6,0.3", "-q"});
    ASSERT_EQ(p.code, 0) << describe_run(p);
    std::uint32_t version = 0;
    EXPECT_EQ(kind_of(read_transfer_file(dir.file("g.prt"), &version)), TransferKind::SH);
    EXPECT_EQ(version, 3u);
    const Result r = run_prt(dir, {"relight", mesh, dir.file("g.prt"), env, "-o", dir.file("g.csv"), "--eye",
                                   "0.5,2,1", "--gloss", "12", "--specular", "0.4", "-q"});
    ASSERT_EQ(r.code, 0) << describe_run(r);
    const Mesh m = load_mesh(mesh);
    const Transfer t = read_transfer(dir.file("g.prt"));
    GlossyShading s;
    s.eye = {0.5, 2, 1};
    s.gloss = 12;
    s.specular = 0.4;
    const std::vector<glm::vec3> want = relight_glossy(t, m, project(load_envmap(env), 4), s);
    const std::vector<glm::vec3> got = read_vertex_csv(dir.file("g.csv"));
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t v = 0; v < got.size(); ++v)
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[v][c], want[v][c], 1e-6 * (1 + std::abs(want[v][c]))) << mode << v;
    const Result info = run_prt(dir, {"info", dir.file("g.prt")});
    EXPECT_NE(info.out.find("glossy matrices"), std::string::npos) << info.out;
    const Result json = run_prt(dir, {"info", dir.file("g.prt"), "--json"});
    EXPECT_NE(json.out.find("\"material\": \"glossy\""), std::string::npos) << json.out;
    EXPECT_NE(json.out.find(std::string("\"floats_per_stored_vertex\": ") +
                            (std::string(mode) == "shadowed" ? "136" : "768")),
              std::string::npos)
        << json.out;
  }
}

TEST(PrecomputeCli, GlossyOptionsAreChecked) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(4));
  const std::string mesh = dir.file("fb.off"), env = write_constant_map(dir, 1.0f);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("d.prt"), "--bands", "3", "--samples", "32", "-q"}).code, 0);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("ir.prt"), "--bands", "3", "--samples", "32", "--mode",
                          "interreflected", "--material", "glossy", "-q"})
                .code,
            0);
  const std::string out = dir.file("x.csv");
  // exit status, words of the message
  const std::vector<std::tuple<std::vector<std::string>, int, std::string>> cases = {
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--material", "glossy", "--mode", "unshadowed"}, 2, "shadowed or interreflected"},
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--material", "glossy", "--bands", "13"}, 2, "at most 12"},
      {{"precompute", mesh, "-o", dir.file("x.prt"), "--material", "shiny"}, 2, "--material"},
      {{"relight", mesh, dir.file("d.prt"), env, "-o", out, "--gloss", "3"}, 2, "needs --eye"},
      {{"relight", mesh, dir.file("d.prt"), env, "-o", out, "--eye", "0,1,0"}, 1, "no glossy matrices"},
      {{"relight", mesh, dir.file("ir.prt"), env, "-o", out, "--eye", "0,1,0", "--diffuse", "2"}, 2, "--diffuse: expected one number or r,g,b, each from 0 to 1 (an albedo)"},
      {{"relight", mesh, dir.file("ir.prt"), env, "-o", out, "--eye", "0,1,0", "--diffuse", "0.5"}, 1, "albedo 0.8"},
      {{"relight", mesh, dir.file("ir.prt"), env, "-o", out, "--eye", "0,1,0", "--gloss", "-1"}, 2, "--gloss"},
      {{"relight", mesh, dir.file("ir.prt"), env, "-o", out, "--eye", "0,nan,0"}, 2, "--eye"},
      {{"reference", mesh, env, "-o", out, "--material", "glossy"}, 2, "needs --eye"},
      {{"reference", mesh, env, "-o", out, "--gloss", "4"}, 2, "--material glossy only"},
  };
  for (const auto& [args, code, words] : cases) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, code) << describe_run(r);
    EXPECT_NE(r.err.find(words), std::string::npos) << describe_run(r);
    EXPECT_FALSE(std::filesystem::exists(out));
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.prt")));
  }
  // The glossy reference and prt compare on its output.
  const Result ref = run_prt(dir, {"reference", mesh, env, "-o", dir.file("ref.csv"), "--material", "glossy", "--eye",
                                   "0,2,1", "--samples", "16", "-q"});
  ASSERT_EQ(ref.code, 0) << describe_run(ref);
  EXPECT_EQ(read_vertex_csv(dir.file("ref.csv")).size(), load_mesh(mesh).vertex_count());
}

// prt reference --material subsurface: the library's numbers in the
// reference's CSV (docs/SUBSURFACE.md "The reference"), and what does not
// apply to a translucent material refused before any work.
TEST(PrecomputeCli, SubsurfaceReferenceThroughTheCommandLine) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(4));
  const std::string mesh = dir.file("fb.off"), env = write_constant_map(dir, 1.0f), out = dir.file("s.csv");
  const Result r = run_prt(dir, {"reference", mesh, env, "-o", out, "--material", "subsurface", "--sss", "marble",
                                 "--length-scale", "10", "--samples", "4", "--mode", "interreflected", "--bounces",
                                 "1", "-t", "2"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("marble: sigma_a 0.0021"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("4 iterations/vertex"), std::string::npos) << r.err;
  std::vector<glm::vec3> se;
  const std::vector<glm::vec3> got = read_vertex_csv(out, &se);
  ReferenceOptions o;
  o.samples = 4;
  o.mode = TransferMode::Interreflected;
  o.bounces = 1;
  const ReferenceResult want =
      render_subsurface_reference(load_mesh(mesh), load_envmap(env), o, SubsurfaceRecord{*subsurface_preset("marble"), 10.0});
  ASSERT_EQ(got.size(), want.radiance.size());
  ASSERT_EQ(se.size(), want.std_error.size());
  for (std::size_t v = 0; v < got.size(); ++v)
    for (int c = 0; c < 3; ++c) {
      // The CSV's text holds a float to 1e-6 relative (or better).
      EXPECT_NEAR(got[v][c], want.radiance[v][c], 1e-6 * std::abs(want.radiance[v][c]) + 1e-12) << v;
      EXPECT_NEAR(se[v][c], want.std_error[v][c], 1e-6 * std::abs(want.std_error[v][c]) + 1e-12) << v;
    }
  const std::string x = dir.file("x.csv");
  const std::vector<std::string> sss = {"--material", "subsurface", "--sss", "skin1"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = {"reference", mesh, env, "-o", x};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  auto plus = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = sss;
    args.insert(args.end(), extra.begin(), extra.end());
    return with(args);
  };
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {plus({"--mode", "unshadowed"}), "--mode unshadowed does not apply to --material subsurface"},
      {plus({"--albedo", "0.5,0.5,0.5"}), "--albedo does not apply to --material subsurface"},
      {plus({"--vertex-colors"}), "--vertex-colors does not apply"},
      {plus({"--uv", "1"}), "--uv picks the lightmap's UV set: give --lightmap WxH too"},
      {plus({"--sun", "auto"}), "--lights and --sun do not apply"},
      {plus({"--eye", "0,1,0"}), "--material glossy only"},
      {with({"--sss", "marble"}), "--sss needs --material subsurface"},
      {with({"--material", "subsurface"}), "needs --sss NAME"},
      {with({"--material", "subsurface", "--sss", "jade"}), "--sss: expected one of apple, chicken1"},
  };
  for (const auto& [args, words] : cases) {
    const Result q = run_prt(dir, args);
    EXPECT_EQ(q.code, 2) << describe_run(q);
    EXPECT_NE(q.err.find(words), std::string::npos) << describe_run(q);
    EXPECT_FALSE(std::filesystem::exists(x));
  }
}

// prt precompute --material subsurface: the library's transfer in the file,
// with the material on prt info's line, relit by prt relight as any RGB
// transfer; what does not apply refused by name before any work.
TEST(PrecomputeCli, SubsurfaceTransferThroughTheCommandLine) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(6));
  const std::string mesh = dir.file("fb.off"), env = write_constant_map(dir, 1.0f), out = dir.file("s.prt");
  const Result r = run_prt(dir, {"precompute", mesh, "-o", out, "--material", "subsurface", "--sss", "skin1",
                                 "--eta", "1.4", "--length-scale", "10", "--samples", "64", "--bands", "3", "--mode",
                                 "interreflected", "-t", "2"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("material: subsurface, skin1 (modified): sigma_a 0.032"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("wrote " + out + ": subsurface (interreflected), 3 bands, 3 channels"), std::string::npos)
      << r.err;
  const Transfer t = read_transfer(out);
  SubsurfaceMaterial m = *subsurface_preset("skin1");
  m.name = "skin1 (modified)";
  m.eta = 1.4;
  ASSERT_TRUE(t.subsurface.has_value());
  EXPECT_EQ(*t.subsurface, (SubsurfaceRecord{m, 10.0}));
  TransferOptions o;
  o.samples = 64;
  o.bands = 3;
  o.mode = TransferMode::Interreflected;
  SubsurfaceScatterOptions so;
  so.length_scale = 10.0;
  const Transfer want = compute_subsurface_transfer(load_mesh(mesh), o, m, so);
  EXPECT_EQ(t.coeffs, want.coeffs);  // the same bits: one computation
  const Result info = run_prt(dir, {"info", out});
  EXPECT_NE(info.out.find("subsurface, skin1 (modified): sigma_a 0.032, 0.17, 0.48 /mm"), std::string::npos)
      << info.out;
  const Result lit = run_prt(dir, {"relight", mesh, out, env, "-o", dir.file("s.csv"), "-q"});
  ASSERT_EQ(lit.code, 0) << describe_run(lit);
  EXPECT_EQ(read_vertex_csv(dir.file("s.csv")).size(), load_mesh(mesh).vertex_count());
  const std::string x = dir.file("x.prt");
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = {"precompute", mesh, "-o", x, "--material", "subsurface", "--sss", "marble"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {with({"--mode", "unshadowed"}), "--material subsurface is shadowed or interreflected"},
      {with({"--basis", "wavelet"}), "--basis wavelet does not apply to --material subsurface"},
      {with({"--albedo", "0.5,0.5,0.5"}), "--albedo does not apply to --material subsurface"},
      {with({"--vertex-colors"}), "--vertex-colors does not apply"},
      {with({"--lightmap", "16x16", "--ao-map", dir.file("ao.exr")}), "--ao-map does not apply to --material subsurface"},
      {with({"--probes", "2x2x2"}), "--probes does not apply"},
      {with({"--adaptive"}), "--adaptive does not apply"},
      {with({"--target-error", "0.1", "--env", env}), "--target-error does not apply"},
      {{"precompute", mesh, "-o", x, "--sigma-a", "1,1,1"}, "--sigma-a needs --material subsurface"},
      {{"precompute", mesh, "-o", x, "--material", "subsurface", "--sigma-a", "1,1,1"}, "both --sigma-a and --sigma-s"},
      {{"precompute", mesh, "-o", x, "--material", "subsurface", "--sigma-a", "0,0,0", "--sigma-s", "0,1,1"},
       "sigma_a + sigma_s' (red) must be > 0"},
  };
  for (const auto& [args, words] : cases) {
    const Result q = run_prt(dir, args);
    EXPECT_EQ(q.code, 2) << describe_run(q);
    EXPECT_NE(q.err.find(words), std::string::npos) << describe_run(q);
    EXPECT_FALSE(std::filesystem::exists(x));
  }
}

// prt precompute SCENE --lightmap WxH --material subsurface: the library's
// translucent lightmap (compute_subsurface_lightmap) in the file, named by
// prt info, relit by prt relight into the atlas.
TEST(PrecomputeCli, SubsurfaceLightmapThroughTheCommandLine) {
  TempDir dir;
  const std::string scene = std::string(PRT_SOURCE_DIR) + "/models/room.gltf", out = dir.file("l.prt");
  const Result r = run_prt(dir, {"precompute", scene, "--lightmap", "24x24", "-o", out, "--material", "subsurface",
                                 "--sss", "ketchup", "--length-scale", "40", "--samples", "32", "--bands", "3", "-t", "2"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("material: subsurface, ketchup: sigma_a 0.061"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("wrote " + out + ": lightmap 24x24, shadowed 3 bands, 3 channels"), std::string::npos) << r.err;
  const LightmapTransfer got = read_lightmap_transfer(out);
  const Scene s = load_scene(scene);
  LightmapTexels texels = lightmap_texels(s, 24, 24, s.lightmap_uv_set());
  move_texels_out_of_geometry(s.mesh, texels);
  TransferOptions o;
  o.samples = 32;
  o.bands = 3;
  SubsurfaceScatterOptions so;
  so.length_scale = 40.0;
  const LightmapTransfer want = compute_subsurface_lightmap(s, texels, o, *subsurface_preset("ketchup"), so);
  EXPECT_EQ(got.transfer.coeffs, want.transfer.coeffs);  // the same bits: one computation
  EXPECT_EQ(got.layout.texels, want.layout.texels);
  const Result info = run_prt(dir, {"info", out});
  EXPECT_NE(info.out.find("material          subsurface, ketchup"), std::string::npos) << info.out;
  const std::string env = write_constant_map(dir, 1.0f);
  const Result lit = run_prt(dir, {"relight", scene, out, env, "-o", dir.file("l.exr"), "-q"});
  ASSERT_EQ(lit.code, 0) << describe_run(lit);
  EXPECT_TRUE(std::filesystem::exists(dir.file("l.exr")));
  // The reference at the same texels (each at its point on its triangle),
  // as the library computes it, and prt compare between the two.
  const Result ref = run_prt(dir, {"reference", scene, env, "--lightmap", "24x24", "--material", "subsurface", "--sss",
                                   "ketchup", "--length-scale", "40", "--samples", "4", "-o", dir.file("r.exr"), "-q"});
  ASSERT_EQ(ref.code, 0) << describe_run(ref);
  const RgbaImage image = read_exr_rgba(dir.file("r.exr"));
  ReferenceOptions ro;
  ro.samples = 4;
  const ReferenceResult direct = render_subsurface_reference_at_points(
      s.mesh, load_envmap(env), ro, SubsurfaceRecord{*subsurface_preset("ketchup"), 40.0},
      texel_surface_points(s.mesh, texels), texels.normals);
  ASSERT_EQ(direct.radiance.size(), texels.layout.texels.size());
  for (std::size_t i = 0; i < direct.radiance.size(); i += 37)
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(image.rgba[4 * std::size_t(texels.layout.texels[i]) + std::size_t(c)], direct.radiance[i][c]) << i;
  const Result cmp = run_prt(dir, {"compare", dir.file("l.exr"), dir.file("r.exr")});
  EXPECT_EQ(cmp.code, 0) << describe_run(cmp);
}

// The band limit says why it is 16 (docs/CONVENTIONS.md, "Band counts"),
// not just that it is.
TEST(PrecomputeCli, BandLimitSaysWhy) {
  TempDir dir;
  const Result r = run_prt(dir, {"precompute", write_quad(dir), "-o", dir.file("x.prt"), "--bands", "20"});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("from 1 to 16"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("prt render and prt view draw at most 16 bands"), std::string::npos) << r.err;
}

TEST(PrecomputeCli, CtrlCLeavesNothingBehind) {
  // A job long enough to interrupt: the bundled model at many rays per
  // vertex, interrupted at its first progress line ("rays: 0% ...").
  TempDir dir;
  const std::string out = dir.file("big.prt");
  const std::string model = std::string(PRT_SOURCE_DIR) + "/models/scene.obj";
  const auto r = run_prt_interrupted(dir, {"precompute", model, "-o", out, "--samples", "65536"}, "rays: 0%");
  EXPECT_TRUE(r.marker_seen) << describe_run(r);
  EXPECT_EQ(r.code, 130) << "killed by a signal instead of stopping cleanly? " << describe_run(r);
  EXPECT_NE(r.err.find("prt precompute: interrupted; nothing written"), std::string::npos) << r.err;
  EXPECT_TRUE(dir.listing().empty()) << "left: " << dir.listing().front();
}

// ---- malformed input (docs/HARD_CASES.md, "Malformed input") ----------------------

template <typename T>
std::string le_bytes(T v) {
  std::string b(sizeof v, '\0');
  std::memcpy(b.data(), &v, sizeof v);
  return b;
}

struct Hostile {
  std::string name, bytes, message;  // the file, its contents, what the refusal says
};

// The bad-input campaign's meshes: each crashed, hung, allocated gigabytes
// or was read as something else before the structure checks.
std::vector<Hostile> hostile_meshes() {
  const std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::string vertices;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) vertices += le_bytes(f);
  std::string face255(1, char(255));
  for (std::int32_t i : {0, 1, 2}) face255 += le_bytes(i);
  std::string big_ply = ply;
  big_ply.replace(big_ply.find("vertex 3"), 8, "vertex 100000000");
  std::string ascii = ply;
  ascii.replace(ascii.find("binary_little_endian"), 20, "ascii");
  ascii.replace(ascii.find("vertex 3"), 8, "vertex 5");
  ascii.replace(ascii.find("face 1"), 6, "face 2");
  std::string glb = "glTF" + le_bytes<std::uint32_t>(2) + le_bytes<std::uint32_t>(86) +
                    le_bytes<std::uint32_t>(0xFFFFFFF0u) + "JSON" + R"({"asset":{"version":"2.0"}})";
  glb.resize(86, ' ');
  // Two quads; one index (9) beyond the 6 vertices: Assimp dropped that
  // triangle. The buffer, base64: six float positions, twelve u16 indices.
  std::string buffer;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 1.f, 0.f, 0.f, 1.f, 0.f, 2.f, 0.f, 0.f, 2.f, 1.f, 0.f})
    buffer += le_bytes(f);
  for (std::uint16_t i : {0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 9}) buffer += le_bytes(i);
  static const char* tab = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string b64;
  for (std::size_t i = 0; i < buffer.size(); i += 3) {  // 96 bytes: no padding
    const std::uint32_t v = std::uint32_t(std::uint8_t(buffer[i])) << 16 | std::uint32_t(std::uint8_t(buffer[i + 1])) << 8 |
                            std::uint8_t(buffer[i + 2]);
    for (int k = 18; k >= 0; k -= 6) b64 += tab[(v >> k) & 63];
  }
  const std::string gltf =
      R"({"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
      "buffers": [{"byteLength": 96, "uri": "data:application/octet-stream;base64,)" + b64 + R"("}],
      "bufferViews": [{"buffer": 0, "byteLength": 72}, {"buffer": 0, "byteOffset": 72, "byteLength": 24}],
      "accessors": [{"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3"},
                    {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]})";
  return {
      {"nodata.ply", ply, "the header declares 3 vertex and 1 face entries, which take at least 37 bytes, but only 0"},
      {"count255.ply", ply + vertices + face255, "truncated: the data ends in face 0 of the 1 its header declares"},
      {"short.ply", ply + vertices.substr(0, 20), "which take at least 37 bytes, but only 20 bytes follow it"},
      {"big.ply", big_ply + vertices, "100000000 vertex and 1 face entries, which take at least 1200000001 bytes"},
      {"noend.ply", "ply\nformat ascii 1.0\n", "has no end_header"},
      {"five.ply", ascii + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n", "line 13: vertex 3 has 4 values"},
      {"faces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "the file ends after 1 of the 2 faces"},
      {"big.off", "OFF\n100000000 1 0\n0 0 0\n", "declares 100000000 vertices and 1 faces, which take at least"},
      {"q.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 q 2\n", "line 6: face 0 uses vertex 'q', which is not a"},
      {"half.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", "line 6: face 0 uses vertex '1.5', which is not"},
      {"bomb.glb", glb, "GLB chunk 0 (JSON) declares 4294967280 bytes, but only 66 follow its header"},
      {"dropped.gltf", gltf, "mesh 0 primitive 0 uses vertex 9 (index 11 of accessor 1), out of range"},
  };
}

// Expects `r` to have exited with `code`, naming `file` with `message`, and
// the test's directory to hold only `inputs` (nothing written, no temporary).
void expect_refused(const TempDir& dir, const Result& r, int code, const std::string& file, const std::string& message,
                    std::vector<std::string> inputs, const std::string& what) {
  EXPECT_EQ(r.code, code) << what << "\n" << describe_run(r);
  EXPECT_NE(r.err.find(file + ": "), std::string::npos) << what << ": does not name " << file << "\n" << r.err;
  EXPECT_NE(r.err.find(message), std::string::npos) << what << ": expected '" << message << "'\n" << r.err;
  std::sort(inputs.begin(), inputs.end());
  EXPECT_EQ(dir.listing(), inputs) << what << ": something was written";
}

// ---- prt compress (docs/COMPRESSION.md) ------------------------------------------------

std::string repo_envmap(const std::string& name) { return std::string(PRT_SOURCE_DIR) + "/envmaps/" + name; }

std::string stderr_number_after(const std::string& err, const std::string& label) {
  const std::size_t at = err.find(label);
  if (at == std::string::npos) return {};
  return err.substr(at + label.size(), err.find('\n', at) - at - label.size());
}

// prt compress's default spectra (--spectra): the bundled maps', at `bands`.
std::vector<NamedLighting> bundled_spectra(int bands) {
  std::vector<NamedLighting> s;
  for (const char* name : {"city", "courtyard", "forest", "studio", "sunset"})
    s.push_back({name, project(load_envmap(repo_envmap(std::string(name) + ".exr")), bands)});
  return s;
}

TEST(CompressCli, CompressRelightInfoAndPrecomputeAgreeWithTheLibrary) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(6));
  const std::string mesh = dir.file("fb.off"), env = repo_envmap("forest.exr");
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("t.prt"), "--material", "glossy", "--bands", "3",
                          "--samples", "128", "-q"}).code, 0);
  const Result c = run_prt(dir, {"compress", dir.file("t.prt"), "-o", dir.file("c.prt"), "--clusters", "4", "--pca",
                                 "3", "--glossy-clusters", "5", "--glossy-pca", "2", "--weights", "32", "--mesh", mesh,
                                 "--env", env});
  ASSERT_EQ(c.code, 0) << describe_run(c);
  // The library, on the same file and options: the same bytes.
  const Transfer t = read_transfer(dir.file("t.prt"));
  CompressOptions o;
  o.clusters = 4;
  o.vectors = 3;
  o.glossy_clusters = 5;
  o.glossy_vectors = 2;
  o.weight_bits = 32;
  const CompressedTransfer lib = compress_transfer(t, o);
  EXPECT_EQ(lib.glossy.clusters, 5);
  write_compressed_transfer(dir.file("lib.prt"), lib);
  EXPECT_EQ(read_file(dir.file("c.prt")), read_file(dir.file("lib.prt")));
  // The error it printed is the meter's over the command's distribution
  // (the one map under 24 rotations taking on the bundled maps' spectra, the
  // sun, 32 eyes), printed to 3 decimals in %.
  const Mesh m = load_mesh(mesh);
  ErrorDistribution d;
  d.maps.push_back({"forest", project(load_envmap(env), 3)});
  d.spectra = bundled_spectra(3);
  const ErrorStats want = CompressionErrorMeter(t, m, d)(lib, true);
  for (const auto& [after, value] : {std::pair{"p95 ", want.p95}, std::pair{"exceeds it) ", want.bound}}) {
    const std::string printed = stderr_number_after(c.err, after);
    ASSERT_FALSE(printed.empty()) << after << c.err;
    EXPECT_NEAR(std::stod(printed), 100 * value, 0.0005 + 1e-9) << after << c.err;
  }
  // relight of the compressed file: the library's per-cluster relighting.
  const Result r = run_prt(dir, {"relight", mesh, dir.file("c.prt"), env, "-o", dir.file("c.csv"), "--eye", "0.5,2,1",
                                 "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  GlossyShading s;
  s.eye = {0.5, 2, 1};
  const std::vector<glm::vec3> lit = relight_glossy(read_compressed_transfer(dir.file("c.prt")), m,
                                                    project(load_envmap(env), 3), s);
  const std::vector<glm::vec3> got = read_vertex_csv(dir.file("c.csv"));
  ASSERT_EQ(got.size(), lit.size());
  for (std::size_t v = 0; v < got.size(); ++v)
    for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(got[v][ch], lit[v][ch], 1e-6 * (1 + std::abs(lit[v][ch]))) << v;
  // info names the clusters, in text and JSON.
  const Result info = run_prt(dir, {"info", dir.file("c.prt")});
  EXPECT_NE(info.out.find("4 clusters x 3 principal vectors"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("5 clusters x 2 principal vectors"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("format version 4"), std::string::npos) << info.out;
  const Result json = run_prt(dir, {"info", dir.file("c.prt"), "--json"});
  EXPECT_NE(json.out.find("\"glossy_matrices\""), std::string::npos) << json.out;
  // precompute --compress KxN (both signals): the same file as precompute, then compress_transfer.
  const Result p = run_prt(dir, {"precompute", mesh, "-o", dir.file("p.prt"), "--material", "glossy", "--bands", "3",
                                 "--samples", "128", "--compress", "4x3", "--compress-weights", "32", "-q"});
  ASSERT_EQ(p.code, 0) << describe_run(p);
  o.glossy_clusters = 0;
  o.glossy_vectors = -1;
  write_compressed_transfer(dir.file("lib2.prt"), compress_transfer(t, o));
  EXPECT_EQ(read_file(dir.file("p.prt")), read_file(dir.file("lib2.prt")));
}

TEST(CompressCli, TargetErrorChoosesTheLibrarysChoiceAndSaysWhy) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(6));
  const std::string mesh = dir.file("fb.off"), env = repo_envmap("studio.exr");
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("t.prt"), "--bands", "4", "--samples", "128", "-q"}).code,
            0);
  const Result c = run_prt(dir, {"compress", dir.file("t.prt"), "-o", dir.file("c.prt"), "--target-error", "0.02",
                                 "--mesh", mesh, "--env", env});
  ASSERT_EQ(c.code, 0) << describe_run(c);
  const Transfer t = read_transfer(dir.file("t.prt"));
  const Mesh m = load_mesh(mesh);
  ErrorDistribution d;  // the command's: the one map under 24 rotations, taking on the bundled maps' spectra; the sun
  d.maps.push_back({"studio", project(load_envmap(env), 4)});
  d.spectra = bundled_spectra(4);
  ChoiceOptions o;
  o.target = 0.02;
  const CompressionChoice want = choose_compression(t, m, d, o);
  // The explanation up to its timings, and the figures after them.
  const std::string head = want.explanation.substr(0, want.explanation.find(" search:"));
  const std::string tail = want.explanation.substr(want.explanation.find("\ndiffuse radiance"));
  EXPECT_NE(c.err.find(head), std::string::npos) << c.err << "\nwanted: " << head;
  EXPECT_NE(c.err.find(tail), std::string::npos) << c.err << "\nwanted: " << tail;
  const CompressedTransfer got = read_compressed_transfer(dir.file("c.prt"));
  EXPECT_EQ(got.coeffs.clusters, want.compressed.coeffs.clusters);
  EXPECT_EQ(got.coeffs.vectors, want.compressed.coeffs.vectors);
  EXPECT_LE(want.whole.p95, 0.02);
  // A compression no smaller than the rows it replaces is said to be (here,
  // a mesh of a few hundred vertices, it is).
  const std::size_t stored = 4 * t.coeffs.size(), packed = got.coeffs.bytes();
  EXPECT_EQ(c.err.find("the uncompressed " + dir.file("t.prt") + " is smaller") != std::string::npos, packed >= stored)
      << c.err << "\n" << packed << " bytes for " << stored;
  // The file records what it was chosen for, and prt info says it.
  ASSERT_TRUE(got.choice.has_value());
  EXPECT_EQ(compression_choice_json(*got.choice), compression_choice_json(*want.compressed.choice));
  const Result info = run_prt(dir, {"info", dir.file("c.prt")});
  ASSERT_EQ(info.code, 0) << describe_run(info);
  for (const char* w : {"format version 6", "chosen for a p95 relit error of at most 2%", "1 map (studio) x 24 rotations",
                        "those of city, courtyard, forest, studio, sunset in turn",
                        "and a point light (the sun) x 24 rotations"})
    EXPECT_NE(info.out.find(w), std::string::npos) << w << " in " << info.out;
  const Result json = run_prt(dir, {"info", dir.file("c.prt"), "--json"});
  ASSERT_EQ(json.code, 0) << describe_run(json);
  for (const char* w : {"\"choice\": {", "\"target\": 0.02,", "\"spectra\": [", "\"measured\": {"})
    EXPECT_NE(json.out.find(w), std::string::npos) << w << " in " << json.out;
  // --measure: the file's error under another map (the meter's, to the 3
  // decimals in % it prints), on stdout; nothing written.
  const std::string other = repo_envmap("sunset.exr");
  const Result m2 = run_prt(dir, {"compress", dir.file("t.prt"), "--measure", dir.file("c.prt"), "--mesh", mesh, "--env",
                                  other, "-q"});
  ASSERT_EQ(m2.code, 0) << describe_run(m2);
  ErrorDistribution held;  // --measure: the map as given, no spectra, no sun
  held.sun = false;
  held.maps.push_back({"sunset", project(load_envmap(other), 4)});
  const ErrorStats e = CompressionErrorMeter(t, m, held)(got, true);
  const std::string printed = stderr_number_after(m2.out, "p95 ");
  ASSERT_FALSE(printed.empty()) << m2.out;
  EXPECT_NEAR(std::stod(printed), 100 * e.p95, 0.0005 + 1e-9) << m2.out;
  EXPECT_GT(e.p95, 0.0);
}

TEST(CompressCli, BadUseIsRefusedAndWritesNothing) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(4));
  const std::string mesh = dir.file("fb.off"), env = repo_envmap("studio.exr"), in = dir.file("t.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", in, "--bands", "3", "--samples", "32", "-q"}).code, 0);
  ASSERT_EQ(run_prt(dir, {"compress", in, "-o", dir.file("c.prt"), "-q"}).code, 0);
  struct Case {
    std::vector<std::string> args;
    int code;
    std::string words;
  };
  const std::string out = dir.file("out.prt");
  const std::vector<Case> cases = {
      {{"compress", dir.file("c.prt"), "-o", out}, 1, "already compressed"},
      {{"compress", in, "-o", out, "--target-error", "0.01"}, 2, "needs --mesh MESH"},
      {{"compress", in, "-o", out, "--target-error", "0.01", "--clusters", "4", "--mesh", mesh, "--env", env}, 2,
       "give the target or the sizes"},
      {{"compress", in, "-o", out, "--weights", "8"}, 2, "--weights"},
      {{"compress", in, "-o", out, "--eyes", "4"}, 2, "--eyes shapes the lightings and views"},
      {{"compress", in, "--measure", dir.file("c.prt"), "-o", out, "--mesh", mesh}, 2, "--measure writes nothing"},
      {{"compress", in, "--measure", dir.file("c.prt")}, 2, "--measure needs --mesh"},
      {{"compress", in}, 2, "--output is required"},
      {{"compress", in, "-o", out, "--metric", "plain"}, 2, "--metric is for --target-error"},
      {{"compress", in, "-o", out, "--spectra", env}, 2, "--spectra shapes the lightings"},
      {{"compress", in, "-o", out, "--no-sun"}, 2, "--no-sun shapes the lightings"},
      {{"compress", in, "-o", out, "--target-error", "0.01", "--mesh", mesh, "--own-spectra", "--spectra", env}, 2,
       "give one of them"},
      {{"compress", in, "-o", in}, 2, "is the input IN"},
      {{"compress", in, "-o", out, "--mesh", dir.file("missing.off"), "--env", env}, 1, "missing.off"},
      {{"compress", in, "-o", out, "--target-error", "1e-12", "--mesh", mesh, "--env", env}, 1, "reaches p95 error"},
      {{"precompute", mesh, "-o", out, "--compress", "4"}, 2, "expected KxN"},
      {{"compress", in, "-o", out, "--glossy-pca", "4"}, 1, "--glossy-pca needs glossy matrices"},
      {{"precompute", mesh, "-o", out, "--compress-weights", "32"}, 2, "--compress-weights is for --compress"},
      {{"relight", mesh, dir.file("c.prt"), env, "-o", dir.file("x.csv"), "--direct"}, 1, "needs an interreflected"},
  };
  for (const Case& k : cases) {
    const Result r = run_prt(dir, k.args);
    EXPECT_EQ(r.code, k.code) << describe_run(r);
    EXPECT_NE(r.err.find(k.words), std::string::npos) << describe_run(r);
    EXPECT_FALSE(std::filesystem::exists(out)) << describe_run(r);
  }
}

// prt relight --tonemap: display colours, what prt render's 8-bit images get
// (exposure, tone map, sRGB with --srgb); a PLY then stores them as bytes,
// round(255 v), which the mesh loader reads back as colours.
TEST(RelightCli, TonemapWritesEightBitDisplayColours) {
  TempDir dir;
  test::write_off(dir.file("fb.off"), test::floor_and_ball(4));
  const std::string mesh = dir.file("fb.off"), env = repo_envmap("sunset.exr"), t = dir.file("t.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", t, "--bands", "3", "--samples", "32", "-q"}).code, 0);
  ASSERT_EQ(run_prt(dir, {"relight", mesh, t, env, "-o", dir.file("lin.csv"), "-q"}).code, 0);
  const std::vector<glm::vec3> linear = read_vertex_csv(dir.file("lin.csv"));
  const Result r = run_prt(dir, {"relight", mesh, t, env, "-o", dir.file("d.ply"), "--tonemap", "aces", "--srgb",
                                 "--exposure", "-1", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::string ply = read_file(dir.file("d.ply"));
  ASSERT_NE(ply.find("property uchar red\nproperty uchar green\nproperty uchar blue\n"), std::string::npos);
  std::size_t at = ply.find("end_header\n");
  ASSERT_NE(at, std::string::npos);
  at += 11;
  const Display d{-1.0, ToneMap::Aces};
  int checked = 0, bright = 0;
  for (std::size_t v = 0; v < linear.size(); ++v, at += 6 * 4 + 3)
    for (int c = 0; c < 3; ++c) {
      const int want = int(std::lround(255.0f * srgb_encode(tone_map(linear[v][c], d))));
      const int got = static_cast<unsigned char>(ply[at + 24 + std::size_t(c)]);
      EXPECT_LE(std::abs(got - want), 1) << "vertex " << v << " channel " << c;  // the CSV's 9 digits
      ++checked;
      bright += got > 128;
    }
  EXPECT_EQ(checked, int(3 * linear.size()));
  EXPECT_GT(bright, 0);
  const Mesh back = load_mesh(dir.file("d.ply"));
  ASSERT_EQ(back.colors.size(), linear.size());
  // Without --tonemap, --srgb and --exposure are refused (the output would be radiance).
  for (const char* o : {"--srgb", "--exposure"}) {
    std::vector<std::string> args = {"relight", mesh, t, env, "-o", dir.file("x.ply"), o};
    if (std::string(o) == "--exposure") args.push_back("1");
    const Result bad = run_prt(dir, args);
    EXPECT_EQ(bad.code, 2) << describe_run(bad);
    EXPECT_NE(bad.err.find("give --tonemap"), std::string::npos) << bad.err;
  }
}

TEST(MalformedInput, MeshesAreRefusedByPrecomputeAndReference) {
  TempDir dir;
  const std::string env = write_constant_map(dir, 1.0f);
  for (const Hostile& h : hostile_meshes()) {
    const std::string mesh = dir.file(h.name);
    write_file(mesh, h.bytes);
    const std::vector<std::string> inputs = {"constant.exr", h.name};
    // Bounded: the ASCII PLY without end_header spun forever.
    const BoundedResult p = run_prt_bounded(dir, {"precompute", mesh, "-o", dir.file("out.prt"), "-q"}, 60);
    EXPECT_FALSE(p.timed_out) << h.name;
    expect_refused(dir, p, 1, mesh, h.message, inputs, "precompute " + h.name);
    const BoundedResult r =
        run_prt_bounded(dir, {"reference", mesh, env, "-o", dir.file("out.csv"), "--samples", "4", "-q"}, 60);
    EXPECT_FALSE(r.timed_out) << h.name;
    expect_refused(dir, r, 1, mesh, h.message, inputs, "reference " + h.name);
    std::filesystem::remove(mesh);
  }
}

TEST(MalformedInput, DeclaredSizesAreCheckedBeforeAnythingIsAllocated) {
  // What the headers claimed took 4.2 GB (GLB), 1.2 GB (PLY), 2.4 and 11.7 GB
  // (OFF) before an error or a crash; now refused in prt's start-up memory.
  TempDir dir;
  std::vector<Hostile> bombs;
  for (const Hostile& h : hostile_meshes())
    if (h.name == "bomb.glb" || h.name == "big.ply" || h.name == "big.off") bombs.push_back(h);
  bombs.push_back({"bigger.off", "OFF\n500000000 1 0\n0 0 0\n", "declares 500000000 vertices"});
  ASSERT_EQ(bombs.size(), 4u);
  for (const Hostile& h : bombs) {
    write_file(dir.file(h.name), h.bytes);
    const BoundedResult r = run_prt_bounded(dir, {"precompute", dir.file(h.name), "-o", dir.file("out.prt"), "-q"}, 60);
    expect_refused(dir, r, 1, dir.file(h.name), h.message, {h.name}, h.name);
    EXPECT_LT(r.max_rss_kb, kRefusalRssKb) << h.name << ": peak RSS " << r.max_rss_kb << " KiB";
    EXPECT_LT(r.seconds, 10.0) << h.name;
    std::filesystem::remove(dir.file(h.name));
  }
}

TEST(MalformedInput, FifosAndDevicesAreRefusedWithoutBlocking) {
  // Refused from stat() before anything opens them: a reader of a FIFO
  // blocks until a writer comes, /dev/zero never ends.
  TempDir dir;
  const std::string env = write_constant_map(dir, 1.0f), quad = write_quad(dir);
  for (const char* name : {"fifo.off", "fifo.exr", "fifo.bin", "fifo.mtl"})
    ASSERT_EQ(::mkfifo(dir.file(name).c_str(), 0600), 0) << name;
  write_file(dir.file("external.gltf"),
             R"({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 96, "uri": "fifo.bin"}]})");
  write_file(dir.file("material.obj"), "mtllib fifo.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::vector<std::string> inputs = {"constant.exr", "external.gltf", "fifo.bin", "fifo.exr",
                                           "fifo.mtl",     "fifo.off",      "material.obj", "quad.off"};
  const std::string fifo = "is a FIFO (named pipe), not a regular file";
  struct Case {
    std::vector<std::string> args;
    std::string file, message;
  };
  const std::vector<Case> cases = {
      {{"precompute", dir.file("fifo.off"), "-o", dir.file("o.prt")}, dir.file("fifo.off"), fifo},
      {{"reference", dir.file("fifo.off"), env, "-o", dir.file("o.csv")}, dir.file("fifo.off"), fifo},
      {{"reference", quad, dir.file("fifo.exr"), "-o", dir.file("o.csv")}, dir.file("fifo.exr"), fifo},
      {{"precompute", dir.file("external.gltf"), "-o", dir.file("o.prt")}, dir.file("external.gltf"),
       "buffer 0: " + dir.file("fifo.bin") + ": " + fifo},
      {{"precompute", dir.file("material.obj"), "-o", dir.file("o.prt")}, dir.file("material.obj"),
       "line 1: its material library " + dir.file("fifo.mtl") + ": " + fifo},
      {{"precompute", "/dev/zero", "-o", dir.file("o.prt")}, "/dev/zero", "is a character device, not a regular file"},
  };
  for (const Case& c : cases) {
    const BoundedResult r = run_prt_bounded(dir, c.args, 20);
    EXPECT_FALSE(r.timed_out) << c.args[0] << " " << c.file << ": blocked";
    expect_refused(dir, r, 1, c.file, c.message, inputs, c.args[0] + " " + c.file);
  }
}

TEST(MalformedInput, RayOffsetIsRangeChecked) {
  // --offset 1e30 put ray origins where Embree asserts (SIGABRT) in every mode.
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  const std::vector<std::string> inputs = {"constant.exr", "quad.off"};
  const std::vector<std::vector<std::string>> runs = {
      {"precompute", mesh, "-o", dir.file("o.prt"), "--samples", "16"},
      {"precompute", mesh, "-o", dir.file("o.prt"), "--samples", "16", "--mode", "interreflected"},
      {"precompute", mesh, "-o", dir.file("o.prt"), "--basis", "wavelet", "--cube-res", "8"},
      {"reference", mesh, env, "-o", dir.file("o.csv"), "--samples", "4"},
  };
  for (std::vector<std::string> args : runs) {
    args.insert(args.end(), {"--offset", "1e30"});
    const Result r = run_prt(dir, args);
    // The quad's diagonal is 2 sqrt(2): at most 0.283.
    expect_refused(dir, r, 1, mesh, "1e+30 is too large for " + mesh + ": at most a tenth of its bounding-box "
                                    "diagonal (0.282843)",
                   inputs, args[0] + " " + args[args.size() - 3]);
    EXPECT_NE(r.err.find("--offset"), std::string::npos) << r.err;
  }
  for (const char* bad : {"0", "-1", "nan", "inf"}) {
    const Result r = run_prt(dir, {"precompute", mesh, "-o", dir.file("o.prt"), "--offset", bad});
    EXPECT_EQ(r.code, 2) << bad << "\n" << describe_run(r);
    EXPECT_NE(r.err.find("--offset: must be a positive number"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(bad), std::string::npos) << r.err;
    const Result q = run_prt(dir, {"reference", mesh, env, "-o", dir.file("o.csv"), "--offset", bad});
    EXPECT_EQ(q.code, 2) << bad << "\n" << describe_run(q);
  }
  EXPECT_EQ(dir.listing(), inputs);
  // Within the bound: computed.
  EXPECT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("o.prt"), "--samples", "16", "--offset", "0.28", "-q"}).code,
            0);
}

TEST(MalformedInput, CoordinatesBeyondTheLimitAreRefused) {
  // The quad scaled by 1e19: Embree asserted (SIGABRT) in every mode.
  TempDir dir;
  const Mesh quad = test::quad(4);
  const std::string mesh = dir.file("huge.off");
  std::string off = "OFF\n" + std::to_string(quad.vertex_count()) + " " + std::to_string(quad.triangles.size()) + " 0\n";
  char line[128];
  for (const glm::vec3& q : quad.positions) {
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", q.x * 1e19, q.y * 1e19, q.z * 1e19);
    off += line;
  }
  for (const glm::uvec3& t : quad.triangles)
    off += "3 " + std::to_string(t.x) + " " + std::to_string(t.y) + " " + std::to_string(t.z) + "\n";
  write_file(mesh, off);
  const std::string env = write_constant_map(dir, 1.0f);
  const std::vector<std::vector<std::string>> runs = {
      {"precompute", mesh, "-o", dir.file("o.prt")},
      {"precompute", mesh, "-o", dir.file("o.prt"), "--mode", "interreflected"},
      {"precompute", mesh, "-o", dir.file("o.prt"), "--basis", "wavelet", "--cube-res", "8"},
      {"reference", mesh, env, "-o", dir.file("o.csv")},
  };
  for (const auto& args : runs)
    expect_refused(dir, run_prt(dir, args), 1, mesh, "vertex 0 has a coordinate beyond prt's limit of 1e+12",
                   {"constant.exr", "huge.off"}, args[0]);
}


// ---- bad options and outputs (docs/HARD_CASES.md, "Bad options and outputs") ----

// Runs each of `runs`, expecting exit `code`, stderr containing each of its
// words, and the directory as it was (nothing written, no temporary).
struct Refusal {
  std::vector<std::string> args, words;
};
void expect_refusals(const TempDir& dir, const std::vector<Refusal>& runs, int code) {
  const auto before = dir.listing();
  for (const Refusal& c : runs) {
    std::string line;
    for (const auto& a : c.args) line += a + " ";
    const Result r = run_prt(dir, c.args);
    EXPECT_EQ(r.code, code) << line << "\n" << describe_run(r);
    for (const auto& w : c.words) EXPECT_NE(r.err.find(w), std::string::npos) << line << ": no '" << w << "'\n" << r.err;
    EXPECT_EQ(dir.listing(), before) << line;
  }
}

TEST(BadOptions, SeedsAreWholeNumbersFrom0To2To64Minus1) {
  // --seed -1 and --seed 18446744073709551616 both became 2^64 - 1.
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  const std::string expected = "--seed: must be a whole number from 0 to 18446744073709551615 (digits only), got ";
  std::vector<Refusal> runs;
  for (const char* bad : {"-1", "18446744073709551616", "99999999999999999999999", "1e3", "0x10", "+1", " 1", "1.5", ""})
    runs.push_back({{"precompute", mesh, "-o", dir.file("x.prt"), "--seed", bad}, {expected + "'" + bad + "'"}});
  runs.push_back({{"reference", mesh, env, "-o", dir.file("x.csv"), "--seed", "-1"}, {expected + "'-1'"}});
  expect_refusals(dir, runs, 2);
  // The largest is taken as it is.
  const Result ok = run_prt(dir, {"precompute", mesh, "-o", dir.file("x.prt"), "--seed", "18446744073709551615",
                                  "--samples", "16", "-q"});
  ASSERT_EQ(ok.code, 0) << describe_run(ok);
  EXPECT_EQ(read_transfer(dir.file("x.prt")).seed, 18446744073709551615ull);
}

TEST(BadOptions, TargetErrorAndItsOptionsAreChecked) {
  // --target-error 0 and nan, and --env without --target-error, were ignored.
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f), out = dir.file("x.prt");
  std::vector<Refusal> runs;
  for (const char* bad : {"0", "nan", "1", "-0.5", "inf"})
    runs.push_back({{"precompute", mesh, "-o", out, "--target-error", bad, "--env", env},
                    {"--target-error: must be a number in (0, 1) (a relative RMS error), got "}});
  runs.push_back({{"precompute", mesh, "-o", out, "--env", env},
                  {"--env is for --target-error", "give --target-error too"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--cache", dir.work().string()}, {"--cache is for --target-error"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--target-error", "0.1"}, {"--target-error needs --env MAP"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--target-error", "0.1", "--env", env, "--bounce-tolerance", "0.1"},
                  {"--bounce-tolerance and --target-error both choose the bounces"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--target-error", "0.1", "--env", env, "--mode", "unshadowed"},
                  {"--target-error: the unshadowed transfer has no sampling to choose"}});
  expect_refusals(dir, runs, 2);
}

TEST(BadOptions, AdaptiveAndItsOptionsAreChecked) {
  TempDir dir;
  const std::string mesh = write_quad(dir), out = dir.file("x.prt");
  std::vector<Refusal> runs;
  for (const char* bad : {"0", "-0.01", "1", "nan", "abc", "0.01x"})
    runs.push_back({{"precompute", mesh, "-o", out, "--adaptive", bad}, {"--adaptive ", bad}});
  // Past 1.5x the default for the samples: the error may pass 1.1x the full run's.
  runs.push_back({{"precompute", mesh, "-o", out, "--adaptive", "0.02"}, {"above 0.015", "--adaptive-any"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--adaptive", "0.01", "--samples", "4096"},
                  {"above 0.0075", "4096 samples"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--verify-adaptive", "0.1"}, {"--verify-adaptive is for --adaptive"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--adaptive-any"}, {"--adaptive-any is for --adaptive"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--adaptive", "--basis", "wavelet"}, {"--adaptive applies to --basis sh"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--adaptive", "--probes", "2x2x2"}, {"not for --probes"}});
  expect_refusals(dir, runs, 2);
  const Result r = run_prt(dir, {"precompute", mesh, "-o", out, "--adaptive", "--verify-adaptive", "2"});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_FALSE(std::filesystem::exists(out));
}

// --adaptive writes what compute_adaptive_transfer computes (the same
// bits, the interpolated vertices marked) and says what it traced.
TEST(PrecomputeCli, AdaptiveIsTheLibrarysAndSaysWhatItTraced) {
  TempDir dir;
  const Mesh m = test::floor_and_ball(60);
  const std::string mesh = dir.file("ball.off");
  test::write_off(mesh, m);
  const Mesh loaded = load_mesh(mesh);
  TransferOptions o;
  o.bands = 4;
  o.samples = 256;
  o.albedo = glm::vec3(0.8f);
  std::size_t default_interpolated = 0;
  for (const char* tol : {"", "0.005"}) {
    std::vector<std::string> args = {"precompute", mesh, "-o", dir.file("a.prt"), "--bands", "4", "--samples", "256",
                                     "--adaptive"};
    if (*tol) args.push_back(tol);
    const Result r = run_prt(dir, args);
    ASSERT_EQ(r.code, 0) << describe_run(r);
    AdaptiveOptions a;
    a.tolerance = *tol ? std::stod(tol) : 0.0;
    AdaptiveReport rep;
    const Transfer lib = compute_adaptive_transfer(loaded, o, a, {}, &rep);
    const Transfer file = read_transfer(dir.file("a.prt"));
    EXPECT_EQ(file.coeffs, lib.coeffs) << tol;
    EXPECT_EQ(file.slots, lib.slots) << tol;
    EXPECT_EQ(file.interpolated, lib.interpolated) << tol;
    ASSERT_GT(lib.interpolated_vertices(), 0u) << tol;
    if (!*tol) default_interpolated = lib.interpolated_vertices();
    EXPECT_NE(r.err.find(fmt::format("traced {} of {} vertices", rep.traced, rep.vertices)), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(fmt::format("adaptive (TOL {:.3g})", rep.tolerance)), std::string::npos) << r.err;
  }
  // --verify-adaptive: the report, and the verified vertices traced.
  const Result v = run_prt(dir, {"precompute", mesh, "-o", dir.file("v.prt"), "--bands", "4", "--samples", "256",
                                 "--adaptive", "--verify-adaptive", "0.5"});
  ASSERT_EQ(v.code, 0) << describe_run(v);
  EXPECT_NE(v.err.find("verify: traced "), std::string::npos) << v.err;
  EXPECT_LT(read_transfer(dir.file("v.prt")).interpolated_vertices(), default_interpolated);
  // --adaptive-any takes a tolerance past the default range.
  const Result any = run_prt(dir, {"precompute", mesh, "-o", dir.file("w.prt"), "--samples", "256", "--adaptive", "0.2",
                                   "--adaptive-any", "-q"});
  EXPECT_EQ(any.code, 0) << describe_run(any);
}

// --subdivide writes the refined mesh (PLY) with the transfer for it: what
// subdivide_for_transfer computes, relit and exported with the refined mesh
// (the glTF carries its vertices), with colours too; a failure writes neither.
TEST(PrecomputeCli, SubdivideWritesTheRefinedMeshWithItsTransfer) {
  TempDir dir;
  const std::string mesh = dir.file("coarse.off"), env = write_constant_map(dir, 1.0f);
  test::write_off(mesh, test::ball_over_floor(6, 8, 16, 0.4f, {0.0f, 0.9f, 0.0f}));
  const Mesh loaded = load_mesh(mesh);
  const Result r = run_prt(dir, {"precompute", mesh, "-o", dir.file("fine.prt"), "--bands", "4", "--samples", "256",
                                 "--subdivide", "0.05"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  ASSERT_TRUE(std::filesystem::exists(dir.file("fine.ply")));  // the default: the output's name with .ply
  TransferOptions o;
  o.bands = 4;
  o.samples = 256;
  o.albedo = glm::vec3(0.8f);
  SubdivideOptions s;
  s.tolerance = 0.05;
  SubdivideReport rep;
  const Subdivided lib = subdivide_for_transfer(loaded, o, s, {}, &rep);
  const Mesh refined = load_mesh(dir.file("fine.ply"));
  EXPECT_EQ(refined.positions, lib.mesh.positions);
  EXPECT_EQ(refined.triangles, lib.mesh.triangles);
  EXPECT_EQ(refined.normals, lib.mesh.normals);
  const Transfer file = read_transfer(dir.file("fine.prt"));
  EXPECT_EQ(file.coeffs, lib.transfer.coeffs);
  EXPECT_EQ(file.slots, lib.transfer.slots);
  EXPECT_NO_THROW(check_matches(file, refined, "fine.prt"));
  EXPECT_NE(r.err.find(fmt::format("subdivided: {} -> {} vertices in {} round{} ({} edges split{})", rep.input_vertices,
                                   rep.vertices, rep.rounds, rep.rounds == 1 ? "" : "s", rep.split_edges,
                                   rep.capped ? fmt::format(", capped at {}", 4 * loaded.vertex_count()) : "")),
            std::string::npos)
      << r.err;
  ASSERT_GT(refined.vertex_count(), loaded.vertex_count());
  // Relit with the refined mesh; refused with the coarse one.
  const Result relit = run_prt(dir, {"relight", dir.file("fine.ply"), dir.file("fine.prt"), env, "-o", dir.file("r.csv"), "-q"});
  ASSERT_EQ(relit.code, 0) << describe_run(relit);
  EXPECT_EQ(read_vertex_csv(dir.file("r.csv")).size(), refined.vertex_count());
  EXPECT_EQ(run_prt(dir, {"relight", mesh, dir.file("fine.prt"), env, "-o", dir.file("c.csv"), "-q"}).code, 1);
  // The glTF export carries the refined mesh: every accessor has its vertices (or its triangles' corners).
  const Result gltf = run_prt(dir, {"export", dir.file("fine.ply"), dir.file("fine.prt"), "-o", dir.file("x.gltf")});
  ASSERT_EQ(gltf.code, 0) << describe_run(gltf);
  const std::string json = read_file(dir.file("x.gltf"));
  const std::regex count("\"count\":([0-9]+)");
  std::size_t with_vertices = 0;
  for (auto it = std::sregex_iterator(json.begin(), json.end(), count); it != std::sregex_iterator(); ++it) {
    const std::size_t n = std::stoul((*it)[1]);
    EXPECT_TRUE(n == refined.vertex_count() || n == 3 * refined.triangles.size()) << n;
    with_vertices += n == refined.vertex_count();
  }
  EXPECT_GE(with_vertices, 3u);  // positions, normals, transfer

  // Colours as albedo: the refined mesh keeps its (averaged) colours, and its file the transfer's shading.
  Mesh coloured = loaded;
  for (const glm::vec3& p : coloured.positions) coloured.colors.push_back(glm::vec3(0.5f + 0.2f * p.x, 0.6f, 0.5f - 0.2f * p.z));
  write_ply(dir.file("coloured.ply"), coloured, coloured.colors, PlyColors::Float, "test");
  const Result c = run_prt(dir, {"precompute", dir.file("coloured.ply"), "-o", dir.file("col.prt"), "--bands", "3",
                                 "--samples", "128", "--vertex-colors", "--subdivide", "0.1", "--subdivided-mesh",
                                 dir.file("col-fine.ply"), "-q"});
  ASSERT_EQ(c.code, 0) << describe_run(c);
  EXPECT_EQ(load_mesh(dir.file("col-fine.ply")).colors.size(), read_transfer(dir.file("col.prt")).vertices);
  const Result cr = run_prt(dir, {"relight", dir.file("col-fine.ply"), dir.file("col.prt"), env, "-o", dir.file("cr.csv"), "-q"});
  EXPECT_EQ(cr.code, 0) << describe_run(cr);

  // Where the refined mesh cannot go, nothing is written.
  const Result bad = run_prt(dir, {"precompute", mesh, "-o", dir.file("none.prt"), "--subdivide", "0.05",
                                   "--subdivided-mesh", dir.file("nodir/none.ply"), "-q"});
  EXPECT_EQ(bad.code, 1) << describe_run(bad);
  EXPECT_NE(bad.err.find("--subdivided-mesh"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("none.prt")));
}

// --subdivide with --target-error: the search's settings (chosen on the
// input mesh), and without a value TOL = target / 2; the refinement is then
// subdivide_for_transfer's with them.
TEST(PrecomputeCli, SubdivideTakesTheTargetErrorsSettingsAndTolerance) {
  TempDir dir;
  const std::string mesh = dir.file("coarse.off"), env = write_constant_map(dir, 1.0f);
  test::write_off(mesh, test::ball_over_floor(6, 8, 16, 0.4f, {0.0f, 0.9f, 0.0f}));
  constexpr double kTarget = 0.1;
  const Result r = run_prt(dir, {"precompute", mesh, "-o", dir.file("fine.prt"), "--target-error", "0.1", "--env", env,
                                 "--cache", dir.file("cache"), "--subdivide"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("target error 0.1"), std::string::npos) << r.err;
  const Transfer file = read_transfer(dir.file("fine.prt"));
  const Mesh loaded = load_mesh(mesh), refined = load_mesh(dir.file("fine.ply"));
  TransferOptions o;
  o.bands = file.bands;
  o.samples = file.samples;
  o.albedo = glm::vec3(0.8f);
  SubdivideOptions s;
  s.tolerance = kTarget / 2;
  const Subdivided lib = subdivide_for_transfer(loaded, o, s);
  EXPECT_GT(lib.mesh.vertex_count(), loaded.vertex_count());
  EXPECT_EQ(refined.positions, lib.mesh.positions);
  EXPECT_EQ(file.coeffs, lib.transfer.coeffs);
  EXPECT_NO_THROW(check_matches(file, refined, "fine.prt"));
}

TEST(BadOptions, SubdivideAndItsOptionsAreChecked) {
  TempDir dir;
  const std::string mesh = write_quad(dir), out = dir.file("x.prt"), env = write_constant_map(dir, 1.0f);
  const Mesh quad = load_mesh(mesh);
  write_ply(dir.file("quad.ply"), quad, {}, PlyColors::Float, "test");
  const std::string ply = dir.file("quad.ply");
  std::vector<Refusal> runs;
  for (const char* bad : {"0", "1", "-0.1", "nan", "abc"})
    runs.push_back({{"precompute", mesh, "-o", out, "--subdivide", bad}, {"--subdivide"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--subdivide-max-vertices", "100"},
                  {"--subdivide-max-vertices is for --subdivide"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--subdivided-mesh", dir.file("f.ply")},
                  {"--subdivided-mesh is for --subdivide"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--subdivide"}, {"--subdivide needs a TOL", "--target-error"}});
  const std::vector<std::pair<std::vector<std::string>, std::string>> others = {
      {{"--adaptive"}, "not with --adaptive"},
      {{"--lightmap", "64x64"}, "not with --lightmap"},
      {{"--probes", "2x2x2"}, "not with --probes"},
      {{"--basis", "wavelet"}, "not with --basis wavelet"},
      {{"--basis", "zh"}, "not with --basis zh"},
  };
  for (const auto& [extra, words] : others) {
    std::vector<std::string> args = {"precompute", mesh, "-o", out, "--subdivide", "0.05"};
    args.insert(args.end(), extra.begin(), extra.end());
    runs.push_back({args, {words}});
  }
  runs.push_back({{"precompute", mesh, "-o", out, "--subdivide", "0.05", "--subdivided-mesh", dir.file("f.obj")},
                  {"--subdivided-mesh", "written as PLY"}});
  runs.push_back({{"precompute", ply, "-o", out, "--subdivide", "0.05", "--subdivided-mesh", ply},
                  {"--subdivided-mesh", "is the input MESH"}});
  runs.push_back({{"precompute", mesh, "-o", dir.file("x.ply"), "--subdivide", "0.05", "--subdivided-mesh",
                   dir.file("x.ply")},
                  {"--subdivided-mesh", "is also the --output file; give each output its own name"}});
  // The default (the output's name with .ply) would be MESH.
  runs.push_back({{"precompute", ply, "-o", dir.file("quad.prt"), "--subdivide", "0.05"},
                  {"the refined mesh would go to", "which is MESH", "give --subdivided-mesh"}});
  runs.push_back({{"precompute", mesh, "-o", out, "--subdivide", "0.05", "--subdivide-max-vertices", "24"},
                  {"--subdivide-max-vertices 24: below the mesh's 25 vertices"}});
  expect_refusals(dir, runs, 2);
}

TEST(BadOptions, BadOptionValuesExitTwo) {
  // These exited 1, as if a file were bad; --bands 100 already exited 2.
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("s.prt"), "--samples", "16", "-q"}).code, 0);
  const std::string out = dir.file("x.prt"), csv = dir.file("x.csv"), prt = dir.file("s.prt");
  expect_refusals(
      dir,
      {
          {{"precompute", mesh, "-o", out, "--mode", "foo"},
           {"prt precompute: error: --mode: unknown mode 'foo' (expected unshadowed, shadowed or interreflected)"}},
          {{"precompute", mesh, "-o", out, "--albedo", "-1"}, {"--albedo: expected three numbers r,g,b, got '-1'"}},
          {{"precompute", mesh, "-o", out, "--albedo", "-1,0,0"},
           {"--albedo: each of r,g,b must be from 0 to 1 (energy conservation), got -1"}},
          {{"precompute", mesh, "-o", out, "--albedo", "0.5,nan,0.5"}, {"--albedo: numbers must be finite"}},
          {{"precompute", mesh, "-o", out, "--basis", "wavelet", "--cube-res", "3"},
           {"--cube-res: must be a power of two from 2 to 256"}},
          {{"precompute", mesh, "-o", out, "--basis", "wavelet", "--samples", "64"},
           {"--samples does not apply to --basis wavelet"}},
          {{"precompute", mesh, "-o", out, "--basis", "wavelet", "--threshold", "1"},
           {"--threshold: must be a number in [0, 1), got 1"}},
          {{"precompute", mesh, "-o", out, "--bounce-tolerance", "1"}, {"--bounce-tolerance: must be a number in [0, 1)"}},
          {{"precompute", mesh, "-o", out, "--cube-res", "16"}, {"--cube-res applies to --basis wavelet only"}},
          {{"reference", mesh, env, "-o", csv, "--mode", "foo"}, {"--mode: unknown mode 'foo'"}},
          {{"reference", mesh, env, "-o", csv, "--albedo", "-1,0,0"}, {"--albedo: each of r,g,b must be from 0 to 1 (energy conservation)"}},
          {{"relight", mesh, prt, env, "-o", csv, "--window", "bogus"}, {"--window: unknown window 'bogus'"}},
          {{"relight", mesh, prt, env, "-o", csv, "--rotate", "1e999,0,0"}, {"--rotate: numbers must be finite"}},
          {{"relight", mesh, prt, env, "-o", dir.file("x.txt")}, {"expected a .ply or .csv file"}},
      },
      2);
}

TEST(BadOptions, AnOutputThatIsAnInputIsRefused) {
  // `prt precompute cow.off -o cow.off` overwrote its own input.
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("s.prt"), "--samples", "16", "-q"}).code, 0);
  const std::string prt = dir.file("s.prt");
  std::filesystem::create_symlink(prt, dir.work() / "to_prt.csv");
  std::filesystem::create_symlink(mesh, dir.work() / "to_mesh.csv");
  std::filesystem::create_symlink(env, dir.work() / "to_env.ply");
  const std::string mesh_bytes = read_file(mesh), prt_bytes = read_file(prt), env_bytes = read_file(env);
  expect_refusals(
      dir,
      {
          {{"precompute", mesh, "-o", mesh}, {"--output " + mesh + ": is the input MESH; prt does not write over"}},
          {{"precompute", mesh, "-o", env, "--target-error", "0.1", "--env", env}, {"--output " + env + ": is the input --env"}},
          {{"relight", mesh, prt, env, "-o", dir.file("to_prt.csv")},
           {"--output " + dir.file("to_prt.csv") + ": is the input TRANSFER (" + prt + ")"}},
          {{"relight", mesh, prt, env, "-o", dir.file("to_env.ply")}, {"is the input ENV (" + env + ")"}},
          {{"reference", mesh, env, "-o", dir.file("to_mesh.csv")}, {"is the input MESH (" + mesh + ")"}},
      },
      2);
  EXPECT_EQ(read_file(mesh), mesh_bytes);
  EXPECT_EQ(read_file(prt), prt_bytes);
  EXPECT_EQ(read_file(env), env_bytes);
}

TEST(BadOptions, RelightDirectNeedsAnInterreflectedTransfer) {
  // --direct on a shadowed file was ignored (render refused --shading direct).
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("s.prt"), "--samples", "16", "-q"}).code, 0);
  expect_refusals(dir,
                  {{{"relight", mesh, dir.file("s.prt"), env, "-o", dir.file("x.csv"), "--direct"},
                    {"prt relight: error: " + dir.file("s.prt") + ": --direct needs an interreflected transfer",
                     "this one is shadowed, not interreflected"}}},
                  1);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("i.prt"), "--samples", "16", "-m", "interreflected",
                          "-q"}).code,
            0);
  const Result ok = run_prt(dir, {"relight", mesh, dir.file("i.prt"), env, "-o", dir.file("x.csv"), "--direct", "-q"});
  EXPECT_EQ(ok.code, 0) << describe_run(ok);
}

TEST(BadOptions, NonFiniteRelitRadianceNamesTheInputs) {
  // A map of 1e10 times transfer coefficients of 1e30 overflows float: the
  // message blamed the output file ("refusing to write a non-finite value").
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1e10f), prt = dir.file("big.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", prt, "--samples", "16", "-q"}).code, 0);
  const Mesh m = load_mesh(mesh);
  Transfer t = read_transfer(prt);
  t.coeffs = dense_transfer(t, m);  // every vertex stored, 1e30 times
  for (float& c : t.coeffs) c *= 1e30f;
  t.slots.clear();
  write_transfer(prt, t);
  for (const char* out : {"o.csv", "o.ply"}) {
    const Result r = run_prt(dir, {"relight", mesh, prt, env, "-o", dir.file(out)});
    EXPECT_EQ(r.code, 1) << describe_run(r);
    EXPECT_NE(r.err.find("relit radiance of vertex 0 is inf (r channel): the values of " + env +
                         " (max 1e+10) times the transfer of " + prt),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("overflow float"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find(out), std::string::npos) << "blames the output: " << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file(out)));
  }
}

// Ctrl-C in the write step: the temporary was left (.NAME.tmpPID-N.ext) and
// the process died of SIGINT. Now exit 130, "interrupted; nothing written",
// the old file as it was. PRT_TEST_PAUSE_BEFORE_RENAME (prt/io.h) holds the
// write step open; the signal goes when the child says it is there.
TEST(CtrlC, DuringTheWriteStepLeavesTheOldFile) {
  TempDir dir;
  const std::string mesh = write_quad(dir), env = write_constant_map(dir, 1.0f);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", dir.file("s.prt"), "--samples", "16", "-q"}).code, 0);
  struct Case {
    std::vector<std::string> args;
    std::string command, output;
  };
  const std::vector<Case> cases = {
      {{"precompute", mesh, "-o", dir.file("p.prt"), "--samples", "16"}, "precompute", "p.prt"},
      {{"precompute", mesh, "-o", dir.file("w.prt"), "--basis", "wavelet", "--cube-res", "4"}, "precompute", "w.prt"},
      {{"relight", mesh, dir.file("s.prt"), env, "-o", dir.file("r.ply")}, "relight", "r.ply"},
      {{"relight", mesh, dir.file("s.prt"), env, "-o", dir.file("r.csv")}, "relight", "r.csv"},
      {{"reference", mesh, env, "-o", dir.file("f.csv"), "--samples", "4"}, "reference", "f.csv"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.output);
    write_file(dir.file(c.output), "old");
    const auto before = dir.listing();
    const auto r = run_prt_interrupted(dir, c.args, "PRT_TEST_PAUSE_BEFORE_RENAME", {"PRT_TEST_PAUSE_BEFORE_RENAME=30000"});
    EXPECT_TRUE(r.marker_seen) << describe_run(r);
    EXPECT_EQ(r.code, 130) << describe_run(r);
    EXPECT_NE(r.err.find("prt " + c.command + ": interrupted; nothing written"), std::string::npos) << r.err;
    EXPECT_EQ(read_file(dir.file(c.output)), "old");
    EXPECT_EQ(dir.listing(), before);
    EXPECT_TRUE(temporaries(dir).empty());
  }
}

}  // namespace
}  // namespace prt
