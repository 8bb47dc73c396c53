// Options several commands take (tools/prt/shared_options.h): every command
// that has one takes the same values and refuses a bad one with the same
// message and exit status 2. The commands' own --help lists are read, so an
// option that a second command starts to take must join the table below
// (or the list of options without a value to check) or this test fails.
#include "test_files.h"
#include "test_meshes.h"

#include <prt/envmap.h>
#include <prt/filter.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/sh.h>
#include <prt/vertex_csv.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace prt::test;

// Each command with placeholders for its required arguments: CLI11 checks
// option values while parsing, before any file is opened, so they need not
// exist.
const std::map<std::string, std::vector<std::string>>& commands() {
  static const std::map<std::string, std::vector<std::string>> c = {
      {"project", {"project", "env.exr"}},
      {"precompute", {"precompute", "mesh.obj", "-o", "out.prt"}},
      {"compress", {"compress", "in.prt", "-o", "out.prt"}},
      {"relight", {"relight", "mesh.obj", "in.prt", "env.exr", "-o", "out.csv"}},
      {"export", {"export", "mesh.obj", "in.prt", "-o", "out.glb"}},
      {"render", {"render", "mesh.obj", "in.prt", "env.exr", "-o", "out.png"}},
      {"reference", {"reference", "mesh.obj", "env.exr", "-o", "out.csv"}},
      {"compare", {"compare", "a.csv", "b.csv"}},
      {"info", {"info", "in.prt"}},
      {"verify", {"verify"}},
      {"view", {"view", "mesh.obj", "in.prt", "env.exr"}},
      {"report", {"report", "mesh.obj", "env.exr"}},
      {"unwrap", {"unwrap", "mesh.obj", "-o", "out.glb"}},
  };
  return c;
}

// The long options a command's --help lists.
std::set<std::string> options_of(const TempDir& dir, const std::string& command) {
  const Result r = run_prt(dir, {command, "--help"});
  EXPECT_EQ(r.code, 0) << command << ": " << r.err;
  std::set<std::string> names;
  static const std::regex option(R"((?:^|[ ,])(--[a-z][a-z0-9-]*))");
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    // Option rows start with blanks and a dash: "  -b,--bands INT ...".
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos || first == 0 || line[first] != '-') continue;
    const std::string head = line.substr(0, line.find("  ", first));
    for (std::sregex_iterator it(head.begin(), head.end(), option), end; it != end; ++it) names.insert((*it)[1]);
  }
  return names;
}

// An option several commands take and the values each must refuse alike;
// `message` is the whole message after "--option: " that every command
// prints for that value.
struct Refusal {
  std::string value, message;
};
struct Shared {
  std::string option;
  std::vector<Refusal> refusals;
  std::vector<std::string> accepted;  // values every command takes (exit status not 2 for them)
};

