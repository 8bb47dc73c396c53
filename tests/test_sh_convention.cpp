// Tests of prt/sh_convention.h: prt's SH in three.js's, Filament's and Unity's
// conventions. Each engine's formula is written out here again, independently
// of the library, from the engine's own source (cited at each); prt's side is
// sh::eval and the clamped-cosine factors, so the library's constants are
// checked against both. three.js itself is run in test_three_interop.
#include <prt/error.h>
#include <prt/filter.h>
#include <prt/sh.h>
#include <prt/sh_convention.h>

#include "test_files.h"
#include "test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace {

using namespace prt;
using prt::test::random_coefficients;
using prt::test::random_directions;

using prt::test::kPi;

// The conversions are a few multiplications per coefficient in double: 1e-13
// of the function's scale leaves room for the different order of the
// products, nothing more.
constexpr double kExactTol = 1e-13;
// three.js's getAt / getIrradianceAt print their constants to 6 digits
// (0.282095 for 0.28209479..., 0.429043 for 0.42904276...): up to 2.4e-6
// relative per constant (0.315392 vs 0.31539157: 1.4e-6; 0.247708 vs
// 0.24770796: 1.7e-7). 1e-5 of the function's largest value bounds the sum of
// nine such terms.
constexpr double kThreeConstantsTol = 1e-5;

// prt's reconstruction sum_k c_k Y_k(d) and irradiance sum_k A_l c_k Y_k(d).
glm::dvec3 prt_radiance(const std::vector<glm::dvec3>& c, const glm::dvec3& d) {
  const int bands = sh::bands_of(c.size());
  std::vector<double> y(c.size());
  sh::eval(bands, d.x, d.y, d.z, y.data());
  glm::dvec3 s(0.0);
  for (std::size_t k = 0; k < c.size(); ++k) s += c[k] * y[k];
  return s;
}
glm::dvec3 prt_irradiance(std::vector<glm::dvec3> c, const glm::dvec3& n) {
  sh::scale_bands(std::span<glm::dvec3>(c), sh::clamped_cosine_factors(sh::bands_of(c.size())));
  return prt_radiance(c, n);
}

