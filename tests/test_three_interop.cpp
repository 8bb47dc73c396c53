// `prt project --convention three` against three.js itself (label interop):
// prt writes the JSON, this test writes prt's own reconstruction and
// irradiance (sh::eval on prt's coefficients from `prt project`'s own JSON)
// at many directions, and tests/js/three_sh.mjs loads the three JSON into
// THREE.SphericalHarmonics3 / LightProbe under Node and compares getAt and
// getIrradianceAt with them (its tolerance, TOLERANCE, is named there).
// And three's own GLSL, shGetIrradianceAt as its lights_pars_begin chunk
// holds it, run in a compute shader on prt's export.
// Without Node or the npm packages it skips, or fails under PRT_REQUIRE_TOOLS=1.
#include <prt/filter.h>
#include <prt/sh.h>

#include "test_files.h"
#include "test_gl.h"
#include "test_sh_gpu.h"
#include "test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace {

using namespace prt;
using namespace prt::test;

#define SKIP_WITHOUT_TOOL(why)                                                   \
  do {                                                                           \
    if (tools_required()) GTEST_FAIL() << "PRT_REQUIRE_TOOLS is set: " << (why); \
    GTEST_SKIP() << (why);                                                       \
  } while (0)

int shell(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

std::vector<glm::dvec3> coefficients_of(const nlohmann::json& j) {
  std::vector<glm::dvec3> c;
  for (const auto& t : j.at("coefficients")) c.emplace_back(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
  return c;
}

TEST(ThreeInterop, SphericalHarmonics3OnPrtsExportIsPrtsLighting) {
  if (shell("command -v node >/dev/null 2>&1") != 0) SKIP_WITHOUT_TOOL("node is not on PATH");
  TempDir dir;
  for (const char* map : {"forest.exr", "sunset.exr"}) {
    SCOPED_TRACE(map);
    const std::string env = std::string(PRT_SOURCE_DIR) + "/envmaps/" + map;
    const std::string three = dir.file("three.json"), prt_json = dir.file("prt.json"), expect = dir.file("expect.json");
    Result r = run_prt(dir, {"project", env, "--bands", "3", "--convention", "three", "-q", "-o", three});
    ASSERT_EQ(r.code, 0) << describe_run(r);
    r = run_prt(dir, {"project", env, "--bands", "3", "-q", "-o", prt_json});
    ASSERT_EQ(r.code, 0) << describe_run(r);

    // prt's own values, from prt's own coefficients.
    std::vector<glm::dvec3> c = coefficients_of(nlohmann::json::parse(read_file(prt_json)));
    ASSERT_EQ(c.size(), 9u);
    std::vector<glm::dvec3> e = c;
    sh::scale_bands(std::span<glm::dvec3>(e), sh::clamped_cosine_factors(3));
    std::vector<glm::dvec3> dirs = random_directions(1000, 3);
    for (const auto& d : special_directions()) dirs.push_back(d);
    nlohmann::json j;
    j["directions"] = nlohmann::json::array();
    j["radiance"] = nlohmann::json::array();
    j["irradiance"] = nlohmann::json::array();
    std::vector<double> y(9);
    for (const auto& d : dirs) {
      sh::eval(3, d.x, d.y, d.z, y.data());
      glm::dvec3 l(0.0), ir(0.0);
      for (int k = 0; k < 9; ++k) {
        l += c[k] * y[k];
        ir += e[k] * y[k];
      }
      j["directions"].push_back({d.x, d.y, d.z});
      j["radiance"].push_back({l.x, l.y, l.z});
      j["irradiance"].push_back({ir.x, ir.y, ir.z});
    }
    write_file(expect, j.dump());

    const std::string log = dir.file("node.txt");
    const int rc =
        shell("node " + shell_quote(std::string(PRT_SOURCE_DIR) + "/tests/js/three_sh.mjs") + " " + shell_quote(three) +
              " " + shell_quote(prt_json) + " " + shell_quote(expect) + " >" + shell_quote(log) + " 2>&1");
    const std::string out = read_file(log);
    if (rc == 77) SKIP_WITHOUT_TOOL(out);
    EXPECT_EQ(rc, 0) << out;
    RecordProperty(std::string("three_sh_") + map, out);
    std::printf("%s:\n%s", map, out.c_str());
  }
}

// 9 significant digits, a float literal (as prt project's glsl).
std::string glsl_float(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%#.9g", v);
  return b;
}

// three's 6-digit constants (see three_sh.mjs's TOLERANCE) and float arithmetic.
constexpr double kThreeGlslTol = 1e-5;

TEST(ThreeInterop, ThreesShGetIrradianceAtGlslOnPrtsExportIsPrtsIrradiance) {
  const std::string chunk_path = std::string(PRT_SOURCE_DIR) +
                                 "/tests/js/node_modules/three/src/renderers/shaders/ShaderChunk/"
                                 "lights_pars_begin.glsl.js";
  if (!std::filesystem::exists(chunk_path)) SKIP_WITHOUT_TOOL("three.js is not installed: npm ci --prefix tests/js");
  const std::string chunk = read_file(chunk_path);
  const auto start = chunk.find("vec3 shGetIrradianceAt(");
  ASSERT_NE(start, std::string::npos) << chunk_path;
  const auto end = chunk.find("\n}", start);
  ASSERT_NE(end, std::string::npos);
  const std::string fn = chunk.substr(start, end + 2 - start) + "\n";
  std::string why;
  if (!sh_gpu_context(why)) PRT_SKIP_WITHOUT_GL(why);

  TempDir dir;
  const std::string env = std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr";
  const std::string three = dir.file("three.json"), prt_json = dir.file("prt.json");
  Result r = run_prt(dir, {"project", env, "--convention", "three", "-q", "-o", three});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"project", env, "-q", "-o", prt_json});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::vector<glm::dvec3> t = coefficients_of(nlohmann::json::parse(read_file(three)));
  std::vector<glm::dvec3> e = coefficients_of(nlohmann::json::parse(read_file(prt_json)));
  sh::scale_bands(std::span<glm::dvec3>(e), sh::clamped_cosine_factors(3));
  std::string decls = fn + "const vec3 PROBE[9] = vec3[9](";
  for (int k = 0; k < 9; ++k)
    decls += "vec3(" + glsl_float(t[k].x) + ", " + glsl_float(t[k].y) + ", " + glsl_float(t[k].z) + ")" +
             (k < 8 ? ", " : ");\n");
  const std::vector<glm::dvec3> dirs = random_directions(500, 11);
  const std::vector<glm::dvec3> got =
      run_at_directions(decls, "    outs[i] = vec4(shGetIrradianceAt(d, PROBE), 1.0);\n", 1, dirs);
  double scale = 0, diff = 0;
  std::vector<double> y(9);
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    sh::eval(3, dirs[i].x, dirs[i].y, dirs[i].z, y.data());
    glm::dvec3 want(0.0);
    for (int k = 0; k < 9; ++k) want += e[k] * y[k];
    for (int c = 0; c < 3; ++c) {
      scale = std::max(scale, std::abs(want[c]));
      diff = std::max(diff, std::abs(got[i][c] - want[c]));
    }
  }
  EXPECT_GT(scale, 0.1);
  EXPECT_LT(diff / scale, kThreeGlslTol);
  RecordProperty("worst_relative", std::to_string(diff / scale));
  std::printf("three's shGetIrradianceAt (GLSL) vs prt's irradiance: worst %.3g of the largest value\n", diff / scale);
}

}  // namespace