const std::vector<Shared>& shared_table() {
  static const std::vector<Shared> t = {
      {"--exposure",
       {{"1e308", "must be a number in [-64, 64] (stops or auto), got 1e+308"},
        {"-1e308", "must be a number in [-64, 64] (stops or auto), got -1e+308"},
        {"64.5", "must be a number in [-64, 64] (stops or auto), got 64.5"},
        {"inf", "must be a number in [-64, 64] (stops or auto), got inf"},
        {"nan", "must be a number in [-64, 64] (stops or auto), got nan"},
        {"bright", "must be a number in [-64, 64] (stops or auto), got 'bright'"}},
       {"auto", "-64", "64", "0.5"}},
      {"--rotate",
       {{"1,2", "expected three numbers yaw,pitch,roll, got '1,2'"},
        {"1e999,0,0", "numbers must be finite, got '1e999,0,0'"},
        {"nan,0,0", "numbers must be finite, got 'nan,0,0'"}},
       {"90,0,0", "-720,1e3,0.5"}},
      {"--tonemap",
       {{"filmic", "unknown tone map 'filmic' (expected clamp, reinhard or aces)"}},
       {"clamp", "reinhard", "aces"}},
      {"--camera",
       {{"1,2,3", "expected 9 numbers ex,ey,ez,tx,ty,tz,ux,uy,uz, got '1,2,3'"},
        {"0,0,1,0,0,1,0,1,0", "eye equals target (0, 0, 1)"},
        {"0,0,inf,0,0,0,0,1,0", "non-finite value inf in '0,0,inf,0,0,0,0,1,0'"}},
       {"0,0,3,0,0,0,0,1,0"}},
      {"--fov",
       {{"0", "must be a number in [1, 179], got 0"}, {"180", "must be a number in [1, 179], got 180"}},
       {"1", "179"}},
      {"--width", {{"0", "must be a whole number from 1 to 16384, got '0'"}}, {"64"}},
      {"--height", {{"16385", "must be a whole number from 1 to 16384, got '16385'"}}, {"64"}},
      {"--frames", {{"0", "must be a whole number from 1 to 100000, got '0'"}}, {"2"}},
      {"--gloss",
       {{"-1", "must be a number in [0, 4096], got -1"}, {"4097", "must be a number in [0, 4096], got 4097"},
        {"nan", "must be a number in [0, 4096], got nan"}},
       {"0", "4096"}},
      {"--specular", {{"1.5", "must be a number in [0, 1], got 1.5"}}, {"0", "1"}},
      {"--diffuse",
       {{"2", "expected one number or r,g,b, each from 0 to 1 (an albedo), got '2'"},
        {"0.5,0.5,1.5", "each of r,g,b must be from 0 to 1 (an albedo), got 1.5"},
        {"0.5,0.5", "expected three numbers r,g,b, got '0.5,0.5'"}},
       {"0.5", "0,0.5,1"}},
      {"--eye", {{"1,2", "expected three numbers x,y,z, got '1,2'"}}, {"0,1,3"}},
      {"--albedo",
       {{"1.5,0,0", "each of r,g,b must be from 0 to 1 (energy conservation), got 1.5"},
        {"-1,0,0", "each of r,g,b must be from 0 to 1 (energy conservation), got -1"},
        {"0.5,nan,0.5", "numbers must be finite, got '0.5,nan,0.5'"}},
       {"0.8,0.8,0.8", "1,0,0"}},
      {"--mode",
       {{"foo", "unknown mode 'foo' (expected unshadowed, shadowed or interreflected)"}},
       {"shadowed", "interreflected"}},
      {"--material", {{"metal", "expected diffuse, glossy or subsurface, got 'metal'"}}, {"diffuse", "glossy", "subsurface"}},
      {"--sun", {{"always", "expected auto or none, got 'always'"}}, {"auto", "none"}},
      {"--sss",
       {{"jade", "expected one of apple, chicken1, chicken2, cream, ketchup, marble, potato, skimmilk, skin1, skin2, "
                 "wholemilk, got 'jade'"}},
       {"marble", "Skin1"}},
      {"--sigma-a",
       {{"-1,0,0", "each of r,g,b must be at least 0, got -1"}, {"1,2", "expected three numbers r,g,b, got '1,2'"}},
       {"0.0021,0.0041,0.0071"}},
      {"--sigma-s", {{"1,nan,1", "numbers must be finite, got '1,nan,1'"}}, {"2.19,2.62,3"}},
      {"--eta", {{"0.9", "must be a number in [1, 3], got 0.9"}, {"3.5", "must be a number in [1, 3], got 3.5"}},
       {"1", "1.3", "3"}},
      {"--length-scale", {{"0", "must be a positive number, got 0"}, {"-25", "must be a positive number, got -25"}},
       {"25", "0.01"}},
      {"--shadow-map-size", {{"8193", "must be a whole number from 16 to 8192, got '8193'"},
                             {"15", "must be a whole number from 16 to 8192, got '15'"}}, {"16", "8192"}},
      {"--bounces", {{"65", "must be a whole number from 0 to 64, got '65'"}}, {"0", "64"}},
      {"--seed",
       {{"-1", "must be a whole number from 0 to 18446744073709551615 (digits only), got '-1'"},
        {"18446744073709551616",
         "must be a whole number from 0 to 18446744073709551615 (digits only), got '18446744073709551616'"}},
       {"0", "18446744073709551615"}},
      {"--threads", {{"1025", "must be a whole number from 0 to 1024, got '1025'"}}, {"0", "2"}},
      {"--offset", {{"0", "must be a positive number, got 0"}, {"inf", "must be a positive number, got inf"}}, {"1e-3"}},
      {"--target-error",
       {{"0", "must be a number in (0, 1) (a relative RMS error), got 0"},
        {"1", "must be a number in (0, 1) (a relative RMS error), got 1"}},
       {"0.01"}},
      {"--window", {{"box", "unknown window 'box' (expected none, hanning, lanczos or auto)"}}, {"none", "auto"}},
      {"--window-width", {{"0", "must be a positive number, got 0"}}, {"4.5"}},
      {"--terms", {{"0", "must be a whole number from 1 to 1073741824, got '0'"}}, {"1", "100"}},
      // render and view: add_look_options (look.h), their shared look.
      {"--shading",
       {{"foo",
         "unknown shading 'foo' (expected transfer, direct, unshadowed, lambert, ao, bent, colors, glossy or clusters)"},
        {"colors", "colors is for callers that upload their own vertex colours"}},
       {"transfer", "ao"}},
      {"--selection", {{"random", "unknown wavelet term selection 'random' (expected area or magnitude)"}}, {"area", "magnitude"}},
      {"--lightmap",
       {{"0x16", "must be WxH with W and H from 1 to 16384 (e.g. 1024x1024), got '0x16'"},
        {"64", "must be WxH with W and H from 1 to 16384 (e.g. 1024x1024), got '64'"}},
       {"64x32"}},
      {"--uv", {{"8", "must be a whole number from 0 to 7, got '8'"}}, {"0", "1"}},
      {"--lightmap-uv", {{"own", "expected scene or auto, got 'own'"}}, {"scene", "auto"}},
      {"--uv-padding", {{"63", "must be a whole number from 0 to 62, got '63'"}}, {"0", "2"}},
      {"--pages", {{"11", "must be 1 to 10 or auto, got '11'"}, {"0", "must be 1 to 10 or auto, got '0'"}}, {"1", "auto"}},
      {"--texel-size", {{"0", "must be a positive number, got 0"}}, {"0.05"}},
      {"--object-at", {{"1,2", "expected three numbers x,y,z, got '1,2'"}}, {"0,1,0"}},
      {"--object-size", {{"0", "must be a positive number, got 0"}}, {"0.5"}},
      {"--deform",
       {{"fold:30", "fold:30: unknown deformation; expected bend:ANGLE or twist:ANGLE in degrees (e.g. bend:60)"},
        {"bend:1000", "bend:1000: the angle is beyond 720 degrees; expected bend:ANGLE or twist:ANGLE in degrees (e.g. "
                      "bend:60)"}},
       {"bend:30", "twist:-90"}},
      {"--time", {{"inf", "must be a finite number, got inf"}}, {"1.5"}},
      {"--animation", {{"-1", "must be a whole number from 0 to 1048576, got '-1'"}}, {"0"}},
  };
  return t;
}