double max_abs(const glm::dvec3& v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

// Largest |got - want| over the directions, relative to the largest |want|.
template <typename Got, typename Want>
double worst_relative(const std::vector<glm::dvec3>& dirs, Got got, Want want) {
  double scale = 0, diff = 0;
  for (const auto& d : dirs) {
    const glm::dvec3 w = want(d);
    scale = std::max(scale, max_abs(w));
    diff = std::max(diff, max_abs(got(d) - w));
  }
  EXPECT_GT(scale, 0.1);
  return diff / scale;
}

// A lighting with a positive mean (so irradiance is mostly positive).
std::vector<glm::dvec3> lighting(unsigned seed) {
  std::vector<glm::dvec3> c = random_coefficients(3, seed);
  c[0] += glm::dvec3(6.0);
  return c;
}

// As --format cpp prints a float.
std::string fmt_float(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%#.9gf", v);
  return b;
}

// ---- three.js -------------------------------------------------------------------

// src/math/SphericalHarmonics3.js (three 0.187.0), getAt and getIrradianceAt.
glm::dvec3 three_get_at(const sh::Sh9& c, const glm::dvec3& n) {
  const double x = n.x, y = n.y, z = n.z;
  glm::dvec3 t = c[0] * 0.282095;
  t += c[1] * (0.488603 * y);
  t += c[2] * (0.488603 * z);
  t += c[3] * (0.488603 * x);
  t += c[4] * (1.092548 * (x * y));
  t += c[5] * (1.092548 * (y * z));
  t += c[6] * (0.315392 * (3.0 * z * z - 1.0));
  t += c[7] * (1.092548 * (x * z));
  t += c[8] * (0.546274 * (x * x - y * y));
  return t;
}
glm::dvec3 three_get_irradiance_at(const sh::Sh9& c, const glm::dvec3& n) {
  const double x = n.x, y = n.y, z = n.z;
  glm::dvec3 t = c[0] * 0.886227;
  t += c[1] * (2.0 * 0.511664 * y);
  t += c[2] * (2.0 * 0.511664 * z);
  t += c[3] * (2.0 * 0.511664 * x);
  t += c[4] * (2.0 * 0.429043 * x * y);
  t += c[5] * (2.0 * 0.429043 * y * z);
  t += c[6] * (0.743125 * z * z - 0.247708);
  t += c[7] * (2.0 * 0.429043 * x * z);
  t += c[8] * (0.429043 * (x * x - y * y));
  return t;
}

TEST(ThreeConvention, GetAtIsPrtsRadianceAndGetIrradianceAtPrtsIrradiance) {
  const auto c = lighting(1);
  const sh::Sh9 t = sh::to_three(c);
  const auto dirs = random_directions(500, 2);
  EXPECT_LT(worst_relative(
                dirs, [&](auto d) { return three_get_at(t, d); }, [&](auto d) { return prt_radiance(c, d); }),
            kThreeConstantsTol);
  EXPECT_LT(
      worst_relative(
          dirs, [&](auto d) { return three_get_irradiance_at(t, d); }, [&](auto d) { return prt_irradiance(c, d); }),
      kThreeConstantsTol);
  // The library's copy of three's formulas is the same.
  for (const auto& d : dirs) {
    EXPECT_LT(max_abs(sh::three_get_at(t, d) - three_get_at(t, d)), kExactTol * 10);
    EXPECT_LT(max_abs(sh::three_get_irradiance_at(t, d) - three_get_irradiance_at(t, d)), kExactTol * 10);
  }
}

TEST(ThreeConvention, NoCondonShortleyPhase) {
  // three's basis has +y, +x where prt's has -y, -x: the coefficients of
  // prt's odd-m functions change sign, the others stay.
  const auto c = lighting(3);
  const sh::Sh9 t = sh::to_three(c);
  for (int k = 0; k < 9; ++k) {
    const bool odd_m = k == 1 || k == 3 || k == 5 || k == 7;
    EXPECT_EQ(t[k], odd_m ? -c[k] : c[k]) << k;
  }
}

// ---- Filament ---------------------------------------------------------------------

// libs/ibl/src/CubemapSH.cpp (google/filament): computeSH(..., irradiance =
// true) multiplies the orthonormal (Condon-Shortley) projection by
// computeTruncatedCosSh(l) = pi, 2pi/3, pi/4; preprocessSHForShader then
// multiplies coefficient i by A[i] / pi with A the polynomial constants below.
sh::Sh9 filament_from_prt(const std::vector<glm::dvec3>& radiance) {
  const double sqrt_pi = std::sqrt(kPi), s3 = std::sqrt(3.0), s5 = std::sqrt(5.0), s15 = std::sqrt(15.0);
  const double A[9] = {1 / (2 * sqrt_pi),   -s3 / (2 * sqrt_pi),  s3 / (2 * sqrt_pi),
                       -s3 / (2 * sqrt_pi), s15 / (2 * sqrt_pi),  -s15 / (2 * sqrt_pi),
                       s5 / (4 * sqrt_pi),  -s15 / (2 * sqrt_pi), s15 / (4 * sqrt_pi)};
  const double truncated_cos[3] = {kPi, 2 * kPi / 3, kPi / 4};
  const int band[9] = {0, 1, 1, 1, 2, 2, 2, 2, 2};
  sh::Sh9 f;
  for (int i = 0; i < 9; ++i) f[i] = radiance[i] * truncated_cos[band[i]] * A[i] * (1 / kPi);
  return f;
}
// shaders/src/surface_light_indirect.fs, Irradiance_SphericalHarmonics (3 bands).
glm::dvec3 filament_irradiance_sh(const sh::Sh9& s, const glm::dvec3& n) {
  const glm::dvec3 e = s[0] + s[1] * (n.y) + s[2] * (n.z) + s[3] * (n.x) + s[4] * (n.y * n.x) + s[5] * (n.y * n.z) +
                       s[6] * (3.0 * n.z * n.z - 1.0) + s[7] * (n.z * n.x) + s[8] * (n.x * n.x - n.y * n.y);
  return {std::max(e.x, 0.0), std::max(e.y, 0.0), std::max(e.z, 0.0)};
}

TEST(FilamentConvention, ArrayIsCmgensAndItsShaderGivesIrradianceOverPi) {
  const auto c = lighting(4);
  const sh::Sh9 f = sh::to_filament(c);
  const sh::Sh9 ref = filament_from_prt(c);
  for (int k = 0; k < 9; ++k) EXPECT_LT(max_abs(f[k] - ref[k]), kExactTol * max_abs(ref[0])) << k;
  const auto dirs = random_directions(500, 5);
  const auto clamp0 = [](glm::dvec3 v) {
    return glm::dvec3(std::max(v.x, 0.0), std::max(v.y, 0.0), std::max(v.z, 0.0));
  };
  EXPECT_LT(worst_relative(
                dirs, [&](auto d) { return filament_irradiance_sh(f, d); },
                [&](auto d) { return clamp0(prt_irradiance(c, d) / kPi); }),
            kExactTol);
  for (const auto& d : dirs)
    EXPECT_LT(max_abs(sh::filament_irradiance(f, d) - filament_irradiance_sh(f, d)), kExactTol);
}

// ---- Unity ------------------------------------------------------------------------

// Unity-Technologies/Graphics, HDRP Runtime/Lighting/SphericalHarmonics.cs:
// SphericalHarmonicsL2 holds the canonical SH times kNormalizationConstants
// (their inverse, invNormConsts, is what UndoCosineRescaling applies):
// c0 = 1/2 sqrt(1/pi), c1 = 1/3 sqrt(3/pi), c2 = 1/8 sqrt(15/pi),
// c3 = 1/16 sqrt(5/pi), c4 = 1/16 sqrt(15/pi), signs {+, -, +, -, +, -, +, -, +}.
// The canonical SH here are of the lighting in Unity's axes, z negated.
sh::Sh9 unity_from_prt(const std::vector<glm::dvec3>& radiance) {
  const double c0 = 0.5 * std::sqrt(1 / kPi), c1 = std::sqrt(3 / kPi) / 3, c2 = std::sqrt(15 / kPi) / 8,
               c3 = std::sqrt(5 / kPi) / 16, c4 = std::sqrt(15 / kPi) / 16;
  const double norm[9] = {c0, -c1, c1, -c1, c2, -c2, c3, -c2, c4};
  // f(x, y, -z): Y_lm(x, y, -z) = (-1)^(l+m) Y_lm(x, y, z).
  const double mirror_z[9] = {1, 1, -1, 1, 1, -1, 1, -1, 1};
  sh::Sh9 u;
  for (int i = 0; i < 9; ++i) u[i] = radiance[i] * mirror_z[i] * norm[i];
  return u;
}
// The same file's PackCoefficients (the packing into unity_SHAr ... unity_SHC).
sh::UnityPacked unity_pack(const sh::Sh9& sh) {
  sh::UnityPacked p;
  for (int c = 0; c < 3; ++c) p[c] = {sh[3][c], sh[1][c], sh[2][c], sh[0][c] - sh[6][c]};
  for (int c = 0; c < 3; ++c) p[3 + c] = {sh[4][c], sh[5][c], sh[6][c] * 3.0, sh[7][c]};
  p[6] = {sh[8][0], sh[8][1], sh[8][2], 1.0};
  return p;
}
// CGIncludes/UnityCG.cginc: ShadeSH9 = SHEvalLinearL0L1 + SHEvalLinearL2 (linear colour space).
glm::dvec3 shade_sh9(const sh::UnityPacked& p, const glm::dvec3& n) {
  const auto dot = [](const glm::dvec4& a, const glm::dvec4& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w;
  };
  const glm::dvec4 normal(n, 1.0);
  glm::dvec3 x{dot(p[0], normal), dot(p[1], normal), dot(p[2], normal)};
  const glm::dvec4 vB(normal.x * normal.y, normal.y * normal.z, normal.z * normal.z, normal.z * normal.x);
  glm::dvec3 x1{dot(p[3], vB), dot(p[4], vB), dot(p[5], vB)};
  const double vC = normal.x * normal.x - normal.y * normal.y;
  return x + x1 + glm::dvec3(p[6]) * vC;
}

TEST(UnityConvention, ShadeSH9AtTheMirroredNormalIsIrradianceOverPi) {
  const auto c = lighting(6);
  const sh::Sh9 u = sh::to_unity(c);
  const sh::Sh9 ref = unity_from_prt(c);
  for (int k = 0; k < 9; ++k) EXPECT_LT(max_abs(u[k] - ref[k]), kExactTol * max_abs(ref[0])) << k;
  const sh::UnityPacked p = sh::unity_pack(u), pref = unity_pack(ref);
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(p[i][j], pref[i][j], kExactTol * max_abs(ref[0])) << i << "," << j;
  const auto dirs = random_directions(500, 7);
  const auto unity_n = [](const glm::dvec3& d) { return glm::dvec3(d.x, d.y, -d.z); };
  EXPECT_LT(
      worst_relative(
          dirs, [&](auto d) { return shade_sh9(p, unity_n(d)); }, [&](auto d) { return prt_irradiance(c, d) / kPi; }),
      kExactTol);
  for (const auto& d : dirs) {
    EXPECT_LT(max_abs(sh::unity_shade_sh9(p, d) - shade_sh9(p, d)), kExactTol * 10);
    EXPECT_EQ(sh::to_engine_axes(sh::Convention::Unity, d), unity_n(d));
  }
}

// Godot 4's probe SH (LightmapGIData probe_data "sh"): its lightmap capture
// at n is E/pi (prt's irradiance, here from prt's own formula, over pi),
// and a white sky of radiance 1 shows 1 (Godot applies no 1/pi after it).
TEST(GodotConvention, LightmapCaptureOfTheProbeArrayIsIrradianceOverPi) {
  const auto c = lighting(9);
  const sh::Sh9 g = sh::to_godot(c);
  EXPECT_LT(worst_relative(
                random_directions(500, 11), [&](auto d) { return sh::godot_lightmap_capture(g, d); },
                [&](auto d) { return prt_irradiance(c, d) / kPi; }),
            kThreeConstantsTol);  // Godot's shader prints three's 6-digit constants
  std::vector<glm::dvec3> white(9, glm::dvec3(0.0));
  white[0] = glm::dvec3(2.0 * std::sqrt(kPi));  // radiance 1 in every direction: c0 = 1 / Y_00
  for (const auto& d : random_directions(50, 12))
    EXPECT_LT(max_abs(sh::godot_lightmap_capture(sh::to_godot(white), d) - glm::dvec3(1.0)), 1e-5);
}

// ---- world axes: a light from a known direction -------------------------------------

// A small bright light from s (prt's axes): its SH is the basis at s. The
// engine's irradiance must peak at the engine's version of s: s itself for
// three and Filament, (s.x, s.y, -s.z) for Unity; and for a light that is not
// in the z = 0 plane, Unity at s itself must differ.
TEST(EngineAxes, ALightFromSAppearsFromTheEnginesS) {
  const glm::dvec3 s = glm::normalize(glm::dvec3(0.3, 0.5, 0.8));
  std::vector<double> y(9);
  sh::eval(3, s.x, s.y, s.z, y.data());
  std::vector<glm::dvec3> c(9);
  for (int k = 0; k < 9; ++k) c[k] = glm::dvec3(y[k]);
  const sh::Sh9 t = sh::to_three(c), f = sh::to_filament(c);
  const sh::UnityPacked u = sh::unity_pack(sh::to_unity(c));
  const auto dirs = random_directions(4000, 8);
  const auto argmax = [&](auto e) {
    glm::dvec3 best = dirs[0];
    for (const auto& d : dirs)
      if (e(d).x > e(best).x) best = d;
    return best;
  };
  // 4000 random directions are at most ~3.6 degrees apart: the peak found
  // is within 0.995 (5.7 degrees) of the true one.
  constexpr double kPeakCos = 0.995;
  EXPECT_GT(glm::dot(argmax([&](auto d) { return three_get_irradiance_at(t, d); }), s), kPeakCos);
  EXPECT_GT(glm::dot(argmax([&](auto d) { return filament_irradiance_sh(f, d); }), s), kPeakCos);
  const glm::dvec3 su(s.x, s.y, -s.z);
  EXPECT_GT(glm::dot(argmax([&](auto d) { return shade_sh9(u, d); }), su), kPeakCos);
  // Unity at s itself: the light is elsewhere (E(s') for s' = s mirrored).
  EXPECT_LT(shade_sh9(u, s).x, 0.9 * shade_sh9(u, su).x);
}

// ---- round trips --------------------------------------------------------------------

TEST(EngineRoundTrip, PrtToEngineToPrtIsTheIdentity) {
  for (unsigned seed = 10; seed < 14; ++seed) {
    const auto c = lighting(seed);
    const double scale = max_abs(c[0]);
    const auto close = [&](const std::vector<glm::dvec3>& back, const char* what) {
      ASSERT_EQ(back.size(), 9u);
      for (int k = 0; k < 9; ++k) EXPECT_LT(max_abs(back[k] - c[k]), kExactTol * scale) << what << " k=" << k;
    };
    close(sh::from_three(sh::to_three(c)), "three");
    close(sh::from_filament(sh::to_filament(c)), "filament");
    close(sh::from_unity(sh::to_unity(c)), "unity");
    close(sh::from_unity(sh::unity_unpack(sh::unity_pack(sh::to_unity(c)))), "unity packed");
  }
}

TEST(EngineRoundTrip, FewerBandsArePaddedAndMoreRefused) {
  const auto c1 = random_coefficients(2, 20);
  const sh::Sh9 t = sh::to_three(c1);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(max_abs(t[k]), max_abs(c1[k]));
  for (int k = 4; k < 9; ++k) EXPECT_EQ(max_abs(t[k]), 0.0);
  EXPECT_THROW(sh::to_filament(random_coefficients(4, 21)), Error);
  EXPECT_THROW(sh::to_unity(std::vector<glm::dvec3>(5)), Error);
  EXPECT_EQ(sh::parse_convention("unity"), sh::Convention::Unity);
  EXPECT_THROW(sh::parse_convention("godot"), Error);
}

// ---- prt project --convention ---------------------------------------------------------

TEST(CliConvention, JsonSaysTheConventionAndHoldsTheEnginesArray) {
  prt::test::TempDir dir;
  const std::string env = std::string(PRT_SOURCE_DIR) + "/envmaps/forest.exr";
  const auto json_of = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"project", env, "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const prt::test::Result r = prt::test::run_prt(dir, args);
    EXPECT_EQ(r.code, 0) << prt::test::describe_run(r);
    return nlohmann::json::parse(r.out);
  };
  const auto coeffs = [](const nlohmann::json& j) {
    std::vector<glm::dvec3> c;
    for (const auto& t : j.at("coefficients"))
      c.emplace_back(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
    return c;
  };
  const nlohmann::json p = json_of({}), t = json_of({"--convention", "three"}),
                       f = json_of({"--convention", "filament"}), u = json_of({"--convention", "unity"});
  EXPECT_EQ(p.at("convention"), "prt");
  EXPECT_EQ(t.at("convention"), "three");
  EXPECT_EQ(f.at("convention"), "filament");
  EXPECT_EQ(u.at("convention"), "unity");
  const std::vector<glm::dvec3> c = coeffs(p);
  // JSON doubles round-trip: the engines' arrays are the library's, exactly.
  const sh::Sh9 want_t = sh::to_three(c), want_f = sh::to_filament(c), want_u = sh::to_unity(c);
  const auto tc = coeffs(t), fc = coeffs(f), uc = coeffs(u);
  ASSERT_EQ(tc.size(), 9u);
  ASSERT_EQ(fc.size(), 9u);
  ASSERT_EQ(uc.size(), 9u);
  for (int k = 0; k < 9; ++k) {
    EXPECT_EQ(tc[k], want_t[k]);
    EXPECT_EQ(fc[k], want_f[k]);
    EXPECT_EQ(uc[k], want_u[k]);
  }
  const sh::UnityPacked packed = sh::unity_pack(want_u);
  EXPECT_EQ(u.at("unity_SH").at("unity_SHAr")[3].get<double>(), packed[0].w);
  EXPECT_EQ(u.at("unity_SH").at("unity_SHC")[0].get<double>(), packed[6].x);
}

TEST(CliConvention, CodeFormatsAreTheLibrarysShaderCode) {
  prt::test::TempDir dir;
  const std::string env = std::string(PRT_SOURCE_DIR) + "/envmaps/forest.exr";
  prt::test::Result r = prt::test::run_prt(dir, {"project", env, "-q"});
  ASSERT_EQ(r.code, 0) << prt::test::describe_run(r);
  std::vector<glm::dvec3> c;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  for (const auto& t : j.at("coefficients")) c.emplace_back(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
  for (const char* conv : {"prt", "three", "filament", "unity"})
    for (const char* format : {"glsl", "hlsl"}) {
      r = prt::test::run_prt(dir, {"project", env, "-q", "--convention", conv, "--format", format});
      ASSERT_EQ(r.code, 0) << prt::test::describe_run(r);
      const std::string code =
          sh::shader_code(sh::parse_convention(conv), c, false,
                          std::string(format) == "glsl" ? sh::ShaderLanguage::Glsl : sh::ShaderLanguage::Hlsl);
      EXPECT_NE(r.out.find(code), std::string::npos) << conv << " " << format << ":\n" << r.out;
    }
  r = prt::test::run_prt(dir, {"project", env, "-q", "--convention", "unity", "--format", "cpp"});
  ASSERT_EQ(r.code, 0) << prt::test::describe_run(r);
  EXPECT_NE(r.out.find("kPrtUnitySH[7][4]"), std::string::npos) << r.out;
  r = prt::test::run_prt(dir, {"project", env, "-q", "--convention", "three", "--format", "cpp"});
  ASSERT_EQ(r.code, 0) << prt::test::describe_run(r);
  const sh::Sh9 t = sh::to_three(c);
  EXPECT_NE(r.out.find(fmt_float(t[1].x)), std::string::npos) << r.out;
}

TEST(CliConvention, RefusesWhatAnEngineCannotTake) {
  prt::test::TempDir dir;
  const std::string env = std::string(PRT_SOURCE_DIR) + "/envmaps/forest.exr";
  struct Case {
    std::vector<std::string> args;
    std::string words;
  };
  for (const Case& c : std::vector<Case>{{{"--convention", "three", "--bands", "4"}, "3 bands"},
                                         {{"--convention", "filament", "--irradiance"}, "radiance"},
                                         {{"--convention", "unity", "--format", "text"}, "--format text"},
                                         {{"--convention", "godot"}, "--convention"}}) {
    std::vector<std::string> args = {"project", env, "-q"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const prt::test::Result r = prt::test::run_prt(dir, args);
    EXPECT_EQ(r.code, 2) << prt::test::describe_run(r);
    EXPECT_NE(r.err.find(c.words), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }
}

}  // namespace
