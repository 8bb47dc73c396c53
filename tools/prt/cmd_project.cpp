// prt project: environment map -> SH coefficients.
#include "commands.h"
#include "progress_bar.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/filter.h>
#include <prt/io.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/sh_convention.h>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace prt::cli {

namespace {

constexpr const char* kConvention =
    "real orthonormal SH, Condon-Shortley phase, polar axis z, index k = l(l+1)+m; world right-handed, +Y up; "
    "in the map's units, no 1/pi (docs/CONVENTIONS.md)";

// What an engine convention's array is (docs/CONVENTIONS.md, "Engines' conventions").
std::string convention_detail(sh::Convention c) {
  switch (c) {
    case sh::Convention::Three:
      return "three.js SphericalHarmonics3 (LightProbe.sh): radiance, no Condon-Shortley phase (prt's k = 1, 3, 5, 7 "
             "negated), index l(l+1)+m, three's world axes = prt's (right-handed, +Y up); three applies the clamped "
             "cosine itself (getIrradianceAt); load with new SphericalHarmonics3().fromArray(coefficients.flat()) "
             "(docs/CONVENTIONS.md)";
    case sh::Convention::Filament:
      return "Filament IndirectLight::Builder::irradiance(3, sh), as cmgen --sh-shader writes it: irradiance / pi "
             "(clamped cosine and Lambert's 1/pi applied), pre-multiplied by the basis constants, summed against 1, "
             "y, z, x, yx, yz, 3z^2-1, zx, x^2-y^2 (Irradiance_SphericalHarmonics); Filament's world axes = prt's "
             "(docs/CONVENTIONS.md)";
    case sh::Convention::Unity:
      return "Unity SphericalHarmonicsL2 (coefficients[i] = sh[r,i], sh[g,i], sh[b,i]): irradiance / pi "
             "pre-multiplied by Unity's normalisation constants, in Unity's left-handed axes (prt's (x, y, z) is "
             "Unity's (x, y, -z)); unity_SH: its packing unity_SHAr..unity_SHC for ShadeSH9 (docs/CONVENTIONS.md)";
    case sh::Convention::Prt: break;
  }
  return kConvention;
}

struct ProjectArgs {
  std::string env, output, format = "json", window = "none", rotate, reconstruct, reconstruct_size;
  std::string exposure = "0";  // --exposure: the reconstruction times 2^stops, or "auto"
  const CLI::Option* exposure_opt = nullptr;
  std::string mapping = "auto", quadrature = "box", convention = "prt";
  int bands = 3;
  double window_width = 0;
  bool irradiance = false, quiet = false, no_stream = false, peak_memory = false;
};

// Peak resident memory of this process so far, in MiB.
double peak_rss_mib() { return double(peak_resident_bytes()) / (1024.0 * 1024.0); }

// --mapping faces: the six files ENV names, a pattern with {face} (px nx py
// ny pz nz) or six comma-separated files; UsageError otherwise.
std::array<std::string, 6> face_paths(const ProjectArgs& a) {
  std::array<std::string, 6> paths;
  static constexpr const char* tags[6] = {"px", "nx", "py", "ny", "pz", "nz"};
  const auto brace = a.env.find("{face}");
  if (brace != std::string::npos) {
    for (int f = 0; f < 6; ++f) paths[f] = std::string(a.env).replace(brace, 6, tags[f]);
  } else {
    std::stringstream ss(a.env);
    int f = 0;
    for (std::string part; std::getline(ss, part, ',');) {
      if (f == 6) throw UsageError("--mapping faces: more than six files in " + show_text(a.env));
      paths[f++] = part;
    }
    if (f != 6)
      throw UsageError("--mapping faces: expected six files +X,-X,+Y,-Y,+Z,-Z or a pattern with {face}, got " +
                       show_text(a.env));
  }
  return paths;
}

EnvMap load(const ProjectArgs& a) {
  const Mapping m = parse_mapping(a.mapping);
  if (m != Mapping::Faces) return load_envmap(a.env, m);
  return load_cube_faces(face_paths(a));
}

// The outputs are none of the inputs, nor each other.
void check_outputs(const ProjectArgs& a) {
  const bool faces = parse_mapping(a.mapping) == Mapping::Faces;
  const std::array<std::string, 6> f = faces ? face_paths(a) : std::array<std::string, 6>{a.env};
  const bool to_file = !a.output.empty() && a.output != "-";
  for (const auto& [option, path] : {std::pair<const char*, std::string>{"--output", to_file ? a.output : ""},
                                     std::pair<const char*, std::string>{"--reconstruct", a.reconstruct}})
    if (!path.empty())
      check_not_input(option, path,
                      {{"ENV", f[0]}, {"ENV", f[1]}, {"ENV", f[2]}, {"ENV", f[3]}, {"ENV", f[4]}, {"ENV", f[5]}});
  if (a.reconstruct.empty() && a.exposure_opt->count() > 0)
    throw UsageError("--exposure scales the --reconstruct image; give --reconstruct FILE too");
  check_distinct_outputs({{"--output", to_file ? a.output : ""}, {"--reconstruct", a.reconstruct}});
}

// --exposure: a number of stops, or "auto": the stops that put the 99th
// percentile of the pixels' largest channel at 1 (about 1% of an 8-bit
// picture saturated; 0 for an image without a positive pixel).
double reconstruction_exposure(const std::string& text, const std::vector<float>& rgb) {
  if (const std::optional<double> stops = exposure_stops(text)) return *stops;
  std::vector<float> top(rgb.size() / 3);
  for (std::size_t p = 0; p < top.size(); ++p) top[p] = std::max({rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2]});
  if (top.empty()) return 0;
  const std::size_t k = std::min(top.size() - 1, std::size_t(0.99 * double(top.size())));
  std::nth_element(top.begin(), top.begin() + std::ptrdiff_t(k), top.end());
  return top[k] > 0 ? -std::log2(double(top[k])) : 0.0;
}