// --bands counts different things (shared_options.h): the bands a transfer
// is computed with (precompute), a map is projected to (project), and a
// renderer shades with (render, view; 0: all of the file's). One validator
// each, pinned per command.
const std::map<std::string, std::vector<Refusal>>& bands_table() {
  static const std::string computed =
      "must be a whole number from 1 to 16 (prt render and prt view draw at most 16 bands; transfer accuracy is "
      "measured up to 16), got ";
  static const std::string shown =
      "must be a whole number from 0 to 16 (the renderer's lighting block holds 16 bands), got ";
  static const std::string projected = "must be a whole number from 1 to 64 (the most prt verify checks), got ";
  static const std::map<std::string, std::vector<Refusal>> t = {
      {"precompute", {{"0", computed + "'0'"}, {"17", computed + "'17'"}}},
      {"project", {{"0", projected + "'0'"}, {"65", projected + "'65'"}}},
      {"render", {{"-1", shown + "'-1'"}, {"17", shown + "'17'"}}},
      {"view", {{"-1", shown + "'-1'"}, {"17", shown + "'17'"}}},
  };
  return t;
}

// Options two or more commands take whose values are no number or name to
// check: flags, files and directories (--at: a points CSV; --object a mesh;
// --probes a probe file in render and view, NXxNYxNZ in precompute, checked
// there), and --samples, which counts rays per
// vertex in prt precompute (1 and up) but Monte Carlo iterations in prt
// reference (2 and up: a standard error needs two).
const std::set<std::string> kNoSharedValue = {"--help",   "--quiet",  "--output", "--env",   "--mesh",
                                              "--cache",  "--json",   "--weld",   "--vertex-colors",     "--samples",
                                              "--bands",  "--at",     "--probes", "--object", "--dynamic-ao",
                                              "--lights", "--directional"};  // --lights: FILE.json or none  // --bands: bands_table()
