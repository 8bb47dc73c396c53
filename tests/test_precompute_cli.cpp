// prt precompute / relight / info end to end through the real executable.
#include "test_files.h"
#include "test_meshes.h"

#include <prt/vertex_csv.h>
#include <prt/compare.h>
#include <prt/envmap.h>

#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>

#include <chrono>
#include <thread>

namespace prt {
namespace {

using namespace prt::test;

// A 4x4-cell quad facing +Y as an OFF file.
std::string write_quad(const TempDir& dir) {
  const std::string path = dir.file("quad.off");
  test::write_off(path, test::quad(4));
  return path;
}

std::string write_constant_map(const TempDir& dir, float value) {
  const std::string path = dir.file("constant.exr");
  write_image(path, 64, 32, std::vector<float>(64 * 32 * 3, value));
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
  EXPECT_NE(info.out.find("25"), std::string::npos) << info.out;  // 25 vertices
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
  const std::vector<std::vector<std::string>> cases = {
      {"precompute", mesh, "-o", dir.file("x.prt"), "--bands", "0"},
      {"precompute", mesh, "-o", dir.file("x.prt"), "--bands", "17"},
      {"precompute", mesh, "-o", dir.file("x.prt"), "--samples", "0"},
      {"precompute", mesh, "-o", dir.file("x.prt"), "--albedo", "2,0,0"},
      {"precompute", mesh, "-o", dir.file("x.prt"), "--mode", "ambient"},
      {"precompute", mesh, "-o", dir.file("x.prt"), "--vertex-colors"},
      {"precompute", dir.file("missing.obj"), "-o", dir.file("x.prt")},
      {"precompute", mesh, "-o", dir.file("nodir/x.prt")},
      {"relight", mesh, dir.file("missing.prt"), dir.file("constant.exr"), "-o", dir.file("x.csv")},
      {"relight", mesh, mesh, mesh, "-o", dir.file("x.txt")},
  };
  for (const auto& args : cases) {
    const Result r = run_prt(dir, args);
    EXPECT_NE(r.code, 0) << describe_run(r);
    EXPECT_LT(r.code, 3) << "not a clean user error: " << describe_run(r);
    EXPECT_FALSE(r.err.empty());
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.prt")));
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.csv")));
  }
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
  // A job long enough to interrupt: the bundled model at many rays per vertex.
  TempDir dir;
  const std::string out = dir.file("big.prt");
  const std::string model = std::string(PRT_SOURCE_DIR) + "/models/scene.obj";
  std::vector<std::string> args = {PRT_EXE, "precompute", model, "-o", out, "--samples", "65536", "-q"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, PRT_EXE, nullptr, nullptr, argv.data(), environ), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by a signal instead of stopping cleanly";
  EXPECT_EQ(WEXITSTATUS(status), 130);
  EXPECT_TRUE(dir.listing().empty()) << "left: " << dir.listing().front();
}

}  // namespace
}  // namespace prt