// --reconstruct-size WxH (size_value() has checked it while parsing).
void parse_size(const std::string& text, int& w, int& h) {
  const auto x = text.find('x');
  w = std::stoi(text.substr(0, x));
  h = std::stoi(text.substr(x + 1));
}

// JSON with one coefficient triple per line (nlohmann serialises every value:
// escaping, and doubles in shortest round-trip form, i.e. full precision).
std::string format_json(const std::vector<glm::dvec3>& c, int bands, sh::Convention conv,
                        const nlohmann::ordered_json& extra) {
  std::string s = fmt::format("{{\n  \"bands\": {},\n  \"convention\": {},\n  \"convention_detail\": {},\n"
                              "  \"coefficients\": [\n",
                              bands, nlohmann::json(sh::convention_name(conv)).dump(),
                              nlohmann::json(convention_detail(conv)).dump());
  for (std::size_t k = 0; k < c.size(); ++k)
    s += "    " + nlohmann::json({c[k].x, c[k].y, c[k].z}).dump() + (k + 1 < c.size() ? ",\n" : "\n");
  s += "  ]";
  for (auto it = extra.begin(); it != extra.end(); ++it) s += ",\n  " + nlohmann::json(it.key()).dump() + ": " + it.value().dump();
  return s + "\n}\n";
}

std::string format_text(const std::vector<glm::dvec3>& c, int bands, const std::string& header) {
  std::string s = "# " + header + "\n# " + kConvention + "\n";
  s += fmt::format("# {:>4} {:>3} {:>4} {:>25} {:>25} {:>25}\n", "k", "l", "m", "r", "g", "b");
  for (int l = 0; l < bands; ++l)
    for (int m = -l; m <= l; ++m) {
      const auto& v = c[sh::index(l, m)];
      s += fmt::format("  {:>4} {:>3} {:>4} {:>25.17g} {:>25.17g} {:>25.17g}\n", sh::index(l, m), l, m, v.x, v.y, v.z);
    }
  return s;
}