// (--directional: precompute's flag, relight's packing.)

// Every option and argument of every command that names a file or a
// directory: each takes options.h's path_value(), so '' is refused while
// parsing with the same message (`--ao-map ''` was taken as not given,
// `--subdivided-mesh ''` and `-o ''` failed after the work).
const std::map<std::string, std::set<std::string>>& path_options() {
  static const std::map<std::string, std::set<std::string>> t = {
      {"project", {"ENV", "--output", "--reconstruct"}},
      {"precompute",
       {"MESH", "--output", "--env", "--cache", "--ao-map", "--bent-normal-map", "--obscurance-map",
        "--subdivided-mesh"}},
      {"compress", {"IN", "--output", "--measure", "--mesh", "--env", "--spectra"}},
      {"relight", {"MESH", "TRANSFER", "ENV", "--output", "--at"}},
      {"export", {"MESH", "TRANSFER", "--probes", "--output", "--bake", "--web", "--env", "--matrices"}},
      {"render", {"MESH", "TRANSFER", "ENV", "--output", "--probes", "--object"}},
      {"reference", {"MESH", "ENV", "--output", "--at"}},
      {"compare", {"A", "B"}},
      {"info", {"FILE"}},
      {"view", {"MESH", "TRANSFER", "ENV", "--probes", "--object", "--screenshot", "--screenshot-dir", "--second"}},
      {"report", {"MESH", "ENV", "--out", "--cache"}},
      {"unwrap", {"SCENE", "--output"}},
  };
  return t;
}

// The long options of a command's --help that take a value (a type after
// the names: "--ao-map TEXT", "--adaptive [TOL]"), flags left out.
std::set<std::string> value_options_of(const TempDir& dir, const std::string& command) {
  const Result r = run_prt(dir, {command, "--help"});
  EXPECT_EQ(r.code, 0) << command << ": " << r.err;
  std::set<std::string> names;
  static const std::regex row(R"(^ +((?:-[a-zA-Z],)?--[a-z][a-z0-9-]*) +([A-Z\[][^ ]*))");
  std::istringstream lines(r.out);
  std::smatch m;
  for (std::string line; std::getline(lines, line);)
    if (std::regex_search(line, m, row)) {
      const std::string names_part = m[1], type = m[2];
      // A type is upper case (TEXT, INT:..., UINT, FLOAT, [TOL], FRACTION:...); a flag's help starts with a word.
      if (!std::regex_match(type, std::regex(R"((\[[A-Z]+\]|[A-Z][A-Z0-9]*([:=].*)?))"))) continue;
      names.insert(names_part.substr(names_part.find("--")));
    }
  return names;
}

