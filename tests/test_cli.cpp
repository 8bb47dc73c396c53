// Tests of the `prt` command line: runs the built executable (PRT_EXE) with
// stdout and stderr captured to files, and compares its output with the
// library computed in-process. Inputs other than the shipped envmaps are
// generated at run time in a per-test temporary directory.
#include "test_child.h"
#include "test_files.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/filter.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <regex>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

using prt::test::kPi;

// ---- tolerances ---------------------------------------------------------------

// JSON carries doubles in shortest round-trip form and the projection is
// deterministic (bit-identical for any thread count), so the CLI's numbers
// should equal the in-process ones; 1e-12 relative allows only for a
// different but equally exact evaluation order.
constexpr double kJsonRelTol = 1e-12;
// The text table prints %.17g: a double round-trips exactly; 1e-15 leaves a
// few ulps.
constexpr double kTextRelTol = 1e-15;
// glsl / cpp print 9 significant digits: rounding error below 5e-9 relative.
constexpr double kCodeRelTol = 5e-9;
// The reconstruction is written as float EXR from float pixels: exact; 1e-6
// relative is float precision with margin.
constexpr double kImageRelTol = 1e-6;
// Irradiance of a constant map: c_00 = pi sqrt(4 pi) exactly (box quadrature
// integrates each pixel exactly), every other coefficient zero up to
// accumulated rounding (~1e-15 observed).
constexpr double kIrradianceTol = 1e-12;

// ---- helpers --------------------------------------------------------------------

using namespace prt::test;

std::string repo_envmap(const std::string& name) { return std::string(PRT_SOURCE_DIR) + "/envmaps/" + name; }

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream is(text);
  for (std::string line; std::getline(is, line);) lines.push_back(line);
  return lines;
}

bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// |got - want| <= rel * |want| per component; `floor` (relative to the largest
// coefficient) stands in for |want| at coefficients that are ~0.
void expect_coeffs_near(const std::vector<glm::dvec3>& got, const std::vector<glm::dvec3>& want, double rel,
                        const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  double scale = 0;
  for (const auto& w : want) scale = std::max({scale, std::abs(w.x), std::abs(w.y), std::abs(w.z)});
  for (std::size_t k = 0; k < want.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      const double g = got[k][c], w = want[k][c];
      EXPECT_LE(std::abs(g - w), rel * std::max(std::abs(w), 1e-12 * scale))
          << what << ": coefficient " << k << " channel " << c << ": " << g << " vs " << w;
    }
}

std::vector<glm::dvec3> coeffs_from_json(const nlohmann::json& j) {
  std::vector<glm::dvec3> c;
  for (const auto& t : j.at("coefficients")) {
    EXPECT_EQ(t.size(), 3u);
    c.emplace_back(t.at(0).get<double>(), t.at(1).get<double>(), t.at(2).get<double>());
  }
  return c;
}

// In-process reference: the library's projection of a map file.
std::vector<glm::dvec3> reference(const std::string& path, int bands) {
  return prt::project(prt::load_envmap(path), bands);
}

void write_constant_map(const std::string& path, int W, int H, float value) {
  prt::write_image(path, W, H, std::vector<float>(std::size_t(W) * H * 3, value));
}

// ---- help, version, no subcommand ------------------------------------------------

