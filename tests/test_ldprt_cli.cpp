// Local deformable PRT through the real executable: prt precompute --basis
// zh, prt info, prt relight of a pose (a file, or --deform), prt render of a
// deformation and of a skin's animation, and the refusals.
#include "test_files.h"
#include "test_ldprt.h"

#include <prt/deform.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/transfer_io.h>
#include <prt/vertex_csv.h>
#include <prt/zh_transfer.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

namespace prt {
namespace {

using namespace prt::test;

TEST(LdprtCli, PrecomputeThenRelightPoses) {
  TempDir dir;
  const std::string z = dir.file("tube-zh.prt");
  const Result p = run_prt(dir, {"precompute", kTube, "-o", z, "--basis", "zh", "--lobes", "2", "--bands", "4",
                                 "--samples", "128"});
  ASSERT_EQ(p.code, 0) << describe_run(p);
  EXPECT_NE(p.err.find("2 lobes x 4 bands"), std::string::npos) << p.err;
  const Result info = run_prt(dir, {"info", z, "--json"});
  ASSERT_EQ(info.code, 0) << describe_run(info);
  EXPECT_NE(info.out.find("\"lobes\": 2"), std::string::npos) << info.out;

  const Mesh rest = load_mesh(kTube);
  // The rest pose, then a bend given as --deform, then the same bend as a
  // file (the PLY --deform wrote): the library's relighting of each.
  const Result r0 = run_prt(dir, {"relight", kTube, z, kEnv, "-o", dir.file("rest.csv"), "-q"});
  ASSERT_EQ(r0.code, 0) << describe_run(r0);
  expect_same(read_vertex_csv(dir.file("rest.csv")), library_relight(z, rest));
  const Mesh bent = deform_mesh(rest, parse_deform("bend:70"));
  for (const char* out : {"bent.csv", "bent.ply"}) {
    const Result r = run_prt(dir, {"relight", kTube, z, kEnv, "--deform", "bend:70", "-o", dir.file(out), "-q"});
    ASSERT_EQ(r.code, 0) << describe_run(r);
  }
  const std::vector<glm::vec3> want = library_relight(z, bent);
  expect_same(read_vertex_csv(dir.file("bent.csv")), want);
  const Result rf = run_prt(dir, {"relight", dir.file("bent.ply"), z, kEnv, "-o", dir.file("posed.csv"), "-q"});
  ASSERT_EQ(rf.code, 0) << describe_run(rf);
  expect_same(read_vertex_csv(dir.file("posed.csv")), want);
  // Bending changes the light (the test would pass on a transfer that ignores the pose otherwise).
  const std::vector<glm::vec3> at_rest = read_vertex_csv(dir.file("rest.csv"));
  double moved = 0;
  for (std::size_t v = 0; v < want.size(); ++v) moved = std::max(moved, double(std::abs(want[v].x - at_rest[v].x)));
  EXPECT_GT(moved, 0.05);
}

// --tangent: the UV tangent from the tube's texture coordinates by default,
// the edge rule when asked; the same SH transfer and fit, only the frames
// (and so the stored axes) differ; refused for other bases and other values.
TEST(LdprtCli, TangentFromTheUvsOrTheEdgeRule) {
  TempDir dir;
  const std::string uv = dir.file("uv.prt"), edge = dir.file("edge.prt");
  const std::vector<std::string> common = {"--basis", "zh", "--lobes", "2", "--bands", "3", "--samples", "64"};
  std::vector<std::string> a = {"precompute", kTube, "-o", uv};
  a.insert(a.end(), common.begin(), common.end());
  const Result pu = run_prt(dir, a);
  ASSERT_EQ(pu.code, 0) << describe_run(pu);
  EXPECT_NE(pu.err.find("vertex frames: 2020 tangents from texture coordinates, 30 by the edge rule"), std::string::npos)
      << pu.err;
  a[3] = edge;
  a.insert(a.end(), {"--tangent", "edge"});
  const Result pe = run_prt(dir, a);
  ASSERT_EQ(pe.code, 0) << describe_run(pe);
  EXPECT_NE(pe.err.find("vertex frames: 0 tangents from texture coordinates, 2050 by the edge rule"), std::string::npos)
      << pe.err;
  const ZhTransfer zu = read_zh_transfer(uv), ze = read_zh_transfer(edge);
  EXPECT_EQ(zu.coeffs, ze.coeffs);  // the frames turn the axes only
  EXPECT_NE(zu.axes, ze.axes);
  EXPECT_EQ(zu.fit_error, ze.fit_error);
  const Result info = run_prt(dir, {"info", uv});
  EXPECT_NE(info.out.find("2020 from texture coordinates, 30 by the edge rule, 0 none"), std::string::npos) << info.out;
  const Result json = run_prt(dir, {"info", edge, "--json"});
  EXPECT_NE(json.out.find(R"("tangents": {
    "uv": 0,
    "edge": 2050,
    "none": 0
  })"),
            std::string::npos)
      << json.out;
  const Result sh = run_prt(dir, {"precompute", kTube, "-o", dir.file("x.prt"), "--tangent", "edge"});
  EXPECT_EQ(sh.code, 2) << describe_run(sh);
  EXPECT_NE(sh.err.find("--tangent applies to --basis zh only"), std::string::npos) << sh.err;
  a.back() = "bitangent";
  const Result bad = run_prt(dir, a);
  EXPECT_EQ(bad.code, 2) << describe_run(bad);
  EXPECT_NE(bad.err.find("--tangent"), std::string::npos) << bad.err;
}

// --dynamic-ao: stored by precompute, applied by relight as the library's
// dynamic_ao_factor; refused for a file without it and for other bases.
TEST(LdprtCli, DynamicAoThroughTheCommandLine) {
  TempDir dir;
  const std::string z = dir.file("z.prt"), plain = dir.file("plain.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", kTube, "-o", z, "--basis", "zh", "--lobes", "2", "--bands", "3", "--samples",
                          "32", "--dynamic-ao", "-q"})
                .code,
            0);
  ASSERT_EQ(run_prt(dir, {"precompute", kTube, "-o", plain, "--basis", "zh", "--lobes", "2", "--bands", "3",
                          "--samples", "32", "-q"})
                .code,
            0);
  const Result r = run_prt(dir, {"relight", kTube, z, kEnv, "--deform", "bend:100", "--dynamic-ao", "-o",
                                 dir.file("ao.csv"), "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const Mesh bent = deform_mesh(load_mesh(kTube), parse_deform("bend:100"));
  std::vector<glm::vec3> want = library_relight(z, bent);
  const std::vector<float> f = dynamic_ao_factor(read_zh_transfer(z), bent);
  for (std::size_t v = 0; v < want.size(); ++v) want[v] *= f[v];
  expect_same(read_vertex_csv(dir.file("ao.csv")), want);
  const Result no = run_prt(dir, {"relight", kTube, plain, kEnv, "--dynamic-ao", "-o", dir.file("x.csv")});
  EXPECT_EQ(no.code, 1) << describe_run(no);
  EXPECT_NE(no.err.find("no rest occlusion"), std::string::npos) << no.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.csv")));
  const Result sh = run_prt(dir, {"precompute", kTube, "-o", dir.file("x.prt"), "--dynamic-ao"});
  EXPECT_EQ(sh.code, 2) << describe_run(sh);
}

// prt render follows --deform: one frame at the whole angle, a sequence from
// rest and back (its first frame the rest pose's image, its middle the
// whole angle's); the image moves with the pose.
TEST(LdprtCli, RenderFollowsTheDeformation) {
  TempDir dir;
  const std::string z = dir.file("z.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", kTube, "-o", z, "--basis", "zh", "--lobes", "2", "--bands", "3", "--samples",
                          "32", "-q"})
                .code,
            0);
  const auto render = [&](const std::string& out, std::vector<std::string> extra) {
    // --exposure 0: auto would measure each run's own frame (a sequence keeps its first frame's).
    std::vector<std::string> args = {"render", kTube, z, kEnv, "-o", dir.file(out), "--width", "128", "--height", "64",
                                     "--camera", "0,1,7,0,1,0,0,1,0", "--exposure", "0", "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const Result r = run_prt(dir, args);
    if (r.code != 0 && r.err.find("no OpenGL 4.5 context") != std::string::npos) return false;
    EXPECT_EQ(r.code, 0) << describe_run(r);
    return true;
  };
  if (!render("rest.exr", {})) GTEST_SKIP() << "no OpenGL 4.5 context";
  ASSERT_TRUE(render("bent.exr", {"--deform", "bend:90"}));
  ASSERT_TRUE(render("seq.exr", {"--deform", "bend:90", "--frames", "4", "--spin", "0"}));
  const auto pixels = [&](const std::string& f) { return load_envmap(dir.file(f), Mapping::LatLong).rgb; };
  const std::vector<float> rest = pixels("rest.exr"), bent = pixels("bent.exr");
  EXPECT_NE(rest, bent);
  EXPECT_EQ(pixels("seq_0000.exr"), rest);
  EXPECT_EQ(pixels("seq_0002.exr"), bent);
}