// The message a usage error prints after "error: OPTION: ", or the whole
// error line.
std::string message_after(const std::string& err, const std::string& option) {
  const std::string marker = "error: " + option + ": ";
  const auto at = err.find(marker);
  if (at == std::string::npos) return err;
  const auto start = at + marker.size();
  return err.substr(start, err.find('\n', start) - start);
}

TEST(CliSharedOptions, EverySharedOptionIsChecked) {
  TempDir dir;
  std::map<std::string, std::vector<std::string>> users;
  for (const auto& [name, args] : commands())
    for (const std::string& o : options_of(dir, name)) users[o].push_back(name);
  ASSERT_GT(users["--exposure"].size(), 4u) << "--help lists were not read";
  std::set<std::string> checked(kNoSharedValue);
  for (const Shared& s : shared_table()) checked.insert(s.option);
  for (const auto& [option, cmds] : users) {
    if (cmds.size() < 2) continue;
    std::string list;
    for (const auto& c : cmds) list += " " + c;
    EXPECT_TRUE(checked.count(option)) << option << " is taken by" << list
                                       << ": add it to tools/prt/shared_options.h and this test's table";
  }
  // --bands: every command that takes it is pinned.
  for (const std::string& c : users["--bands"]) EXPECT_TRUE(bands_table().count(c)) << c << " takes --bands";
}

TEST(CliSharedOptions, EachRefusesABadValueAlike) {
  TempDir dir;
  std::map<std::string, std::set<std::string>> options;
  for (const auto& [name, args] : commands()) options[name] = options_of(dir, name);
  for (const Shared& s : shared_table()) {
    std::vector<std::string> takers;
    for (const auto& [name, opts] : options)
      if (opts.count(s.option)) takers.push_back(name);
    EXPECT_GE(takers.size(), 2u) << s.option << " is no longer shared: take it out of the table";
    for (const std::string& c : takers) {
      for (const Refusal& bad : s.refusals) {
        std::vector<std::string> args = commands().at(c);
        args.insert(args.end(), {s.option, bad.value});
        const Result r = run_prt(dir, args);
        EXPECT_EQ(r.code, 2) << "prt " << c << " " << s.option << " " << bad.value << ": " << r.err;
        EXPECT_EQ(message_after(r.err, s.option), bad.message) << "prt " << c << " " << s.option << " " << bad.value;
        EXPECT_NE(r.err.find("prt " + c + ": error: " + s.option + ": "), std::string::npos) << r.err;
      }
      // An accepted value passes the parser: whatever the command says
      // next (its placeholder files do not exist) is not about the option.
      for (const std::string& good : s.accepted) {
        std::vector<std::string> args = commands().at(c);
        args.insert(args.end(), {s.option, good});
        const Result r = run_prt(dir, args);
        EXPECT_EQ(r.err.find("error: " + s.option + ": "), std::string::npos)
            << "prt " << c << " " << s.option << " " << good << ": " << r.err;
      }
    }
  }
}