// glsl / hlsl: the constants and a function evaluating them (prt/sh_convention.h);
// cpp: the constants (prt's, or the engine's array). c: prt's coefficients.
std::string format_code(const std::vector<glm::dvec3>& c, int bands, const std::string& header,
                        const std::string& format, sh::Convention conv, bool irradiance) {
  std::string s = "// " + header + "\n// " + convention_detail(conv) + "\n";
  if (format == "glsl" || format == "hlsl") {
    s += sh::shader_code(conv, c, irradiance, format == "glsl" ? sh::ShaderLanguage::Glsl : sh::ShaderLanguage::Hlsl);
  } else if (conv == sh::Convention::Unity) {
    const sh::UnityPacked p = sh::unity_pack(sh::to_unity(c));
    s += "// unity_SHAr, SHAg, SHAb, SHBr, SHBg, SHBb, SHC\nconstexpr float kPrtUnitySH[7][4] = {\n";
    for (const auto& v : p) s += fmt::format("    {{{:#.9g}f, {:#.9g}f, {:#.9g}f, {:#.9g}f}},\n", v.x, v.y, v.z, v.w);
    s += "};\n";
  } else {
    std::vector<glm::dvec3> e = c;
    if (conv == sh::Convention::Three) {
      const sh::Sh9 t = sh::to_three(c);
      e.assign(t.begin(), t.end());
    } else if (conv == sh::Convention::Filament) {
      const sh::Sh9 f = sh::to_filament(c);
      e.assign(f.begin(), f.end());
    }
    const int n = int(e.size());
    if (conv != sh::Convention::Prt) bands = 3;
    s += fmt::format("constexpr int kPrtShBands = {};\nconstexpr float kPrtShCoeffs[{}][3] = {{\n", bands, n);
    // '#' keeps the decimal point (2 -> 2.00000000f): always a valid float literal.
    for (int k = 0; k < n; ++k) s += fmt::format("    {{{:#.9g}f, {:#.9g}f, {:#.9g}f}},\n", e[k].x, e[k].y, e[k].z);
    s += "};\n";
  }
  return s;
}