// prt render of a skinned glTF with a zh file plays the skin's animation
// (skinned on the GPU): one frame at --time (default 0, wrapping), --frames N
// one loop from there, frame f at f / N of it (of 4 frames of the 2 s loop,
// frame 2 is --time 1); the camera is the same at every time, so equal poses
// give equal images. The pose moves the image. Refusals name the problem.
TEST(LdprtCli, RenderAnimatesASkin) {
  TempDir dir;
  const std::string z = dir.file("z.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", kSkinned, "-o", z, "--basis", "zh", "--lobes", "2", "--bands", "3",
                          "--samples", "32", "-q"})
                .code,
            0);
  const auto render = [&](const std::string& out, std::vector<std::string> extra) {
    // --exposure 0: auto would measure each run's own frame (a sequence keeps its first frame's).
    std::vector<std::string> args = {"render", kSkinned, z, kEnv, "-o", dir.file(out), "--width", "96", "--height",
                                     "48", "--exposure", "0", "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const Result r = run_prt(dir, args);
    if (r.code != 0 && r.err.find("no OpenGL 4.5 context") != std::string::npos) return false;
    EXPECT_EQ(r.code, 0) << describe_run(r);
    return true;
  };
  if (!render("t0.exr", {})) GTEST_SKIP() << "no OpenGL 4.5 context";
  ASSERT_TRUE(render("t1.exr", {"--time", "1"}));
  ASSERT_TRUE(render("t3.exr", {"--time", "3", "--animation", "0"}));
  ASSERT_TRUE(render("seq.exr", {"--frames", "4", "--spin", "0"}));
  const auto pixels = [&](const std::string& f) { return load_envmap(dir.file(f), Mapping::LatLong).rgb; };
  const std::vector<float> t0 = pixels("t0.exr"), t1 = pixels("t1.exr");
  EXPECT_NE(t0, t1);
  EXPECT_EQ(pixels("t3.exr"), t1);
  EXPECT_EQ(pixels("seq_0000.exr"), t0);
  EXPECT_EQ(pixels("seq_0002.exr"), t1);
  EXPECT_NE(pixels("seq_0001.exr"), t0);

  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases = {
      {{"render", kSkinned, z, kEnv, "--deform", "bend:30", "-o", dir.file("x.png")}, "one pose source"},
      {{"render", kSkinned, z, kEnv, "--animation", "1", "-o", dir.file("x.png")}, "no animation 1"},
      {{"render", kSkinned, z, kEnv, "--time", "inf", "-o", dir.file("x.png")}, "--time"},
  };
  for (const Case& c : cases) {
    const Result r = run_prt(dir, c.args);
    EXPECT_NE(r.code, 0) << describe_run(r);
    EXPECT_NE(r.err.find(c.says), std::string::npos) << describe_run(r);
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
  }
}