// '' for any option of any command that takes a value is refused while
// parsing (exit 2, the option named); for a path, with path_value()'s
// message. The --help lists are read, so a new path option without the
// validator fails here. Positional paths too.
TEST(CliPathOptions, EmptyValuesAreRefusedWhileParsing) {
  TempDir dir;
  // Optional values, where '' is "no value": --adaptive's default TOL, --subdivide's (--target-error / 2).
  const std::set<std::string> no_value = {"--adaptive", "--subdivide"};
  std::size_t paths = 0, checked = 0;
  for (const auto& [c, base] : commands()) {
    const std::set<std::string> options = value_options_of(dir, c);
    checked += options.size();
    const std::set<std::string> expected_paths = path_options().count(c) ? path_options().at(c) : std::set<std::string>{};
    for (const std::string& o : options) {
      if (no_value.count(o)) continue;
      std::vector<std::string> args = base;
      // An option the placeholder already gives (-o) takes '' in its place.
      bool replaced = false;
      for (std::size_t i = 1; i + 1 < args.size(); ++i)
        if (args[i] == o || (o == "--output" && args[i] == "-o")) args[i + 1] = "", replaced = true;
      if (!replaced) args.insert(args.end(), {o, ""});
      const Result r = run_prt(dir, args);
      EXPECT_EQ(r.code, 2) << "prt " << c << " " << o << " '': " << r.err;
      if (expected_paths.count(o)) {
        ++paths;
        EXPECT_EQ(message_after(r.err, o), "expected a path, got ''") << "prt " << c << " " << o << " ''";
      } else {
        EXPECT_NE(r.err.find("error: " + o + ": "), std::string::npos) << "prt " << c << " " << o << " '': " << r.err;
      }
    }
    for (const std::string& p : expected_paths)
      EXPECT_TRUE(p.rfind("--", 0) != 0 || options.count(p)) << "prt " << c << " lists no " << p << " in --help";
  }
  EXPECT_GT(checked, 150u) << "--help lists were not read";
  EXPECT_EQ(paths, 35u);  // the --options of path_options()
  // Positional paths: '' in place of each.
  const std::vector<std::vector<std::string>> positional = {
      {"precompute", "", "-o", "out.prt"},
      {"relight", "mesh.obj", "", "env.exr", "-o", "out.csv"},
      {"relight", "mesh.obj", "in.prt", "", "-o", "out.csv"},
      {"reference", "", "env.exr", "-o", "out.csv"},
      {"project", ""},
      {"compress", "", "-o", "out.prt"},
      {"info", ""},
      {"compare", "a.csv", ""},
      {"export", "", "in.prt", "-o", "out.glb"},
      {"render", "mesh.obj", "in.prt", "", "-o", "out.png"},
      {"view", "mesh.obj", "", "env.exr"},
      {"report", "mesh.obj", ""},
      {"unwrap", "", "-o", "out.glb"},
  };
  for (const auto& args : positional) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 2) << "prt " << args[0] << " with an empty argument: " << r.err;
    EXPECT_NE(r.err.find(": expected a path, got ''"), std::string::npos) << "prt " << args[0] << ": " << r.err;
  }
  // Names that are paths, however odd, are not refused for being paths.
  for (const char* name : {" ", "./x.exr", "a b.exr"}) {
    const Result r = run_prt(dir, {"project", "env.exr", "--reconstruct", name});
    EXPECT_EQ(r.err.find("expected a path"), std::string::npos) << "'" << name << "': " << r.err;
  }
}

TEST(CliSharedOptions, BandsArePinnedPerCommand) {
  TempDir dir;
  for (const auto& [c, refusals] : bands_table())
    for (const Refusal& bad : refusals) {
      std::vector<std::string> args = commands().at(c);
      args.insert(args.end(), {"--bands", bad.value});
      const Result r = run_prt(dir, args);
      EXPECT_EQ(r.code, 2) << "prt " << c << " --bands " << bad.value << ": " << r.err;
      EXPECT_EQ(message_after(r.err, "--bands"), bad.message) << "prt " << c << " --bands " << bad.value;
    }
}