int run_project(const ProjectArgs& a) {
  // Validate every option and output path before reading the map (names,
  // numbers and sizes were checked while parsing).
  const Quadrature quad = for_option("--quadrature", [&] { return parse_quadrature(a.quadrature); });
  const sh::Window window = for_option("--window", [&] { return sh::parse_window(a.window); });
  const sh::Convention conv = for_option("--convention", [&] { return sh::parse_convention(a.convention); });
  if (conv != sh::Convention::Prt) {
    const std::string_view name = sh::convention_name(conv);
    if (a.bands > sh::convention_max_bands(conv))
      throw UsageError(fmt::format("--convention {}: the engine's array holds 3 bands (9 coefficients); got --bands "
                                   "{}; give --bands 3 or fewer (missing bands are written as zeros)",
                                   name, a.bands));
    if (a.irradiance)
      throw UsageError(fmt::format("--convention {} takes radiance: {}; leave out --irradiance", name,
                                   conv == sh::Convention::Three
                                       ? "three.js applies the clamped cosine itself (getIrradianceAt)"
                                       : "its array is irradiance / pi already"));
    if (a.format == "text")
      throw UsageError(fmt::format("--convention {}: --format text is prt's (k, l, m) table; use json, glsl, hlsl "
                                   "or cpp",
                                   name));
  }
  if (!a.reconstruct.empty())
    if (const std::string problem = image_output_type_problem(a.reconstruct); !problem.empty())
      throw UsageError("--reconstruct: " + problem);
  check_outputs(a);
  if (!a.output.empty() && a.output != "-") for_path("--output", [&] { check_writable(a.output); });
  if (!a.reconstruct.empty()) for_path("--reconstruct", [&] { check_image_output(a.reconstruct); });
  const std::array<double, 3> euler = rotate_degrees(a.rotate);
  int rw = 0, rh = 0;
  if (!a.reconstruct_size.empty()) parse_size(a.reconstruct_size, rw, rh);

  // A single file is streamed (project_file): a lat-long map is read and
  // projected a block of rows at a time, with the same coefficients as the
  // whole map in memory, so it is the default at every size.
  FileProjection fp;
  if (a.no_stream || parse_mapping(a.mapping) == Mapping::Faces) {
    fp.map = load(a);
    fp.coeffs = project(fp.map, a.bands, quad);
  } else {
    fp = project_file(a.env, a.bands, quad, parse_mapping(a.mapping));
  }
  const EnvMap& map = fp.map;
  std::vector<glm::dvec3>& c = fp.coeffs;
  if (!a.quiet) fmt::print(stderr, "{}\n", describe(map));
  const std::string reading = fp.streamed ? fmt::format("streamed in {}-row blocks", fp.block_rows)
                                          : "read whole" + (fp.note.empty() ? std::string() : " (" + fp.note + ")");

  nlohmann::ordered_json extra;
  extra["source"] = map.source;
  extra["mapping"] = map.source_layout;
  extra["quantity"] = a.irradiance ? "irradiance (clamped-cosine convolution, no 1/pi)" : "radiance";
  extra["quadrature"] = std::string(quadrature_name(quad));
  // Last in the JSON, measured once everything else is done.
  const auto report_memory = [&](nlohmann::ordered_json& j) {
    if (!a.peak_memory) return;
    const double mib = peak_rss_mib();
    j["memory"] = {{"peak_rss_mib", std::round(mib * 10) / 10}, {"read", reading}};
    fmt::print(stderr, "peak memory {:.1f} MiB (getrusage ru_maxrss); map {}\n", mib, reading);
  };

  if (a.irradiance) sh::scale_bands(std::span<glm::dvec3>(c), sh::clamped_cosine_factors(a.bands));
  const double width = a.window_width > 0 ? a.window_width : a.bands;
  const sh::AutoWindow w = sh::apply_window(std::span<glm::dvec3>(c), window, width);
  nlohmann::ordered_json wj;
  wj["kind"] = std::string(sh::window_name(window));
  if (window == sh::Window::Auto) {
    wj["hanning_width"] = w.width;
    wj["min_before"] = w.min_before;
    wj["min_after"] = w.min_after;
    if (!a.quiet) {
      if (!w.windowed)
        fmt::print(stderr, "window auto: reconstruction already non-negative (min {:.6g}); no window applied\n",
                   w.min_before);
      else
        fmt::print(stderr, "window auto: Hanning width {:.6g} lifts the minimum from {:.6g} to {:.6g}\n", w.width,
                   w.min_before, w.min_after);
    }
    if (!w.achieved)
      fmt::print(stderr, "warning: the map's mean is negative in some channel; no window makes it non-negative\n");
  } else if (window != sh::Window::None) {
    wj["width"] = width;
  }
  extra["window"] = wj;

  if (!a.rotate.empty()) {
    const sh::Rotation rot(a.bands, sh::rotation_from_euler(euler[0], euler[1], euler[2]));
    std::vector<glm::dvec3> r(c.size());
    rot.apply(c, r);
    c.swap(r);
    extra["rotate_yaw_pitch_roll_deg"] = {euler[0], euler[1], euler[2]};
  }

  const std::string header = fmt::format("prt project {} --bands {}: {}{}", map.source, a.bands,
                                         a.irradiance ? "irradiance" : "radiance",
                                         a.rotate.empty() ? "" : ", rotated " + a.rotate);
  // Both files or neither (Outputs): a failure or Ctrl-C while writing one
  // leaves the old ones.
  Outputs out("project");
  if (!a.reconstruct.empty()) {
    if (rw == 0) {
      rw = map.is_cube() ? 4 * map.width : map.width;
      rh = rw / 2;
    }
    std::vector<float> img = reconstruct_latlong(c, rw, rh);
    const double stops = reconstruction_exposure(a.exposure, img);
    const float scale = float(std::exp2(stops));
    for (float& v : img) v *= scale;
    if (a.exposure == "auto" && !a.quiet) fmt::print(stderr, "--exposure auto: {:.2f} stops\n", stops);
    out.write([&] { write_image(a.reconstruct, rw, rh, img); });
  }
  report_memory(extra);
  std::string text;
  if (a.format == "json") {
    if (conv == sh::Convention::Prt) {
      text = format_json(c, a.bands, conv, extra);
    } else {
      const sh::Sh9 e = conv == sh::Convention::Three    ? sh::to_three(c)
                        : conv == sh::Convention::Filament ? sh::to_filament(c)
                                                           : sh::to_unity(c);
      extra["quantity"] = conv == sh::Convention::Three ? "radiance" : "irradiance / pi (pre-multiplied)";
      if (conv == sh::Convention::Unity) {
        nlohmann::ordered_json u;
        static constexpr const char* names[7] = {"unity_SHAr", "unity_SHAg", "unity_SHAb", "unity_SHBr",
                                                 "unity_SHBg", "unity_SHBb", "unity_SHC"};
        const sh::UnityPacked p = sh::unity_pack(e);
        for (int i = 0; i < 7; ++i) u[names[i]] = {p[i].x, p[i].y, p[i].z, p[i].w};
        extra["unity_SH"] = u;
      }
      if (a.bands < 3) extra["bands_projected"] = a.bands;
      text = format_json(std::vector<glm::dvec3>(e.begin(), e.end()), 3, conv, extra);
    }
  } else if (a.format == "text") {
    text = format_text(c, a.bands, header);
  } else {
    text = format_code(c, a.bands, header, a.format, conv, a.irradiance);
  }
  if (!a.output.empty() && a.output != "-") out.write([&] { write_text_file(a.output, text); });
  if (const int rc = out.commit(); rc != 0) return rc;
  if (a.output.empty() || a.output == "-") fmt::print("{}", text);
  if (!a.reconstruct.empty() && !a.quiet)
    fmt::print(stderr, "wrote {} ({}x{} lat-long, {} bands)\n", a.reconstruct, rw, rh, a.bands);
  return 0;
}

}  // namespace

