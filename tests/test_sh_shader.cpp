// prt project --format glsl / hlsl (prt/sh_convention.h, shader_code): the
// emitted code compiles as GLSL 4.50 in a compute shader (headless EGL, the
// runtime's own context code) and, run at many directions, gives prt's CPU
// evaluation: radiance sum c_k Y_k(d), irradiance sum A_l c_k Y_k(n) (E/pi
// for Filament and Unity, Unity's normal in Unity's axes), for every
// convention.
//
// HLSL cannot be compiled here (no DXC/FXC). Its text is checked for HLSL's
// spellings (float3/float4, static const, no GLSL vec types), then turned into
// GLSL by renaming only those keywords (static const -> const, float3 -> vec3,
// float4 -> vec4; GLSL 4.50 takes HLSL's {...} array initialisers) and run the
// same way: so its arithmetic is checked, not just its text.
#include <prt/error.h>
#include <prt/filter.h>
#include <prt/render.h>
#include <prt/sh.h>
#include <prt/sh_convention.h>

#include "test_gl.h"
#include "test_sh_gpu.h"
#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <regex>

namespace {

using namespace prt;

// GPU float against CPU double, relative to the largest |value| over the
// directions: the constants are printed to 9 digits (5e-9), three's formula
// uses its 6-digit constants (up to 1e-5 of the scale, see
// test_sh_convention), float evaluation of prt's recurrence to 10 bands is
// a few 1e-7 (sh::eval<float> measures 1.9e-6 of the band norm at 16 bands).
// 2e-5 holds all of them with margin and would catch any wrong sign or
// constant (1e-2 and more).
constexpr double kGpuTol = 2e-5;

std::string to_glsl(std::string hlsl) {
  hlsl = std::regex_replace(hlsl, std::regex(R"(\bstatic const\b)"), "const");
  hlsl = std::regex_replace(hlsl, std::regex(R"(\bfloat3\b)"), "vec3");
  return std::regex_replace(hlsl, std::regex(R"(\bfloat4\b)"), "vec4");
}

class ShShader : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!test::sh_gpu_context(why)) PRT_SKIP_WITHOUT_GL(why);
  }

  // Runs `snippet` at `dirs`: (prt_sh_irradiance, prt_sh_radiance or 0) per direction.
  static std::vector<std::pair<glm::dvec3, glm::dvec3>> run(const std::string& snippet, bool radiance,
                                                            const std::vector<glm::dvec3>& dirs) {
    const std::vector<glm::dvec3> out =
        test::run_at_directions(snippet,
                                std::string("    outs[2u * i] = vec4(prt_sh_irradiance(d), 1.0);\n") +
                                    (radiance ? "    outs[2u * i + 1u] = vec4(prt_sh_radiance(d), 1.0);\n"
                                              : "    outs[2u * i + 1u] = vec4(0.0);\n"),
                                2, dirs);
    std::vector<std::pair<glm::dvec3, glm::dvec3>> r;
    for (std::size_t i = 0; i < dirs.size(); ++i) r.emplace_back(out[2 * i], out[2 * i + 1]);
    return r;
  }
};

glm::dvec3 prt_sum(const std::vector<glm::dvec3>& c, const glm::dvec3& d, bool cosine) {
  const int bands = sh::bands_of(c.size());
  std::vector<double> y(c.size());
  sh::eval(bands, d.x, d.y, d.z, y.data());
  glm::dvec3 s(0.0);
  for (int l = 0; l < bands; ++l)
    for (int m = -l; m <= l; ++m)
      s += c[sh::index(l, m)] * (y[sh::index(l, m)] * (cosine ? sh::clamped_cosine_factor(l) : 1.0));
  return s;
}