TEST(CliHelp, TopLevelHelp) {
  TempDir dir;
  const Result r = run_prt(dir, {"--help"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  for (const char* word : {"project", "verify", "--version", "--help"}) EXPECT_TRUE(contains(r.out, word)) << word;
}

TEST(CliHelp, ProjectHelpListsItsOptions) {
  TempDir dir;
  const Result r = run_prt(dir, {"project", "--help"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  for (const char* word : {"ENV", "--bands", "--output", "--format", "--window", "--window-width", "--irradiance",
                           "--rotate", "--mapping", "--quadrature", "--reconstruct", "--reconstruct-size", "--exposure", "--quiet",
                           "json", "glsl", "cpp", "hcross", "vcross", "faces"})
    EXPECT_TRUE(contains(r.out, word)) << word << "\n" << r.out;
}

TEST(CliHelp, VerifyHelpListsItsOptions) {
  TempDir dir;
  const Result r = run_prt(dir, {"verify", "--help"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  for (const char* word : {"--bands-max", "--verbose"}) EXPECT_TRUE(contains(r.out, word)) << word << "\n" << r.out;
}

TEST(CliHelp, NoSubcommandIsAnError) {
  TempDir dir;
  const Result r = run_prt(dir, {});
  EXPECT_NE(r.code, 0) << describe_run(r);
  EXPECT_LT(r.code, 128) << "crashed: " << describe_run(r);
  EXPECT_TRUE(contains(lower(r.err), "subcommand")) << describe_run(r);
  EXPECT_TRUE(r.out.empty()) << describe_run(r);
}

TEST(CliHelp, UnknownSubcommandIsAnError) {
  TempDir dir;
  const Result r = run_prt(dir, {"frobnicate"});
  EXPECT_EQ(r.code, 2) << describe_run(r);  // a usage error
  EXPECT_TRUE(contains(r.err, "unknown command 'frobnicate'")) << r.err;
  EXPECT_TRUE(contains(r.err, "verify")) << "lists the commands: " << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(CliHelp, VersionPrintsAVersion) {
  TempDir dir;
  const Result r = run_prt(dir, {"--version"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(^prt \d+\.\d+\.\d+)"))) << r.out;
}

// ---- project: outputs ---------------------------------------------------------------

TEST(CliProject, JsonMatchesTheLibrary) {
  TempDir dir;
  const std::string env = repo_envmap("forest.exr");
  const Result r = run_prt(dir, {"project", env, "--bands", "3"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out;
  EXPECT_EQ(j.at("bands").get<int>(), 3);
  ASSERT_EQ(j.at("coefficients").size(), 9u);
  for (const auto& t : j.at("coefficients")) {
    ASSERT_TRUE(t.is_array());
    ASSERT_EQ(t.size(), 3u);
    for (const auto& v : t) ASSERT_TRUE(v.is_number());
  }
  expect_coeffs_near(coeffs_from_json(j), reference(env, 3), kJsonRelTol, "json");
  EXPECT_TRUE(j.at("convention").is_string());
  EXPECT_EQ(j.at("source").get<std::string>(), env);
  EXPECT_EQ(j.at("mapping").get<std::string>(), "lat-long");
  EXPECT_EQ(j.at("quantity").get<std::string>(), "radiance");
  EXPECT_EQ(j.at("quadrature").get<std::string>(), "box");
  EXPECT_EQ(j.at("window").at("kind").get<std::string>(), "none");

  // stderr: exactly the one-line summary of the map.
  const prt::EnvMap m = prt::load_envmap(env);
  EXPECT_EQ(r.err, prt::describe(m) + "\n");
  const auto err_lines = lines_of(r.err);
  ASSERT_EQ(err_lines.size(), 1u) << r.err;
  for (const char* word : {"forest.exr", "1024x512", "min", "max", "mean", "negative", "non-finite"})
    EXPECT_TRUE(contains(err_lines[0], word)) << word << " in: " << err_lines[0];
  EXPECT_TRUE(contains(err_lines[0], std::to_string(m.stats.negative) + " negative")) << err_lines[0];
  EXPECT_TRUE(contains(err_lines[0], "0 non-finite")) << err_lines[0];
}

TEST(CliProject, QuietPrintsNoSummary) {
  TempDir dir;
  const Result r = run_prt(dir, {"project", repo_envmap("studio.exr"), "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(r.err.empty()) << r.err;
  nlohmann::json j;
  EXPECT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out;
}

TEST(CliProject, TextTableRoundTrips) {
  TempDir dir;
  const std::string env = repo_envmap("forest.exr");
  const Result r = run_prt(dir, {"project", env, "--bands", "3", "--format", "text"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  std::vector<glm::dvec3> got;
  int row = 0;
  for (const auto& line : lines_of(r.out)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream is(line);
    int k = -1, l = -1, m = 99;
    std::string sr, sg, sb;
    ASSERT_TRUE(is >> k >> l >> m >> sr >> sg >> sb) << line;
    EXPECT_EQ(k, row) << line;
    EXPECT_EQ(k, prt::sh::index(l, m)) << line;
    got.emplace_back(std::strtod(sr.c_str(), nullptr), std::strtod(sg.c_str(), nullptr), std::strtod(sb.c_str(), nullptr));
    ++row;
  }
  ASSERT_EQ(got.size(), 9u) << r.out;
  expect_coeffs_near(got, reference(env, 3), kTextRelTol, "text");
}

TEST(CliProject, GlslSnippetHasAllCoefficients) {
  TempDir dir;
  const std::string env = repo_envmap("forest.exr");
  const Result r = run_prt(dir, {"project", env, "--bands", "3", "--format", "glsl"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "PRT_SH_BANDS = 3")) << r.out;
  EXPECT_TRUE(contains(r.out, "PRT_SH_COEFFS[9]")) << r.out;
  const std::regex vec3(R"(vec3\(([^,()]+), ([^,()]+), ([^,()]+)\))");
  std::vector<glm::dvec3> got;
  for (std::sregex_iterator it(r.out.begin(), r.out.end(), vec3), end; it != end; ++it)
    got.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]));
  ASSERT_EQ(got.size(), 9u) << r.out;
  expect_coeffs_near(got, reference(env, 3), kCodeRelTol, "glsl");
}

TEST(CliProject, CppSnippetHasAllCoefficients) {
  TempDir dir;
  const std::string env = repo_envmap("forest.exr");
  const Result r = run_prt(dir, {"project", env, "--bands", "3", "--format", "cpp"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "kPrtShBands = 3")) << r.out;
  EXPECT_TRUE(contains(r.out, "kPrtShCoeffs[9][3]")) << r.out;
  const std::regex triple(R"(\{([^,{}]+)f, ([^,{}]+)f, ([^,{}]+)f\})");
  std::vector<glm::dvec3> got;
  for (std::sregex_iterator it(r.out.begin(), r.out.end(), triple), end; it != end; ++it)
    got.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]));
  ASSERT_EQ(got.size(), 9u) << r.out;
  expect_coeffs_near(got, reference(env, 3), kCodeRelTol, "cpp");
}

TEST(CliProject, CppSnippetLiteralsAreValidCpp) {
  // The snippet is "paste-ready": every number must be a valid C++ float
  // literal, which needs a '.' or an exponent before the 'f' ("0f" and "2f"
  // do not compile).
  // Regression: "{:.9g}f" printed "0f" for an exact zero (here the green
  // channel of a map with G = 0) and "2f" for integral values: not C++.
  TempDir dir;
  const std::string env = dir.file("red_blue.exr");
  std::vector<float> rgb(64 * 32 * 3);
  for (std::size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = 1.0f;
    rgb[i + 1] = 0.0f;
    rgb[i + 2] = 2.0f;
  }
  prt::write_image(env, 64, 32, rgb);
  const Result r = run_prt(dir, {"project", env, "--bands", "2", "--format", "cpp", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::regex number(R"([-+]?(\d|\.\d)[0-9.eE+-]*f?)");
  const std::regex float_literal(R"([-+]?(\d+\.\d*|\.\d+|\d+(\.\d*)?[eE][-+]?\d+)f)");
  const auto start = r.out.find("= {");
  ASSERT_NE(start, std::string::npos) << r.out;
  const std::string body = r.out.substr(start);
  int numbers = 0;
  for (std::sregex_iterator it(body.begin(), body.end(), number), end; it != end; ++it, ++numbers)
    EXPECT_TRUE(std::regex_match(it->str(), float_literal)) << "not a C++ float literal: '" << it->str() << "'";
  EXPECT_EQ(numbers, 12);
}

TEST(CliProject, OutputFileAndNothingOnStdout) {
  TempDir dir;
  const std::string env = repo_envmap("studio.exr");
  const std::string out = dir.file("out.json");
  const Result r = run_prt(dir, {"project", env, "--bands", "3", "-o", out});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(r.out.empty()) << r.out;
  ASSERT_TRUE(fs::exists(out));
  const nlohmann::json j = nlohmann::json::parse(read_file(out));
  expect_coeffs_near(coeffs_from_json(j), reference(env, 3), kJsonRelTol, "-o");
  // The same text as on stdout, and no temporary left beside it.
  const Result s = run_prt(dir, {"project", env, "--bands", "3"});
  ASSERT_EQ(s.code, 0) << describe_run(s);
  EXPECT_EQ(read_file(out), s.out);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"out.json"});
  // --output - means stdout.
  const Result dash = run_prt(dir, {"project", env, "--output", "-"});
  ASSERT_EQ(dash.code, 0) << describe_run(dash);
  EXPECT_EQ(dash.out, s.out);
}

TEST(CliProject, ReconstructWritesTheReconstruction) {
  TempDir dir;
  const std::string env = repo_envmap("forest.exr");
  const std::string rec = dir.file("rec.exr");
  const Result r = run_prt(dir, {"project", env, "--bands", "3", "--reconstruct", rec});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.err, "rec.exr")) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  const std::vector<glm::dvec3> c = coeffs_from_json(j);
  const prt::EnvMap m = prt::load_envmap(rec);
  ASSERT_EQ(m.width, 1024);
  ASSERT_EQ(m.height, 512);
  const std::vector<float> want = prt::reconstruct_latlong(c, 1024, 512);
  ASSERT_EQ(m.rgb.size(), want.size());
  float scale = 0;
  for (float v : want) scale = std::max(scale, std::abs(v));
  std::size_t bad = 0;
  for (std::size_t i = 0; i < want.size(); ++i)
    if (std::abs(m.rgb[i] - want[i]) > kImageRelTol * std::max(std::abs(want[i]), 1e-6f * scale)) {
      if (bad++ == 0) ADD_FAILURE() << "value " << i << ": " << m.rgb[i] << " vs " << want[i];
    }
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"rec.exr"});
}

TEST(CliProject, ReconstructSize) {
  TempDir dir;
  const std::string rec = dir.file("small.exr");
  const Result r =
      run_prt(dir, {"project", repo_envmap("sunset.exr"), "--reconstruct", rec, "--reconstruct-size", "64x32", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const prt::EnvMap m = prt::load_envmap(rec);
  EXPECT_EQ(m.width, 64);
  EXPECT_EQ(m.height, 32);
  const std::vector<float> want = prt::reconstruct_latlong(coeffs_from_json(nlohmann::json::parse(r.out)), 64, 32);
  ASSERT_EQ(m.rgb.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i)
    ASSERT_NEAR(m.rgb[i], want[i], kImageRelTol * std::max(1.0f, std::abs(want[i]))) << i;
}

// --exposure scales the picture by 2^stops; auto puts the 99th percentile of
// the pixels' largest channel at 1 (a brighter irradiance picture would
// saturate most of its 8-bit pixels); without --reconstruct it is refused.
TEST(CliProject, ReconstructExposure) {
  TempDir dir;
  const std::string env = repo_envmap("courtyard.exr");
  const auto picture = [&](const std::string& name, const std::string& exposure) {
    const std::string rec = dir.file(name);
    const Result r = run_prt(dir, {"project", env, "--bands", "3", "--irradiance", "-o", dir.file(name + ".json"),
                                   "--reconstruct", rec, "--reconstruct-size", "64x32", "--exposure", exposure, "-q"});
    EXPECT_EQ(r.code, 0) << describe_run(r);
    return prt::load_envmap(rec).rgb;
  };
  const std::vector<float> plain = picture("plain.exr", "0"), brighter = picture("bright.exr", "1.5"),
                           automatic = picture("auto.exr", "auto");
  ASSERT_EQ(plain.size(), brighter.size());
  for (std::size_t i = 0; i < plain.size(); ++i)
    ASSERT_NEAR(brighter[i], std::exp2(1.5f) * plain[i], kImageRelTol * std::max(1.0f, std::abs(brighter[i]))) << i;
  std::vector<float> top;
  for (std::size_t p = 0; p < automatic.size() / 3; ++p)
    top.push_back(std::max({automatic[3 * p], automatic[3 * p + 1], automatic[3 * p + 2]}));
  std::sort(top.begin(), top.end());
  std::size_t above = 0, plain_above = 0;
  for (float v : top) above += v > 1.0f + 1e-5f;
  for (std::size_t p = 0; p < plain.size() / 3; ++p)
    plain_above += std::max({plain[3 * p], plain[3 * p + 1], plain[3 * p + 2]}) > 1.0f;
  EXPECT_NEAR(top[std::size_t(0.99 * double(top.size()))], 1.0f, 1e-5f);
  EXPECT_LE(above, top.size() / 100 + 1);  // about 1% saturated
  EXPECT_GT(plain_above, top.size() / 2);  // courtyard's irradiance at exposure 0: most pixels above 1
  const Result bad = run_prt(dir, {"project", env, "--bands", "3", "--exposure", "1"});
  EXPECT_EQ(bad.code, 2) << describe_run(bad);
  EXPECT_TRUE(contains(bad.err, "give --reconstruct FILE")) << bad.err;
}

TEST(CliProject, RotateMatchesTheLibrary) {
  TempDir dir;
  const std::string env = repo_envmap("forest.exr");
  const Result r = run_prt(dir, {"project", env, "--bands", "3", "--rotate", "90,0,0"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  const std::vector<glm::dvec3> c = reference(env, 3);
  std::vector<glm::dvec3> want(c.size());
  const prt::sh::Rotation rot(3, prt::sh::rotation_from_euler(90, 0, 0));
  rot.apply(c, want);
  expect_coeffs_near(coeffs_from_json(j), want, kJsonRelTol, "--rotate 90,0,0");
  EXPECT_EQ(j.at("rotate_yaw_pitch_roll_deg"), nlohmann::json({90.0, 0.0, 0.0}));
  // Band 0 is rotation invariant, band 1 is not (for this map).
  EXPECT_EQ(coeffs_from_json(j)[0], c[0]);

  // A general rotation through the short option.
  const Result r2 = run_prt(dir, {"project", env, "-q", "-r", "30,-45,10.5"});
  ASSERT_EQ(r2.code, 0) << describe_run(r2);
  const prt::sh::Rotation rot2(3, prt::sh::rotation_from_euler(30, -45, 10.5));
  rot2.apply(c, want);
  expect_coeffs_near(coeffs_from_json(nlohmann::json::parse(r2.out)), want, kJsonRelTol, "-r 30,-45,10.5");
}

TEST(CliProject, IrradianceOfAConstantMap) {
  TempDir dir;
  const std::string env = dir.file("white.exr");
  write_constant_map(env, 64, 32, 1.0f);
  const Result r = run_prt(dir, {"project", env, "--bands", "3", "--irradiance"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(contains(j.at("quantity").get<std::string>(), "irradiance"));
  const std::vector<glm::dvec3> c = coeffs_from_json(j);
  ASSERT_EQ(c.size(), 9u);
  const double c00 = kPi * std::sqrt(4.0 * kPi);  // white furnace: E = pi everywhere
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(c[0][ch], c00, kIrradianceTol * c00) << ch;
  for (std::size_t k = 1; k < c.size(); ++k)
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(c[k][ch], 0.0, kIrradianceTol) << k << " " << ch;
}

// Issue #13: 64 bands on a map one pixel high (its row spans the sphere's
// whole polar range) through the command: the JSON carries the library's
// coefficients at full precision (their exactness against box integrals is
// Projection.BoxRuleIsExactOnCoarseMapsAtEveryBandCount), and two
// hemispheres of 1 and 3 give c_00 = 2 sqrt(4pi).
TEST(CliProject, SixtyFourBandsOfAOnePixelHighMap) {
  TempDir dir;
  const std::string env = dir.file("halves.exr");
  prt::write_image(env, 2, 1, {1.0f, 1.0f, 1.0f, 3.0f, 3.0f, 3.0f});
  const Result r = run_prt(dir, {"project", env, "--bands", "64", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::vector<glm::dvec3> c = coeffs_from_json(nlohmann::json::parse(r.out));
  ASSERT_EQ(c.size(), 64u * 64u);
  const std::vector<glm::dvec3> want = reference(env, 64);
  for (std::size_t k = 0; k < c.size(); ++k)
    for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(c[k][ch], want[k][ch], 1e-15 + 1e-15 * std::abs(want[k][ch])) << k;
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(c[0][ch], 2.0 * std::sqrt(4.0 * kPi), 1e-12) << ch;
}

TEST(CliProject, CrossAndFaceFilesMatchTheLibrary) {
  TempDir dir;
  constexpr int N = 8;
  // A horizontal cross with some structure: a bright spot on +X, a gradient elsewhere.
  std::vector<float> cross(std::size_t(4 * N) * 3 * N * 3);
  for (std::size_t i = 0; i < cross.size(); ++i) cross[i] = 0.1f + 0.01f * float(i % 97) + (i % 3 == 0 ? 0.2f : 0.0f);
  cross[(std::size_t(N + 2) * 4 * N + 2 * N + 3) * 3] = 50.0f;
  const std::string hcross = dir.file("cross.exr");
  prt::write_image(hcross, 4 * N, 3 * N, cross);
  const Result r = run_prt(dir, {"project", hcross, "--bands", "4"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("mapping").get<std::string>(), "horizontal cross");
  EXPECT_TRUE(contains(r.err, "cube map")) << r.err;
  expect_coeffs_near(coeffs_from_json(j), reference(hcross, 4), kJsonRelTol, "hcross");

  // The same six faces as separate files, through a {face} pattern and a list.
  const prt::EnvMap cube = prt::load_envmap(hcross);
  const char* tags[6] = {"px", "nx", "py", "ny", "pz", "nz"};
  std::string list;
  for (int f = 0; f < 6; ++f) {
    const std::vector<float> face(cube.rgb.begin() + std::ptrdiff_t(f) * N * N * 3,
                                  cube.rgb.begin() + std::ptrdiff_t(f + 1) * N * N * 3);
    const std::string path = dir.file(std::string("sky_") + tags[f] + ".exr");
    prt::write_image(path, N, N, face);
    list += (f ? "," : "") + path;
  }
  for (const std::string& env : {dir.file("sky_{face}.exr"), list}) {
    const Result rf = run_prt(dir, {"project", env, "--bands", "4", "--mapping", "faces", "-q"});
    ASSERT_EQ(rf.code, 0) << describe_run(rf);
    expect_coeffs_near(coeffs_from_json(nlohmann::json::parse(rf.out)), coeffs_from_json(j), kJsonRelTol, env);
  }
}

// ---- project: bad input -----------------------------------------------------------

// One bad command line: the arguments after `prt project` ({dir} stands for the
// test's directory, {forest} for envmaps/forest.exr), the words its message
// must contain (case-insensitive), and whether the message must name the input.
struct BadCase {
  const char* name;
  std::vector<std::string> args;
  std::vector<std::string> words;
  std::string input;  // must appear in stderr; "" when there is no file to name
  int code;           // 1: a bad file or data; 2: a bad option value (README, "Exit status")
};

std::string expand(std::string s, const TempDir& dir) {
  for (auto [key, value] : {std::pair<std::string, std::string>{"{dir}", dir.work().string()},
                            std::pair<std::string, std::string>{"{forest}", repo_envmap("forest.exr")}}) {
    for (std::size_t p; (p = s.find(key)) != std::string::npos;) s.replace(p, key.size(), value);
  }
  return s;
}

// Inputs the bad cases refer to, in the test's directory.
void make_bad_inputs(const TempDir& dir) {
  write_file(dir.file("text.exr"), "this is a text file, not an image\n");
  write_file(dir.file("empty.exr"), "");
  const std::string studio = read_file(repo_envmap("studio.exr"));
  write_file(dir.file("truncated.exr"), studio.substr(0, studio.size() * 6 / 10));
  write_constant_map(dir.file("odd.exr"), 100, 37, 1.0f);
  std::vector<float> rgb(std::size_t(64) * 32 * 3, 1.0f);
  rgb[(std::size_t(7) * 64 + 12) * 3 + 1] = std::numeric_limits<float>::quiet_NaN();  // x 12, y 7
  prt::write_image(dir.file("nan.exr"), 64, 32, rgb);
  rgb[(std::size_t(7) * 64 + 12) * 3 + 1] = 1.0f;
  rgb[(std::size_t(20) * 64 + 63) * 3 + 2] = std::numeric_limits<float>::infinity();  // x 63, y 20
  prt::write_image(dir.file("inf.exr"), 64, 32, rgb);
  fs::create_directories(dir.work() / "subdir.exr");
  write_constant_map(dir.file("env.exr"), 8, 4, 1.0f);  // an input an output must not overwrite
}

// Test names and failure messages show the case's name, not its bytes.
void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class CliBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(CliBadInput, FailsWithAMessageAndNoOutput) {
  const BadCase& c = GetParam();
  TempDir dir;
  make_bad_inputs(dir);
  const auto before = dir.listing();
  const std::string out = dir.file("out.json");
  std::vector<std::string> args = {"project"};
  for (const auto& a : c.args) args.push_back(expand(a, dir));
  const bool has_output = std::find(c.args.begin(), c.args.end(), "-o") != c.args.end();
  if (!has_output) {
    args.push_back("-o");
    args.push_back(out);
  }
  const Result r = run_prt(dir, args);
  EXPECT_EQ(r.code, c.code) << describe_run(r);
  EXPECT_TRUE(r.out.empty()) << describe_run(r);
  const std::string err = lower(r.err);
  if (!c.input.empty()) {
    EXPECT_TRUE(contains(r.err, expand(c.input, dir))) << "input not named: " << r.err;
  }
  for (const auto& w : c.words) EXPECT_TRUE(contains(err, lower(expand(w, dir)))) << "'" << w << "' missing: " << r.err;
  // Numbers in messages are short ({:.6g}), whatever was given.
  EXPECT_FALSE(std::regex_search(r.err, std::regex("[0-9]{25}"))) << "a number printed whole: " << r.err;
  if (c.code == 2) {
    EXPECT_TRUE(contains(r.err, "prt project: error: ")) << r.err;
  }
  // Nothing written: the directory holds exactly the inputs it held before.
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(dir.listing(), before);
}

const BadCase kBadCases[] = {
    {"MissingFile", {"{dir}/missing.exr"}, {"no such file"}, "{dir}/missing.exr", 1},
    {"Directory", {"{dir}/subdir.exr"}, {"directory"}, "{dir}/subdir.exr", 1},
    {"TextFileNamedExr", {"{dir}/text.exr"}, {"not an openexr file"}, "{dir}/text.exr", 1},
    {"TruncatedExr", {"{dir}/truncated.exr"}, {"truncated"}, "{dir}/truncated.exr", 1},
    {"EmptyFile", {"{dir}/empty.exr"}, {"empty"}, "{dir}/empty.exr", 1},
    {"WrongShapeAuto", {"{dir}/odd.exr"}, {"100x37", "mapping"}, "{dir}/odd.exr", 1},
    {"WrongShapeLatLong", {"{dir}/odd.exr", "--mapping", "latlong"}, {"100x37", "twice as wide"}, "{dir}/odd.exr", 1},
    {"NaNPixel", {"{dir}/nan.exr"}, {"nan", "x 12, y 7"}, "{dir}/nan.exr", 1},
    {"InfPixel", {"{dir}/inf.exr"}, {"infinite", "x 63, y 20"}, "{dir}/inf.exr", 1},
    {"BandsZero", {"{forest}", "--bands", "0"}, {"--bands"}, "", 2},
    {"BandsNegative", {"{forest}", "--bands", "-3"}, {"--bands"}, "", 2},
    {"BandsHuge", {"{forest}", "--bands", "100000"}, {"--bands"}, "", 2},
    {"BandsOverTheMost", {"{forest}", "--bands", "65"}, {"--bands", "1 to 64"}, "", 2},
    {"BandsNotANumber", {"{forest}", "--bands", "abc"}, {"--bands", "abc"}, "", 2},
    {"WindowBogus", {"{forest}", "--window", "bogus"}, {"window", "bogus"}, "", 2},
    {"WindowWidthNegative", {"{forest}", "--window-width", "-1"}, {"--window-width"}, "", 2},
    {"RotateTwoNumbers", {"{forest}", "--rotate", "1,2"}, {"--rotate", "three numbers"}, "", 2},
    {"RotateNotNumbers", {"{forest}", "--rotate", "a,b,c"}, {"--rotate", "three numbers"}, "", 2},
    {"RotateFourNumbers", {"{forest}", "--rotate", "1,2,3,4"}, {"--rotate"}, "", 2},
    // Regression: std::stod accepts "nan"; the error must name --rotate.
    {"RotateNaN", {"{forest}", "--rotate", "nan,0,0"}, {"--rotate"}, "", 2},
    {"FormatXml", {"{forest}", "--format", "xml"}, {"--format", "xml"}, "", 2},
    {"MappingBogus", {"{forest}", "--mapping", "bogus"}, {"mapping", "bogus"}, "", 2},
    {"QuadratureBogus", {"{forest}", "--quadrature", "bogus"}, {"quadrature", "bogus"}, "", 2},
    {"FacesWithTwoFiles", {"{forest},{forest}", "--mapping", "faces"}, {"six files"}, "", 2},
    {"FacesPatternMissing", {"{dir}/sky_{face}.exr", "--mapping", "faces"}, {"no such file"}, "{dir}/sky_px.exr", 1},
    {"ReconstructSizeZero", {"{forest}", "--reconstruct-size", "0x0"}, {"--reconstruct-size", "0x0"}, "", 2},
    {"ReconstructSizeBogus", {"{forest}", "--reconstruct-size", "64by32"}, {"--reconstruct-size"}, "", 2},
    {"NoInput", {"--bands", "3"}, {"env"}, "", 2},
    {"OutputInMissingDirectory", {"{forest}", "-o", "{dir}/nodir/out.json"}, {"{dir}/nodir/out.json"}, "", 1},
    // The message names the requested file, not write_atomically's temporary.
    {"ReconstructInMissingDirectory",
     {"{forest}", "--reconstruct", "{dir}/nodir/rec.exr"},
     {"{dir}/nodir/rec.exr"},
     "", 1},
    {"ReconstructUnknownFormat", {"{forest}", "--reconstruct", "{dir}/rec.xyz"}, {"{dir}/rec.xyz"}, "", 2},
    // Bad options and outputs (docs/HARD_CASES.md): every bad value exits 2.
    {"FormatYaml", {"{forest}", "--format", "yaml"}, {"--format: expected json, text, glsl, hlsl or cpp, got 'yaml'"}, "", 2},
    // sscanf's %d wrapped 4294967297 to 1: a 1x2 image was written.
    {"ReconstructSizeOverflow",
     {"{forest}", "--reconstruct", "{dir}/rec.exr", "--reconstruct-size", "4294967297x2"},
     {"--reconstruct-size: expected wxh with w and h whole numbers from 1 to 65536, got '4294967297x2'"},
     "",
     2},
    {"ReconstructSizeTooWide", {"{forest}", "--reconstruct-size", "65537x2"}, {"--reconstruct-size", "65537x2"}, "", 2},
    {"ReconstructSizeNegative", {"{forest}", "--reconstruct-size", "-64x32"}, {"--reconstruct-size", "-64x32"}, "", 2},
    {"ReconstructSizeSigned", {"{forest}", "--reconstruct-size", "+64x32"}, {"--reconstruct-size", "+64x32"}, "", 2},
    // OpenImageIO has no PFM writer: refused before the work, not after it.
    {"ReconstructPfm", {"{forest}", "--reconstruct", "{dir}/rec.pfm"}, {"{dir}/rec.pfm", "unknown image type"}, "", 2},
    {"WindowWidthHuge", {"{forest}", "--window-width", "-1e308"}, {"--window-width", "got -1e+308"}, "", 2},
    {"RotateHuge", {"{forest}", "--rotate", "1e999,0,0"}, {"--rotate", "must be finite"}, "", 2},
    {"OutputIsTheInput",
     {"{dir}/env.exr", "-o", "{dir}/env.exr"},
     {"--output {dir}/env.exr: is the input env", "does not write over its inputs"},
     "",
     2},
    {"ReconstructIsTheInput",
     {"{dir}/env.exr", "--reconstruct", "{dir}/env.exr"},
     {"--reconstruct {dir}/env.exr: is the input env"},
     "",
     2},
    {"ReconstructIsTheOutput",
     {"{dir}/env.exr", "-o", "{dir}/same.exr", "--reconstruct", "{dir}/same.exr"},
     {"--reconstruct {dir}/same.exr: is also the --output file"},
     "",
     2},
};

INSTANTIATE_TEST_SUITE_P(Cases, CliBadInput, ::testing::ValuesIn(kBadCases),
                         [](const ::testing::TestParamInfo<BadCase>& p) { return std::string(p.param.name); });

// ---- inputs that are not regular files (docs/HARD_CASES.md, "Malformed input") ----

TEST(CliInputFiles, MapsAndVertexCsvMustBeRegularFiles) {
  // A FIFO blocked prt until a writer came; /dev/zero grew without end
  // (`prt compare a.csv /dev/zero` until killed). Refused from stat(), before
  // OpenEXR, the OpenImageIO plugin or the CSV reader opens anything.
  TempDir dir;
  for (const char* name : {"fifo.exr", "fifo.png", "fifo.csv"})
    ASSERT_EQ(::mkfifo(dir.file(name).c_str(), 0600), 0) << name;
  write_file(dir.file("a.csv"), "vertex,r,g,b\n0,1,1,1\n");
  std::filesystem::create_symlink("loop2.exr", dir.work() / "loop1.exr");
  std::filesystem::create_symlink("loop1.exr", dir.work() / "loop2.exr");
  const std::vector<std::string> listing = dir.listing();
  const std::string fifo = "is a FIFO (named pipe), not a regular file";
  struct Case {
    std::vector<std::string> args;
    std::string file, message;
  };
  const std::vector<Case> cases = {
      {{"project", dir.file("fifo.exr")}, dir.file("fifo.exr"), fifo},                 // OpenEXR
      {{"project", dir.file("fifo.png")}, dir.file("fifo.png"), fifo},                 // the OpenImageIO plugin
      {{"project", dir.file("fifo.exr"), "--no-stream"}, dir.file("fifo.exr"), fifo},  // the whole-image path
      {{"project", "/dev/zero"}, "/dev/zero", "is a character device, not a regular file"},
      {{"project", dir.file("loop1.exr")}, dir.file("loop1.exr"), "too many levels of symbolic links"},
      {{"compare", dir.file("a.csv"), "/dev/zero"}, "/dev/zero", "is a character device, not a regular file"},
      {{"compare", dir.file("a.csv"), dir.file("fifo.csv")}, dir.file("fifo.csv"), fifo},
      {{"info", dir.file("fifo.exr")}, dir.file("fifo.exr"), fifo},
  };
  for (const Case& c : cases) {
    const BoundedResult r = run_prt_bounded(dir, c.args, 20);
    const std::string what = c.args[0] + " " + c.file;
    EXPECT_FALSE(r.timed_out) << what << ": blocked";
    EXPECT_EQ(r.code, 1) << what << "\n" << describe_run(r);
    EXPECT_NE(r.err.find(c.file + ": " + c.message), std::string::npos) << what << "\n" << r.err;
    EXPECT_LT(r.max_rss_kb, kRefusalRssKb) << what;
    EXPECT_EQ(dir.listing(), listing) << what << ": something was written";
  }
}

TEST(CliVerify, PassesAndSummarises) {
  TempDir dir;
  const Result r = run_prt(dir, {"verify"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  auto lines = lines_of(r.out);
  while (!lines.empty() && lines.back().empty()) lines.pop_back();
  ASSERT_FALSE(lines.empty()) << describe_run(r);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(lines.back(), m, std::regex(R"(^verify: (\d+) passed, 0 failed\b)"))) << lines.back();
  const int passed = std::stoi(m[1]);
  EXPECT_GT(passed, 0);
  // One PASS row per check.
  int pass_rows = 0;
  for (const auto& l : lines) pass_rows += std::regex_search(l, std::regex(R"(\bPASS$)")) ? 1 : 0;
  EXPECT_EQ(pass_rows, passed);
}

// A failing check makes prt verify fail: every tolerance scaled down to
// 1e-300 leaves only checks whose error is exactly 0 passing.
TEST(CliVerify, AFailedCheckExitsOne) {
  TempDir dir;
  const Result r = run_prt(dir, {"verify", "--bands-max", "3", "--tolerance-scale", "1e-300"});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(\nverify: (\d+) passed, (\d+) failed\b)"))) << r.out;
  const int failed = std::stoi(m[2]);
  EXPECT_GT(failed, 0);
  int fail_rows = 0;
  for (const auto& l : lines_of(r.out)) fail_rows += std::regex_search(l, std::regex(R"(\bFAIL$)")) ? 1 : 0;
  EXPECT_EQ(fail_rows, failed);
  // The same checks at their own tolerances pass (exit 0), and a scale that is not positive is a usage error.
  EXPECT_EQ(run_prt(dir, {"verify", "--bands-max", "3"}).code, 0);
  const Result bad = run_prt(dir, {"verify", "--tolerance-scale", "0"});
  EXPECT_EQ(bad.code, 2) << describe_run(bad);
  EXPECT_TRUE(contains(bad.err, "--tolerance-scale")) << bad.err;
}

// The four exit statuses (README, "Exit status"): 0 done, 1 bad data, 2 bad
// option, 3 a bug in prt (PRT_TEST_INTERNAL_ERROR makes the command fail as
// one would).
TEST(CliExitStatus, OneForBadDataTwoForBadOptionsThreeForABug) {
  TempDir dir;
  const std::string map = repo_envmap("studio.exr");
  EXPECT_EQ(run_prt(dir, {"project", map, "--bands", "2"}).code, 0);
  write_file(dir.file("bad.exr"), "not an image");
  const Result data = run_prt(dir, {"project", dir.file("bad.exr")});
  EXPECT_EQ(data.code, 1) << describe_run(data);
  EXPECT_TRUE(contains(data.err, "prt project: error: " + dir.file("bad.exr"))) << data.err;
  const Result option = run_prt(dir, {"project", map, "--bands", "0"});
  EXPECT_EQ(option.code, 2) << describe_run(option);
  EXPECT_TRUE(contains(option.err, "--bands")) << option.err;
  EXPECT_TRUE(contains(option.err, "Run 'prt project --help' for the options.")) << option.err;
  const Result bug = run_prt(dir, {"project", map}, {{"PRT_TEST_INTERNAL_ERROR", "1"}});
  EXPECT_EQ(bug.code, 3) << describe_run(bug);
  EXPECT_TRUE(contains(bug.err, "This is a bug in prt; please report it.")) << bug.err;
  EXPECT_TRUE(contains(bug.err, "check failed")) << bug.err;
}

// ---- bad options and outputs (docs/HARD_CASES.md, "Bad options and outputs") ----

// A PNG that cannot be written whole (a full disk; here RLIMIT_FSIZE, which
// fails the write with EFBIG as a full disk fails it with ENOSPC): exit 1
// naming the file, the old file untouched, no temporary. OpenImageIO's PNG
// writer ignored the short write: exit 0, a truncated PNG under the real name.
// Every format through the plugin is now encoded in memory and written with
// each call checked; EXR (OpenEXR's own writer) reported it already.
TEST(CliOutputs, ImageOnAFullDiskFailsAndKeepsTheOldFile) {
  TempDir dir;
  const std::string studio = repo_envmap("studio.exr");
  for (const char* name : {"rec.png", "rec.jpg", "rec.tif", "rec.exr"}) {  // .hdr, .bmp, .tga: as .png
    SCOPED_TRACE(name);
    const std::string rec = dir.file(name), json = dir.file("c.json");
    write_file(rec, "old image");
    write_file(json, "old coefficients");
    const auto before = dir.listing();
    // 512x256: every format takes more than 16 KiB (JPEG 22 KB, PNG 53 KB).
    const Result r = run_prt_file_limit(dir, {"project", studio, "--bands", "4", "--reconstruct", rec,
                                              "--reconstruct-size", "512x256", "-o", json, "-q"},
                                        16 * 1024);
    EXPECT_EQ(r.code, 1) << describe_run(r);
    EXPECT_TRUE(contains(r.err, "prt project: error: " + rec + ": ")) << r.err;
    EXPECT_TRUE(contains(lower(r.err), "file too large")) << r.err;
    EXPECT_EQ(read_file(rec), "old image");
    EXPECT_EQ(read_file(json), "old coefficients");  // both or neither
    EXPECT_EQ(dir.listing(), before);
    EXPECT_TRUE(temporaries(dir).empty());
    fs::remove(rec);
    fs::remove(json);
  }
  // Without the limit the same PNG is written, and is an image.
  const Result ok = run_prt(dir, {"project", studio, "--bands", "4", "--reconstruct", dir.file("rec.png"),
                                  "--reconstruct-size", "512x256", "-q"});
  ASSERT_EQ(ok.code, 0) << describe_run(ok);
  EXPECT_EQ(prt::load_envmap(dir.file("rec.png")).width, 512);
}

// An output that is an input: refused (exit 2) naming which input, the input
// untouched; also when the output is a link to it.
TEST(CliOutputs, AnOutputThatIsAnInputIsRefused) {
  TempDir dir;
  const std::string env = dir.file("env.exr");
  write_constant_map(env, 16, 8, 0.5f);
  const std::string bytes = read_file(env);
  fs::create_symlink(env, dir.work() / "link.json");
  fs::create_hard_link(env, dir.work() / "hard.exr");
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"project", env, "-o", env}, "--output " + env + ": is the input ENV"},
      {{"project", env, "-o", dir.file("link.json")}, "--output " + dir.file("link.json") + ": is the input ENV (" + env + ")"},
      {{"project", env, "--reconstruct", dir.file("hard.exr")}, "--reconstruct " + dir.file("hard.exr") + ": is the input ENV"},
  };
  for (const Case& c : cases) {
    const Result r = run_prt(dir, c.args);
    EXPECT_EQ(r.code, 2) << describe_run(r);
    EXPECT_TRUE(contains(r.err, c.message)) << r.err;
    EXPECT_EQ(read_file(env), bytes);
  }
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"env.exr", "hard.exr", "link.json"}));
}

// Two outputs that are one file: refused (exit 2) before any input is read,
// by check_distinct_outputs (options.h) in every command with two outputs:
// the same name, the same path spelled another way, a symbolic or hard link
// to an existing file. Distinct names are not refused.
TEST(CliOutputs, TwoOutputsThatAreOneFileAreRefused) {
  TempDir dir;
  const std::string scene = std::string(PRT_SOURCE_DIR) + "/models/wall-on-floor.gltf";
  const std::string env = dir.file("env.exr");
  write_constant_map(env, 16, 8, 0.5f);
  write_file(dir.file("old.exr"), "an old map");
  fs::create_symlink(dir.file("old.exr"), dir.work() / "link.exr");
  fs::create_hard_link(dir.file("old.exr"), dir.work() / "hard.exr");
  fs::create_directories(dir.work() / "sub");
  const std::string here = dir.work().string();
  const std::string dot = here + "/./a.exr", dotdot = here + "/sub/../a.exr";
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"precompute", scene, "-o", dir.file("o.prt"), "--lightmap", "16x16", "--ao-map", dir.file("a.exr"),
        "--bent-normal-map", dir.file("a.exr")},
       "--bent-normal-map " + dir.file("a.exr") + ": is also the --ao-map file; give each output its own name"},
      {{"precompute", scene, "-o", dir.file("o.prt"), "--lightmap", "16x16", "--ao-map", dir.file("a.exr"),
        "--obscurance", "0.5", "--obscurance-map", dot},
       "--obscurance-map " + dot + ": is also the --ao-map file (" + dir.file("a.exr") + ")"},
      {{"precompute", scene, "-o", dir.file("o.prt"), "--lightmap", "16x16", "--ao-map", dir.file("old.exr"),
        "--bent-normal-map", dir.file("link.exr")},
       "--bent-normal-map " + dir.file("link.exr") + ": is also the --ao-map file (" + dir.file("old.exr") + ")"},
      {{"precompute", scene, "-o", dir.file("o.prt"), "--lightmap", "16x16", "--ao-map", dir.file("hard.exr"),
        "--bent-normal-map", dir.file("old.exr")},
       "--bent-normal-map " + dir.file("old.exr") + ": is also the --ao-map file (" + dir.file("hard.exr") + ")"},
      {{"precompute", scene, "-o", dir.file("a.exr"), "--lightmap", "16x16", "--ao-map", dotdot},
       "--ao-map " + dotdot + ": is also the --output file (" + dir.file("a.exr") + ")"},
      {{"precompute", scene, "-o", dir.file("o.ply"), "--subdivide", "0.1", "--subdivided-mesh", here + "/./o.ply"},
       "--subdivided-mesh " + here + "/./o.ply: is also the --output file"},
      {{"precompute", scene, "-o", dir.file("o.prt"), "--target-error", "0.1", "--env", env, "--cache",
        dir.file("o.prt")},
       "--cache " + dir.file("o.prt") + ": is also the --output file"},
      {{"export", scene, "--probes", dir.file("p.prt"), "-o", dir.file("m.json"), "--bake", env, "--matrices",
        dir.file("m.json")},
       "--matrices " + dir.file("m.json") + ": is also the --output file"},
      {{"export", scene, dir.file("t.prt"), "-o", dir.file("w.glb"), "--web", here + "/./w.glb"},
       "--web " + here + "/./w.glb: is also the --output file"},
      {{"project", env, "-o", dir.file("c.exr"), "--reconstruct", here + "/./c.exr"},
       "--reconstruct " + here + "/./c.exr: is also the --output file"},
      {{"view", scene, dir.file("t.prt"), env, "--frames", "1", "--screenshot", dir.file("s.png"), "--screenshot-dir",
        dir.file("s.png")},
       "--screenshot " + dir.file("s.png") + ": is also the --screenshot-dir file"},
  };
  const auto before = dir.listing();
  for (const Case& c : cases) {
    const Result r = run_prt(dir, c.args);
    EXPECT_EQ(r.code, 2) << describe_run(r);
    EXPECT_TRUE(contains(r.err, "error: " + c.message)) << c.message << "\n" << r.err;
    EXPECT_EQ(dir.listing(), before);
    EXPECT_EQ(read_file(dir.file("old.exr")), "an old map");
  }
  // Other names are not refused as the same file: the run goes on (and writes both maps).
  const Result ok = run_prt(dir, {"precompute", scene, "-o", dir.file("o.prt"), "--lightmap", "16x16", "--samples",
                                  "16", "-q", "--ao-map", dir.file("a.exr"), "--bent-normal-map", dir.file("b.exr")});
  EXPECT_EQ(ok.code, 0) << describe_run(ok);
  EXPECT_TRUE(fs::exists(dir.file("a.exr")) && fs::exists(dir.file("b.exr")));
}

// Ctrl-C while the outputs are written: exit 130, "interrupted; nothing
// written", neither output changed, no temporary. PRT_TEST_PAUSE_BEFORE_RENAME
// (prt/io.h) holds the write step open until the signal comes.
TEST(CliOutputs, CtrlCWhileWritingLeavesTheOldFiles) {
  TempDir dir;
  const std::string rec = dir.file("rec.exr"), json = dir.file("c.json");
  write_file(rec, "old image");
  write_file(json, "old coefficients");
  const auto r = run_prt_interrupted(
      dir, {"project", repo_envmap("studio.exr"), "--bands", "3", "--reconstruct", rec, "-o", json, "-q"},
      "PRT_TEST_PAUSE_BEFORE_RENAME", {"PRT_TEST_PAUSE_BEFORE_RENAME=30000"});
  EXPECT_TRUE(r.marker_seen) << describe_run(r);
  EXPECT_EQ(r.code, 130) << describe_run(r);
  EXPECT_TRUE(contains(r.err, "prt project: interrupted; nothing written")) << r.err;
  EXPECT_EQ(read_file(rec), "old image");
  EXPECT_EQ(read_file(json), "old coefficients");
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"c.json", "rec.exr"}));
}

// Usage errors look alike, whether CLI11's validators or a command's rule
// finds them: "prt CMD: error: --option: ...", where the options are, exit 2.
TEST(CliOutputs, UsageErrorsLookAlike) {
  TempDir dir;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"project", repo_envmap("forest.exr"), "--bands", "100"},
        std::vector<std::string>{"project", repo_envmap("forest.exr"), "--mapping", "faces"},
        std::vector<std::string>{"project", repo_envmap("forest.exr"), "--frobnicate"}}) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 2) << describe_run(r);
    EXPECT_EQ(r.err.rfind("prt project: error: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, "Run 'prt project --help' for the options.")) << r.err;
  }
}

}  // namespace
