// `prt project --convention three` against three.js itself (label interop):
// prt writes the JSON, this test writes prt's own reconstruction and
// irradiance (sh::eval on prt's coefficients from `prt project`'s own JSON)
// at many directions, and tests/js/three_sh.mjs loads the three JSON into
// THREE.SphericalHarmonics3 / LightProbe under Node and compares getAt and
// getIrradianceAt with them (its tolerance, TOLERANCE, is named there).
// Without Node or the npm packages it skips, or fails under PRT_REQUIRE_TOOLS=1.
#include <prt/filter.h>
#include <prt/sh.h>

#include "test_files.h"
#include "test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>

#include <cstdlib>

namespace {

using namespace prt;
using namespace prt::test;

bool tools_required() {
  const char* v = std::getenv("PRT_REQUIRE_TOOLS");
  return v && *v && std::string(v) != "0";
}

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

}  // namespace