TEST(LdprtCli, RefusalsNameTheProblem) {
  TempDir dir;
  const std::string z = dir.file("z.prt"), sh = dir.file("sh.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", kTube, "-o", z, "--basis", "zh", "--lobes", "1", "--bands", "3", "--samples",
                          "32", "-q"})
                .code,
            0);
  ASSERT_EQ(run_prt(dir, {"precompute", kTube, "-o", sh, "--bands", "3", "--samples", "32", "-q"}).code, 0);
  const std::string other = dir.file("other.off");
  {
    std::ofstream f(other);
    f << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  }
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases = {
      {{"precompute", kTube, "-o", dir.file("x.prt"), "--lobes", "3"}, "--basis zh only"},
      {{"precompute", kTube, "-o", dir.file("x.prt"), "--basis", "zh", "--lobes", "9"}, "--lobes"},
      {{"precompute", kTube, "-o", dir.file("x.prt"), "--basis", "zh", "--material", "glossy"}, "glossy"},
      {{"precompute", kTube, "-o", dir.file("x.prt"), "--basis", "zh", "--compress", "8x2"}, "--compress"},
      {{"precompute", kTube, "-o", dir.file("x.prt"), "--basis", "zh", "--cube-res", "16"}, "--basis wavelet only"},
      {{"relight", other, z, kEnv, "-o", dir.file("x.csv")}, "topology"},
      {{"relight", kTube, sh, kEnv, "--deform", "bend:30", "-o", dir.file("x.csv")}, "--basis zh"},
      {{"relight", kTube, z, kEnv, "--deform", "bend:x", "-o", dir.file("x.csv")}, "bend:ANGLE"},
      {{"relight", kTube, z, kEnv, "--terms", "10", "-o", dir.file("x.csv")}, "wavelet"},
      {{"render", kTube, z, kEnv, "--shading", "ao", "-o", dir.file("x.png")}, "transfer or lambert"},
      {{"render", kTube, sh, kEnv, "--deform", "bend:20", "-o", dir.file("x.png")}, "--basis zh"},
      {{"render", kTube, z, kEnv, "--deform", "fold:20", "-o", dir.file("x.png")}, "unknown deformation"},
      {{"render", kTube, z, kEnv, "--time", "1", "-o", dir.file("x.png")}, "no skin to animate"},
      {{"render", kTube, z, kEnv, "--animation", "0", "-o", dir.file("x.png")}, "no skin to animate"},
      {{"render", kTube, sh, kEnv, "--time", "1", "-o", dir.file("x.png")}, "--basis zh"},
  };
  for (const Case& c : cases) {
    const Result r = run_prt(dir, c.args);
    EXPECT_NE(r.code, 0) << describe_run(r);
    EXPECT_NE(r.err.find(c.says), std::string::npos) << describe_run(r);
    for (const char* out : {"x.prt", "x.csv", "x.png"}) EXPECT_FALSE(std::filesystem::exists(dir.file(out))) << out;
  }
}

}  // namespace
}  // namespace prt