Run add_project(CLI::App& app) {
  auto a = std::make_shared<ProjectArgs>();
  CLI::App* s = app.add_subcommand("project", "Project an environment map onto spherical harmonics");
  s->footer(
      "Maps: any format OpenImageIO reads (EXR, HDR, PNG, ...). Lat-long (2:1), horizontal (4:3) or vertical (3:4)\n"
      "cross, or six faces (--mapping faces, ENV = 'sky_{face}.exr' with px nx py ny pz nz, or six comma-separated\n"
      "files +X,-X,+Y,-Y,+Z,-Z). A one-line summary of the map goes to stderr. A lat-long file is read and\n"
      "projected ~32 MiB of rows at a time, so a 16384x8192 map needs ~0.1 GiB, not 1.5 (docs/HARD_CASES.md).\n"
      "Engines: --convention three|filament|unity writes three.js's, Filament's or Unity's array (3 bands; JSON,\n"
      "glsl/hlsl with the engine's own evaluation, cpp; docs/CONVENTIONS.md, \"Engines' conventions\").\n"
      "Example: prt project envmaps/forest.exr --bands 3 --irradiance --format glsl");
  s->add_option("ENV", a->env, "Environment map file (or six faces, see below)")->check(path_value())->required();
  add_shared(s, SharedOption::BandsProjected, a->bands,
             "Number of bands n; every n computed to 1e-12 in double (the box rule's pixel integrals, the cube's "
             "texel sum, --rotate; prt verify --bands-max 64)");
  s->add_option("-o,--output", a->output, "Write the coefficients to this file (default: stdout)")->check(path_value());
  s->add_option("-f,--format", a->format,
                "Output format: json, text (table), glsl, hlsl (the constants and a function evaluating them) or cpp "
                "(paste-ready constants)")
      ->check(one_of({"json", "text", "glsl", "hlsl", "cpp"}))
      ->capture_default_str();
  s->add_option("--convention", a->convention,
                "SH convention of the output: prt, three (three.js SphericalHarmonics3), filament (IndirectLight "
                "irradiance SH), unity (SphericalHarmonicsL2 and unity_SHAr..SHC); engines take 3 bands "
                "(docs/CONVENTIONS.md, \"Engines' conventions\")")
      ->check(one_of({"prt", "three", "filament", "unity"}))
      ->capture_default_str();
  add_shared(s, SharedOption::Window, a->window, "Windowing against ringing");
  add_shared(s, SharedOption::WindowWidth, a->window_width, "Window width w in bands (band l is scaled by f(l/w))");
  s->add_flag("--irradiance", a->irradiance, "Convolve with the clamped cosine: irradiance E_lm = A_l L_lm (no 1/pi)");
  add_shared(s, SharedOption::Rotate, a->rotate, "Rotate the lighting");
  s->add_option("-m,--mapping", a->mapping, "Map layout: auto, latlong, hcross, vcross, faces")
      ->check(parsed_by(parse_mapping))
      ->capture_default_str();
  s->add_option("--quadrature", a->quadrature,
                "box: texels are area averages, integrated exactly; point: texels are point samples (lat-long only)")
      ->check(parsed_by(parse_quadrature))
      ->capture_default_str();
  s->add_option("--reconstruct", a->reconstruct, "Also write the n-band reconstruction as a lat-long image")
      ->check(path_value());
  s->add_option("--reconstruct-size", a->reconstruct_size,
                "WxH of the reconstruction, each from 1 to 65536 (default: the map's size)")
      ->check(size_value(65536));
  a->exposure_opt = add_shared(s, SharedOption::Exposure, a->exposure,
                               "Scale the reconstruction by 2^stops before writing it (as prt render); auto: the "
                               "99th percentile of its pixels at 1 (8-bit pictures about 1% saturated)");
  s->add_flag("-q,--quiet", a->quiet, "No summary on stderr");
  s->add_flag("--no-stream", a->no_stream,
              "Read the whole map before projecting (same coefficients; lat-long maps are otherwise streamed)");
  s->add_flag("--peak-memory", a->peak_memory,
              "Report the peak resident memory on stderr and as \"memory\" in the JSON");
  return [a] { return run_project(*a); };
}

}  // namespace prt::cli