std::string fmt_g(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

double max_abs(const glm::dvec3& v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

// Largest |got - want| over the directions, relative to the largest |want|.
double worst(const std::vector<glm::dvec3>& got, const std::vector<glm::dvec3>& want) {
  double scale = 0, diff = 0;
  for (std::size_t i = 0; i < want.size(); ++i) {
    scale = std::max(scale, max_abs(want[i]));
    diff = std::max(diff, max_abs(got[i] - want[i]));
  }
  EXPECT_GT(scale, 0.1);
  return diff / scale;
}

struct Case {
  sh::Convention conv;
  int bands;
  bool irradiance;  // prt only: the coefficients are E_lm
};

std::string name(const Case& c) {
  return std::string(sh::convention_name(c.conv)) + " " + std::to_string(c.bands) + " bands" +
         (c.irradiance ? " (irradiance)" : "");
}

void check(const Case& c, sh::ShaderLanguage lang,
           const std::function<std::vector<std::pair<glm::dvec3, glm::dvec3>>(const std::string&, bool,
                                                                              const std::vector<glm::dvec3>&)>& run) {
  std::vector<glm::dvec3> coeffs = test::random_coefficients(c.bands, 100 + c.bands);
  coeffs[0] += glm::dvec3(6.0);
  std::string code = sh::shader_code(c.conv, coeffs, c.irradiance, lang);
  const std::string what = name(c) + (lang == sh::ShaderLanguage::Hlsl ? " hlsl" : " glsl");
  if (lang == sh::ShaderLanguage::Hlsl) {
    EXPECT_FALSE(std::regex_search(code, std::regex(R"(\bvec[34]\b)"))) << what << ": GLSL type in HLSL\n" << code;
    EXPECT_NE(code.find("float3 prt_sh_irradiance(float3 n)"), std::string::npos) << what << "\n" << code;
    EXPECT_NE(code.find("static const"), std::string::npos) << what << "\n" << code;
    code = to_glsl(code);
  } else {
    EXPECT_NE(code.find("vec3 prt_sh_irradiance(vec3 n)"), std::string::npos) << what << "\n" << code;
  }
  const bool radiance = (c.conv == sh::Convention::Prt && !c.irradiance) || c.conv == sh::Convention::Three;
  EXPECT_EQ(code.find("prt_sh_radiance(") != std::string::npos, radiance) << what;

  std::vector<glm::dvec3> dirs = test::random_directions(256, 7);
  for (const auto& d : test::special_directions()) dirs.push_back(d);
  std::vector<glm::dvec3> engine_dirs;
  for (const auto& d : dirs) engine_dirs.push_back(sh::to_engine_axes(c.conv, d));
  const auto got = run(code, radiance, engine_dirs);
  std::vector<glm::dvec3> got_e, got_l, want_e, want_l;
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    glm::dvec3 e = prt_sum(coeffs, dirs[i], !c.irradiance);
    if (c.conv == sh::Convention::Filament || c.conv == sh::Convention::Unity) e /= std::numbers::pi;
    if (c.conv == sh::Convention::Filament) e = {std::max(e.x, 0.0), std::max(e.y, 0.0), std::max(e.z, 0.0)};
    got_e.push_back(got[i].first);
    want_e.push_back(e);
    got_l.push_back(got[i].second);
    want_l.push_back(prt_sum(coeffs, dirs[i], false));
  }
  const double we = worst(got_e, want_e);
  EXPECT_LT(we, kGpuTol) << what << ": irradiance";
  ::testing::Test::RecordProperty("worst_irradiance_" + what, fmt_g(we));
  if (radiance) {
    const double wl = worst(got_l, want_l);
    EXPECT_LT(wl, kGpuTol) << what << ": radiance";
    ::testing::Test::RecordProperty("worst_radiance_" + what, fmt_g(wl));
  }
}

const std::vector<Case> kCases = {
    {sh::Convention::Prt, 1, false},   {sh::Convention::Prt, 2, false},   {sh::Convention::Prt, 3, false},
    {sh::Convention::Prt, 6, false},   {sh::Convention::Prt, 10, false},  {sh::Convention::Prt, 3, true},
    {sh::Convention::Prt, 6, true},    {sh::Convention::Three, 3, false}, {sh::Convention::Filament, 3, false},
    {sh::Convention::Unity, 3, false}, {sh::Convention::Three, 2, false},
};

TEST_F(ShShader, GlslCompilesAndMatchesTheCpu) {
  for (const Case& c : kCases) check(c, sh::ShaderLanguage::Glsl, run);
}

TEST_F(ShShader, HlslHasHlslsSpellingAndTheSameArithmetic) {
  for (const Case& c : kCases) check(c, sh::ShaderLanguage::Hlsl, run);
}

TEST_F(ShShader, AWrongSignIsCaught) {
  // The comparison can fail: prt's code with the coefficients of three's
  // convention (the Condon-Shortley signs dropped) is far from prt's values.
  std::vector<glm::dvec3> c = test::random_coefficients(3, 5);
  c[0] += glm::dvec3(6.0);
  const sh::Sh9 t = sh::to_three(c);
  const std::string code = sh::shader_code(sh::Convention::Prt, std::vector<glm::dvec3>(t.begin(), t.end()), false,
                                           sh::ShaderLanguage::Glsl);
  const auto dirs = test::random_directions(256, 9);
  const auto got = run(code, true, dirs);
  std::vector<glm::dvec3> g, w;
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    g.push_back(got[i].second);
    w.push_back(prt_sum(c, dirs[i], false));
  }
  EXPECT_GT(worst(g, w), 100 * kGpuTol);
}

}  // namespace