// --exposure auto in prt relight and prt export --bake is prt render's rule
// (prt::frame_exposure) with no frame: the stops that put the 99th
// percentile (nearest rank, floor(0.99 (n - 1)) of n ascending) of the relit
// vertices' largest channel at 1, each vertex counted once. The oracle
// takes the linear colours of prt relight (CSV) and ranks them here. Each
// output equals the one the same stops give when typed.
TEST(CliSharedOptions, ExposureAutoIsRendersEverywhere) {
  TempDir dir;
  const std::string mesh = dir.file("m.off"), prt = dir.file("m.prt"), env = dir.file("sky.exr");
  write_off(mesh, floor_and_ball(4));
  // A map whose auto exposure is far from 0 (radiance 40 in one region).
  std::vector<float> rgb(std::size_t(32) * 16 * 3, 0.05f);
  for (int y = 2; y < 6; ++y)
    for (int x = 4; x < 10; ++x)
      for (int c = 0; c < 3; ++c) rgb[(std::size_t(y) * 32 + x) * 3 + c] = 40.0f;
  prt::write_image(env, 32, 16, rgb);
  ASSERT_EQ(run_prt(dir, {"precompute", mesh, "-o", prt, "--bands", "3", "--samples", "64", "-q"}).code, 0);
  ASSERT_EQ(run_prt(dir, {"relight", mesh, prt, env, "-o", dir.file("linear.csv"), "-q"}).code, 0);
  std::vector<float> top;
  for (const glm::vec3& c : prt::read_vertex_csv(dir.file("linear.csv"))) top.push_back(std::max({c.x, c.y, c.z, 0.0f}));
  ASSERT_GT(top.size(), 100u) << "too few vertices for the 99th percentile to differ from the maximum";
  std::sort(top.begin(), top.end());
  const double stops = -std::log2(double(top[std::size_t(0.99 * double(top.size() - 1))]));
  ASSERT_GT(std::abs(stops), 1.0) << "the map should need an exposure";
  ASSERT_GT(top.back(), top[std::size_t(0.99 * double(top.size() - 1))]) << "the maximum would give the same stops";
  char typed[64];
  std::snprintf(typed, sizeof typed, "%.17g", stops);

  const auto run_ok = [&](std::vector<std::string> args) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 0) << r.err;
  };
  run_ok({"relight", mesh, prt, env, "-o", dir.file("auto.csv"), "--tonemap", "clamp", "--exposure", "auto", "-q"});
  run_ok({"relight", mesh, prt, env, "-o", dir.file("typed.csv"), "--tonemap", "clamp", "--exposure", typed, "-q"});
  run_ok({"relight", mesh, prt, env, "-o", dir.file("zero.csv"), "--tonemap", "clamp", "-q"});
  EXPECT_EQ(read_file(dir.file("auto.csv")), read_file(dir.file("typed.csv")));
  EXPECT_NE(read_file(dir.file("auto.csv")), read_file(dir.file("zero.csv")));  // auto did something

  run_ok({"export", mesh, prt, "-o", dir.file("auto.glb"), "--bake", env, "--exposure", "auto", "-q"});
  run_ok({"export", mesh, prt, "-o", dir.file("typed.glb"), "--bake", env, "--exposure", typed, "-q"});
  run_ok({"export", mesh, prt, "-o", dir.file("zero.glb"), "--bake", env, "-q"});
  EXPECT_EQ(read_file(dir.file("auto.glb")), read_file(dir.file("typed.glb")));
  EXPECT_NE(read_file(dir.file("auto.glb")), read_file(dir.file("zero.glb")));
}

// The rules past the value stay each command's: prt relight's --exposure
// needs --tonemap, prt export's needs --bake or --web, prt project's needs
// --reconstruct; each refuses with exit 2 before reading anything.
TEST(CliSharedOptions, ExposureNeedsWhatItScales) {
  TempDir dir;
  const struct {
    std::vector<std::string> args;
    std::string words;
  } cases[] = {
      {{"relight", "m.obj", "t.prt", "e.exr", "-o", "x.csv", "--exposure", "auto"}, "give --tonemap"},
      {{"export", "m.obj", "t.prt", "-o", "x.glb", "--exposure", "1"}, "give --bake ENV or --web DIR too"},
      {{"project", "e.exr", "--exposure", "auto"}, "give --reconstruct FILE too"},
  };
  for (const auto& c : cases) {
    const Result r = run_prt(dir, c.args);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find(c.words), std::string::npos) << r.err;
  }
}

}  // namespace
