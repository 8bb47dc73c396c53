// prt report: speed against error on the user's model and map. The grid is
// prt::run_report (prt/report.h); this command writes its tables (report.md,
// report.csv, report.json), renders pictures through prt::Renderer and runs
// the embedded plotting script (scripts/report_plots.py) for the PNG plots;
// it also times the compression sweep's GPU frames (prt::FrameTimer).
#include "commands.h"
#include "look.h"
#include "progress_bar.h"

#include <prt/envmap.h>
#include <prt/io.h>
#include <prt/mesh.h>
#include <prt/render.h>
#include <prt/report.h>
#include <prt/rotation.h>

#include <fmt/core.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <unistd.h>

namespace prt::cli {

extern const char* const report_plots_py;  // generated from scripts/report_plots.py

namespace {

namespace fs = std::filesystem;

struct ReportArgs {
  std::string mesh, env, out = "prt-report", albedo = "0.8,0.8,0.8", cache, sweeps = "bands,samples,bounces,terms,glossy,compression";
  MeshOptions mesh_opt;
  int threads = 0, image_size = 360;
  bool quick = false, no_cache = false, no_plots = false, quiet = false;
};

// The frame size of the compression sweep's GPU timing, and its frames:
// kWarmFrames untimed (compile, allocate), then the median of kTimedFrames.
constexpr int kFrameSize = 512, kWarmFrames = 2, kTimedFrames = 7;

// The report's one OpenGL context (pictures and frame times), made on first
// use; `why` says why there is none.
struct Gl {
  std::unique_ptr<Renderer> renderer;
  std::string why;
  bool tried = false, environment = false;  // environment: the map uploaded for the frame timing
  Renderer* get() {
    if (!tried) {
      tried = true;
      try {
        renderer = std::make_unique<Renderer>();
      } catch (const Error& e) {
        why = e.what();
      }
    }
    return renderer.get();
  }
};

// prt::FrameTimer through prt::Renderer: the lighting turned about +Y by a
// new angle each frame (as BM_CompressedFrame), the map as background, the
// default camera, kFrameSize^2, draw_only (waits for the GPU). NaN, with
// `why` set, when there is no context or the renderer refuses the transfer.
double time_frames(Gl& gl, const Mesh& mesh, const EnvMap& map, const Transfer& t, const CompressedTransfer* c,
                   std::span<const glm::dvec3> light, double gloss, double specular, std::string& why) {
  Renderer* r = gl.get();
  if (!r) {
    why = gl.why;
    return NAN;
  }
  try {
    if (c) r->set_mesh(mesh, *c);
    else r->set_mesh(mesh, t);
    if (!gl.environment) r->set_environment(map);
    gl.environment = true;
    r->set_shading(t.glossy ? Shading::Glossy : Shading::Transfer);
    if (t.glossy) r->set_glossy(gloss, specular);
    const std::vector<glm::dvec3> l(light.begin(), light.end());
    std::vector<glm::dvec3> rotated(l.size());
    sh::Rotation rot(t.bands, glm::dmat3(1.0));
    const Camera camera = default_camera(mesh);
    double angle = 0;
    std::vector<double> ms;
    for (int i = 0; i < kWarmFrames + kTimedFrames; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      angle += 0.01;
      const glm::dmat3 R = sh::rotation_axis_angle({0, 1, 0}, angle);
      rot.set(R);
      rot.apply(l, rotated);
      r->set_lighting(rotated);
      r->set_environment_rotation(R);
      r->draw_only(camera, kFrameSize, kFrameSize);
      if (i >= kWarmFrames) ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    std::nth_element(ms.begin(), ms.begin() + std::ptrdiff_t(ms.size() / 2), ms.end());
    return ms[ms.size() / 2];
  } catch (const Error& e) {
    why = e.what();
    return NAN;
  }
}

// Least-squares line through (log x, log y): y ~ e^intercept x^slope.
struct Fit {
  double slope = NAN, intercept = NAN, x0 = 0, x1 = 0;
  int points = 0;
};
Fit fit_loglog(const std::vector<std::pair<double, double>>& pts) {
  Fit f;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (auto [x, y] : pts) {
    if (!(x > 0 && y > 0)) continue;
    const double lx = std::log(x), ly = std::log(y);
    sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
    f.x0 = f.points ? std::min(f.x0, x) : x;
    f.x1 = std::max(f.x1, x);
    ++f.points;
  }
  const double d = f.points * sxx - sx * sx;
  if (f.points >= 2 && d > 0) {
    f.slope = (f.points * sxy - sx * sy) / d;
    f.intercept = (sy - f.slope * sx) / f.points;
  }
  return f;
}

std::string bytes_text(double b) {
  if (b >= 1 << 20) return fmt::format("{:.1f} MB", b / (1 << 20));
  if (b >= 1 << 10) return fmt::format("{:.1f} kB", b / (1 << 10));
  return fmt::format("{:.0f} B", b);
}

std::string csv_text(const std::vector<ReportRow>& rows, const std::vector<bool>& front, std::size_t vertices) {
  std::string s =
      "sweep,basis,reference,bands,samples,bounces,terms,cube_res,precompute_s,relight_ms,bytes,bytes_per_vertex,"
      "rel_rms,rel_rms_raw,noise_floor,p99_rel,self_rms,pareto,gloss,intrinsic_rel_rms,clusters,vectors,"
      "uncompressed_bytes_per_vertex,frame_ms,uncompressed_frame_ms\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const ReportRow& r = rows[i];
    const auto num = [](double x) { return std::isnan(x) ? std::string("nan") : fmt::format("{:.6g}", x); };
    const bool packed = r.sweep == "compression";
    s += fmt::format("{},{},{},{},{},{},{},{},{:.6g},{:.6g},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{},{},{},{},{},{},{},{},{}\n",
                     r.sweep,
                     r.basis, report_reference(r), r.bands, r.samples, r.bounces, r.terms, r.cube_res, r.precompute_s,
                     r.relight_ms, r.bytes, double(r.bytes) / double(vertices), r.error.rel_rms,
                     r.error.rel_rms_raw, r.error.noise_floor, r.error.p99_rel,
                     std::isnan(r.self_rms) ? std::string("nan") : fmt::format("{:.6g}", r.self_rms),
                     front[i] ? 1 : 0, std::isnan(r.gloss) ? std::string("nan") : fmt::format("{:g}", r.gloss),
                     r.sweep == "glossy" ? fmt::format("{:.6g}", r.intrinsic.rel_rms) : std::string("nan"), r.clusters,
                     r.vectors, packed ? num(double(r.uncompressed_bytes) / double(vertices)) : std::string("nan"),
                     num(r.frame_ms), num(r.uncompressed_frame_ms));
  }
  return s;
}

// The error as the tables show it: flagged when the reference's own noise
// is comparable (the corrected value is then only an estimate).
std::string error_text(const Accuracy& e) {
  const bool unresolved = e.rel_rms < 2 * e.noise_floor;
  return fmt::format("{:.3g}{}", e.rel_rms, unresolved ? " *" : "");
}

// The glossy sweep: one row per (bands, e), the error next to the intrinsic
// SH error and their ratio (issue 15's target: at most 1.2).
std::string glossy_table(const std::vector<ReportRow>& rows, std::size_t vertices) {
  std::string s =
      "| e | bands | precompute (s) | relight (ms/frame) | per vertex | rel. RMS | intrinsic | ratio | p99 |\n"
      "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const ReportRow& r : rows) {
    if (r.sweep != "glossy") continue;
    s += fmt::format("| {:g} | {} | {:.2f} | {:.2f} | {} | {} | {} | {:.2f} | {:.3g} |\n", r.gloss, r.bands,
                     r.precompute_s, r.relight_ms, bytes_text(double(r.bytes) / double(vertices)), error_text(r.error),
                     error_text(r.intrinsic), r.intrinsic.rel_rms > 0 ? r.error.rel_rms / r.intrinsic.rel_rms : NAN,
                     r.error.p99_rel);
  }
  return s;
}

// The compression sweep of one transfer (`basis`): per K x N the bytes per
// vertex (and their share of the uncompressed rows'), the fit, the relit
// error against the uncompressed transfer, CPU relight and GPU frame time.
std::string compression_table(const std::vector<ReportRow>& rows, const std::vector<bool>& front,
                              const std::string& basis, std::size_t vertices) {
  std::string s =
      "| K | N | per vertex | of uncompressed | fit (s) | relit error | relight (ms/frame) | frame (ms) | of "
      "uncompressed | Pareto |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const ReportRow& r = rows[i];
    if (r.sweep != "compression" || r.basis != basis) continue;
    const std::string frame = std::isnan(r.frame_ms) ? "-" : fmt::format("{:.3g}", r.frame_ms);
    const std::string ratio = std::isnan(r.frame_ms) || std::isnan(r.uncompressed_frame_ms)
                                  ? "-"
                                  : fmt::format("{:.2f}", r.frame_ms / r.uncompressed_frame_ms);
    s += fmt::format("| {} | {} | {} | {:.3f} | {:.2f} | {:.3g} | {:.2f} | {} | {} | {} |\n", r.clusters, r.vectors,
                     bytes_text(double(r.bytes) / double(vertices)),
                     r.uncompressed_bytes ? double(r.bytes) / double(r.uncompressed_bytes) : NAN, r.precompute_s,
                     r.error.rel_rms, r.relight_ms, frame, ratio, front[i] ? "yes" : "");
  }
  return s;
}

std::string table(const std::vector<ReportRow>& rows, const std::vector<bool>& front, const std::string& sweep,
                  std::size_t vertices) {
  const bool wavelet = sweep == "terms";
  std::string s = fmt::format("| {} | precompute (s) | relight (ms/frame) | storage | per vertex | rel. RMS | p99 |{}"
                              " Pareto |\n|---|---:|---:|---:|---:|---:|---:|{}---|\n",
                              wavelet ? "K" : sweep, sweep == "samples" ? " sampling alone |" : "",
                              sweep == "samples" ? "---:|" : "");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const ReportRow& r = rows[i];
    if (r.sweep != sweep) continue;
    const int key = sweep == "bands" ? r.bands : sweep == "samples" ? r.samples : sweep == "bounces" ? r.bounces : r.terms;
    s += fmt::format("| {} | {:.2f} | {:.2f} | {} | {} | {} | {:.3g} |{} {} |\n", key, r.precompute_s, r.relight_ms,
                     bytes_text(double(r.bytes)), bytes_text(double(r.bytes) / double(vertices)),
                     error_text(r.error), r.error.p99_rel,
                     sweep == "samples" ? (std::isnan(r.self_rms) ? " - |" : fmt::format(" {:.3g} |", r.self_rms))
                                        : "",
                     front[i] ? "yes" : "");
  }
  return s;
}

// Per-vertex error |a - ref| / mean |ref| as an image: R = error, G = 1 on
// the mesh (0 on the background), written as PFM for the plotting script.
void write_error_pfm(const std::string& path, const Image& img) {
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << "PF\n" << img.width << " " << img.height << "\n-1.0\n";
    for (int y = img.height - 1; y >= 0; --y)  // PFM rows run bottom to top
      f.write(reinterpret_cast<const char*>(img.rgb.data() + std::size_t(y) * img.width * 3),
              std::streamsize(sizeof(float) * 3 * img.width));
    f.close();  // close() too: a full disk may show only there
    if (!f) throw Error(path + ": write failed: " + std::strerror(errno));
  });
}

// Renders the reference and each picture, and the error heat maps. Returns
// the JSON entries; throws prt::Error when there is no GL 4.5 context.
nlohmann::json render_pictures(Gl& gl, const Mesh& mesh, const Report& report, const glm::vec3& albedo,
                               const std::string& out, int size) {
  if (!gl.get()) throw Error(gl.why);
  fs::create_directories(fs::path(out) / "images");
  Renderer& renderer = *gl.get();
  renderer.set_mesh(mesh, albedo, false);
  renderer.clear_environment();  // black behind the pictures (the frame timing draws the map)
  gl.environment = false;
  const Camera camera = default_camera(mesh);
  // Exposure: the reference's 95th-percentile vertex luminance maps to 0.8 before the tone map.
  std::vector<float> lum;
  for (const glm::vec3& c : report.image_reference) lum.push_back(glm::dot(c, glm::vec3(0.2126f, 0.7152f, 0.0722f)));
  std::nth_element(lum.begin(), lum.begin() + lum.size() * 95 / 100, lum.end());
  const double p95 = lum.empty() ? 1.0 : std::max(1e-12, double(lum[lum.size() * 95 / 100]));
  const Display display{std::log2(0.8 / p95), ToneMap::Reinhard};
  const auto draw = [&](const std::vector<glm::vec3>& colors, const std::string& file, const Display& d) {
    renderer.set_vertex_colors(colors);
    renderer.set_shading(Shading::VertexColors);
    write_frame((fs::path(out) / file).string(), renderer.render(camera, size, size), d);
  };
  draw(report.image_reference, "images/reference.png", display);
  double mean_ref = 0;
  for (const glm::vec3& c : report.image_reference) mean_ref += glm::length(glm::dvec3(c));
  mean_ref /= double(std::max<std::size_t>(1, report.image_reference.size()));
  // Each picture's error over every vertex, noise-corrected as the tables are.
  const ErrorSet all = whole_error_set(report.image_reference, report.image_std_error);
  nlohmann::json pics = nlohmann::json::array();
  for (std::size_t i = 0; i < report.pictures.size(); ++i) {
    const ReportPicture& p = report.pictures[i];
    const std::string stem = fmt::format("images/setting{}", i);
    draw(p.radiance, stem + ".png", display);
    std::vector<glm::vec3> err(p.radiance.size());
    for (std::size_t v = 0; v < err.size(); ++v) {
      const glm::dvec3 d = glm::dvec3(p.radiance[v]) - glm::dvec3(report.image_reference[v]);
      err[v] = glm::vec3(float(glm::length(d) / std::max(mean_ref, 1e-30)), 1.0f, 0.0f);
    }
    renderer.set_vertex_colors(err);
    write_error_pfm((fs::path(out) / (stem + "_error.pfm")).string(), renderer.render(camera, size, size));
    pics.push_back({{"label", p.label},
                    {"image", stem + ".png"},
                    {"error", stem + "_error.pfm"},
                    {"rel_rms", measure_accuracy(all, p.radiance).rel_rms}});
  }
  return pics;
}

// The interpreter for the plotting script: $PRT_PYTHON, else Debian's
// /usr/bin/python3 (where python3-matplotlib installs), else python3 on PATH.
std::string python() {
  if (const char* p = std::getenv("PRT_PYTHON"); p && *p) return p;
  if (access("/usr/bin/python3", X_OK) == 0) return "/usr/bin/python3";
  return "python3";
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Writes plots.py into `out` and runs it; returns an empty string or why it failed.
std::string run_plots(const std::string& out) {
  const std::string script = (fs::path(out) / "plots.py").string();
  write_text_file(script, report_plots_py);
  const std::string log = (fs::path(out) / "plots.log").string();
  const std::string cmd = shell_quote(python()) + " " + shell_quote(script) + " " + shell_quote(out) + " > " +
                          shell_quote(log) + " 2>&1";
  const int rc = std::system(cmd.c_str());
  if (rc == 0) {
    fs::remove(log);
    return {};
  }
  std::ifstream f(log);
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto last = text.find_last_of('\n', text.size() > 1 ? text.size() - 2 : 0);
  return fmt::format("{} failed (see {}): {}", cmd.substr(0, cmd.find(" > ")), log,
                     last == std::string::npos ? text : text.substr(last + 1));
}

// The grid's options from the command line: --albedo, --quick, --sweeps
// (the sweeps not named are emptied), --threads; --out's files kept off the
// inputs.
ReportOptions report_command_options(const ReportArgs& a) {
  double rgb[3];
  parse_triple(a.albedo, "--albedo", rgb);  // in [0, 1]: checked while parsing
  for (const char* name : {"report.md", "report.csv", "report.json", "plots.py", "plots.log"})
    check_not_input("--out", (fs::path(a.out) / name).string(), {{"MESH", a.mesh}, {"ENV", a.env}});
  ReportOptions opt = report_options(a.quick);
  // --sweeps: the others are emptied.
  std::vector<std::string> chosen;
  for (std::size_t at = 0; at <= a.sweeps.size();) {
    const std::size_t comma = std::min(a.sweeps.find(',', at), a.sweeps.size());
    chosen.push_back(a.sweeps.substr(at, comma - at));
    at = comma + 1;
  }
  const auto keep = [&](const char* name) { return std::find(chosen.begin(), chosen.end(), name) != chosen.end(); };
  for (const std::string& c : chosen)
    if (c != "bands" && c != "samples" && c != "bounces" && c != "terms" && c != "glossy" && c != "compression")
      throw UsageError("--sweeps: unknown sweep '" + c + "' (bands, samples, bounces, terms, glossy, compression)");
  if (!keep("bands")) opt.bands.clear();
  if (!keep("samples")) opt.samples.clear();
  if (!keep("bounces")) opt.bounces.clear();
  if (!keep("terms")) opt.terms.clear();
  if (!keep("glossy")) opt.glossy_bands.clear();
  if (!keep("compression")) {
    opt.compression_clusters.clear();
    opt.compression_vectors.clear();
  }
  opt.albedo = glm::vec3(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  opt.threads = a.threads;
  return opt;
}

// Fits of error against samples: all points against the reference; the
// sampling error alone on points with at most 1/4 of the largest count
// (where the comparison's own sampling error is at most about half).
struct SampleFits {
  Fit fit, fit_alone;
  int max_samples = 0;
};

SampleFits sample_fits(const Report& rep) {
  std::vector<std::pair<double, double>> total, alone;
  int max_samples = 0;
  for (const ReportRow& r : rep.rows)
    if (r.sweep == "samples") max_samples = std::max(max_samples, r.samples);
  for (const ReportRow& r : rep.rows)
    if (r.sweep == "samples") {
      total.emplace_back(r.samples, r.error.rel_rms);
      if (!std::isnan(r.self_rms) && 4 * r.samples <= max_samples) alone.emplace_back(r.samples, r.self_rms);
    }
  return {fit_loglog(total), fit_loglog(alone), max_samples};
}

// What the report's writers share once the grid has run.
struct ReportRun {
  const ReportArgs& a;
  const ReportOptions& opt;
  const Report& rep;
  std::vector<bool> front;  // pareto_front(rep.rows)
  std::size_t V = 0;        // the mesh's vertices
  SampleFits fits;
  std::string gl_device;          // the OpenGL device, "" without a context
  const std::string& frames_why;  // why there are no frame times, "" when there are

  bool has(const char* sweep) const {
    return std::any_of(rep.rows.begin(), rep.rows.end(), [&](const ReportRow& r) { return r.sweep == sweep; });
  }
  bool has_basis(const char* basis) const {
    return std::any_of(rep.rows.begin(), rep.rows.end(),
                       [&](const ReportRow& r) { return r.sweep == "compression" && r.basis == basis; });
  }
};

// report.json, without the pictures.
nlohmann::json report_meta(const ReportRun& r) {
  const ReportArgs& a = r.a;
  const ReportOptions& opt = r.opt;
  const Report& rep = r.rep;
  const std::size_t V = r.V;
  const Fit& fit = r.fits.fit;
  const Fit& fit_alone = r.fits.fit_alone;
  nlohmann::json meta;
  meta["mesh"] = a.mesh;
  meta["map"] = a.env;
  meta["mesh_name"] = fs::path(a.mesh).filename().string();
  meta["map_name"] = fs::path(a.env).filename().string();
  meta["vertices"] = V;
  meta["quick"] = a.quick;
  meta["shadowed_noise_floor"] = rep.shadowed_truth.vertices.empty() ? 0.0 : rep.shadowed_truth.noise_floor();
  meta["interreflected_noise_floor"] =
      rep.interreflected_truth.vertices.empty() ? 0.0 : rep.interreflected_truth.noise_floor();
  nlohmann::json fits = nlohmann::json::object();
  if (!std::isnan(fit.slope))
    fits.update({{"slope", fit.slope}, {"intercept", fit.intercept}, {"slope_range", {fit.x0, fit.x1}}});
  if (!std::isnan(fit_alone.slope))
    fits.update({{"self_slope", fit_alone.slope},
                 {"self_intercept", fit_alone.intercept},
                 {"self_slope_range", {fit_alone.x0, fit_alone.x1}}});
  meta["samples_fit"] = fits;
  if (r.has("compression")) {
    nlohmann::json c{{"bands", opt.compression_bands},
                     {"samples", opt.bands_samples},
                     {"iterations", opt.compression_iterations},
                     {"weight_bits", opt.compression_weight_bits},
                     {"frame_size", kFrameSize},
                     {"frames", kTimedFrames},
                     {"device", r.gl_device},
                     {"no_frames", r.frames_why}};
    if (r.has_basis("cpca glossy"))
      c.update({{"glossy_bands", opt.compression_glossy_bands},
                {"gloss", rep.compression_gloss},
                {"eyes", rep.compression_eyes.size()}});
    meta["compression"] = c;
  }
  return meta;
}

// report.md's title, what the errors are measured against, and the first plot.
std::string report_intro(const ReportRun& r, const nlohmann::json& meta) {
  const ReportArgs& a = r.a;
  const ReportOptions& opt = r.opt;
  const Report& rep = r.rep;
  const std::size_t V = r.V;
  std::string md = fmt::format("# prt report: {} under {}\n\n", meta["mesh_name"].get<std::string>(),
                               meta["map_name"].get<std::string>());
  const std::size_t error_vertices =
      !rep.shadowed_truth.vertices.empty()  ? rep.shadowed_truth.vertices.size()
      : !rep.glossy_truth.empty()           ? rep.glossy_truth.front().vertices.size()
                                            : rep.interreflected_truth.vertices.size();
  if (error_vertices == 0)  // the compression sweep alone: no reference
    md += fmt::format("{} vertices, albedo {}, {} grid. No reference: the compression sweep's errors are against the "
                      "uncompressed transfer.\n\n",
                      V, a.albedo, a.quick ? "quick" : "full");
  if (error_vertices > 0) {
    md += fmt::format(
        "{} vertices, albedo {}, {} grid. Errors are relative RMS over {} randomly chosen vertices against the "
        "Monte Carlo reference (`prt reference`",
        V, a.albedo, a.quick ? "quick" : "full", error_vertices);
    if (!rep.shadowed_truth.vertices.empty())
      md += fmt::format(": shadowed {} samples per vertex, noise floor {:.3g}", opt.truth_samples,
                        meta["shadowed_noise_floor"].get<double>());
    if (!rep.interreflected_truth.vertices.empty())
      md += fmt::format("; interreflected, {} bounces, {} samples, noise floor {:.3g}", opt.truth_bounces,
                        opt.truth_bounce_samples, meta["interreflected_noise_floor"].get<double>());
    md +=
        "), with the reference's own noise subtracted in quadrature (docs/REPORT.md); `*` marks an error below "
        "twice the noise floor, which the reference does not resolve. p99: 99th percentile of the per-vertex "
        "relative error (uncorrected). Precompute: wall time for the whole mesh on this machine; relight: CPU time "
        "per frame (lighting rotation and every vertex's sum; wavelets: resample, Haar, K terms, sparse sum), "
        "median. Storage: the transfer file.\n\n";
  }
  if (r.has("bands") || r.has("samples") || r.has("bounces") || r.has("terms"))
    md += "![error against precompute time](error_vs_time.png)\n\n";
  return md;
}

// report.md's sections of the bands, samples, bounces, terms and glossy sweeps.
std::string sweep_sections(const ReportRun& r) {
  const ReportOptions& opt = r.opt;
  const Report& rep = r.rep;
  const std::size_t V = r.V;
  const Fit& fit = r.fits.fit;
  const Fit& fit_alone = r.fits.fit_alone;
  const int max_samples = r.fits.max_samples;
  std::string md;
  const auto section = [&](const char* sweep, const std::string& title, const std::string& text) {
    if (std::none_of(rep.rows.begin(), rep.rows.end(), [&](const ReportRow& row) { return row.sweep == sweep; })) return;
    md += "## " + title + "\n\n" + text + "\n\n" + table(rep.rows, r.front, sweep, V) + "\n";
  };
  section("bands", "SH bands", fmt::format("Shadowed, {} samples per vertex.", opt.bands_samples));
  if (r.has("bands") || r.has("terms")) md += "![error against bands and K](error_vs_settings.png)\n\n";
  std::string fit_text = fmt::format("Shadowed, {} bands.", opt.samples_bands);
  if (!std::isnan(fit.slope))
    fit_text += fmt::format(" Fitted slope of error against samples (log-log): **{:.2f}** against the reference", fit.slope);
  if (!std::isnan(fit_alone.slope))
    fit_text += fmt::format(", **{:.2f}** for the sampling error alone (against {} samples, points up to {})",
                            fit_alone.slope, max_samples, max_samples / 4);
  fit_text += "; Monte Carlo converges with slope -0.5. \"Sampling alone\" is the error against the sweep's "
              "largest sample count at the same bands, which the band truncation does not hide.";
  section("samples", "Samples per vertex", fit_text);
  if (r.has("samples")) md += "![error against samples](error_vs_samples.png)\n\n";
  section("bounces", "Interreflection bounces",
          fmt::format("{} bands, {} samples; 0 is the shadowed transfer. Against the interreflected reference.",
                      opt.bounce_bands, opt.bounce_samples));
  section("terms", "Wavelet terms K",
          fmt::format("Haar on a {}x{}x6 cube, threshold {}, area-weighted selection; one precompute.", opt.cube_res,
                      opt.cube_res, opt.threshold));
  if (std::any_of(rep.rows.begin(), rep.rows.end(), [](const ReportRow& row) { return row.sweep == "glossy"; })) {
    std::string noise;
    for (std::size_t g = 0; g < rep.glossy_truth.size(); ++g)
      noise += fmt::format("{}e = {:g}: {:.3g}", g ? ", " : "", opt.glossy_gloss[g], rep.glossy_truth[g].noise_floor());
    md += fmt::format(
        "## Glossy transfer\n\nShadowed glossy matrices at {} samples, the glossy part alone (rho_s = 1, no "
        "diffuse) seen from ({:.4g}, {:.4g}, {:.4g}), against a glossy reference per exponent ({} samples per "
        "vertex; noise floors {}). Intrinsic: the same SH formula with matrices traced at {} samples at the error "
        "vertices: what the band count alone costs (docs/GLOSSY.md).\n\n{}\n",
        opt.glossy_samples, rep.glossy_eye.x, rep.glossy_eye.y, rep.glossy_eye.z, opt.truth_glossy_samples, noise,
        opt.glossy_exact_samples, glossy_table(rep.rows, V));
  }
  return md;
}

// report.md's compression section.
std::string compression_section(const ReportRun& r) {
  const ReportOptions& opt = r.opt;
  const Report& rep = r.rep;
  const std::size_t V = r.V;
  const std::string& gl_device = r.gl_device;
  const std::string& frames_why = r.frames_why;
  std::string md;
  const auto uncompressed = [&](const char* basis) {
    for (const ReportRow& row : rep.rows)
      if (row.sweep == "compression" && row.basis == basis) return row;
    return ReportRow{};
  };
  const ReportRow d = uncompressed("cpca"), g = uncompressed("cpca glossy");
  const auto frame = [](double ms) { return std::isnan(ms) ? std::string("-") : fmt::format("{:.3g} ms", ms); };
  md += fmt::format(
      "## Compression (clustered PCA)\n\nEach K clusters x N vectors fitted to the stored rows (docs/COMPRESSION.md) "
      "with {}-bit weights, at most {} rounds of the fit. Per vertex: the signals' bytes as stored "
      "(ClusteredSignal::bytes) over all {} vertices; \"of uncompressed\": their share of the uncompressed rows' "
      "floats. Relit error: relative RMS of the compressed transfer's radiance against the uncompressed one's "
      "under the map (compression_error), not against the reference. Relight: CPU, per frame (per-cluster "
      "products and N weights a vertex). Frame: GPU, {}x{}, the lighting turned and the frame drawn, median of {} "
      "frames{}; \"of uncompressed\": over the uncompressed transfer's frame, timed in the same run. Pareto: no "
      "other row has no more bytes and no larger error, and less of one.\n\n",
      opt.compression_weight_bits, opt.compression_iterations, V, kFrameSize, kFrameSize, kTimedFrames,
      gl_device.empty() ? std::string() : " (" + gl_device + ")");
  if (!frames_why.empty()) md += "No frame times: " + frames_why + "\n\n";
  if (r.has_basis("cpca"))
    md += fmt::format("### Diffuse, {} bands\n\nShadowed, {} samples: uncompressed {} a vertex, frame {}.\n\n{}\n",
                      d.bands, d.samples, bytes_text(double(d.uncompressed_bytes) / double(V)),
                      frame(d.uncompressed_frame_ms), compression_table(rep.rows, r.front, "cpca", V));
  if (r.has_basis("cpca glossy"))
    md += fmt::format(
        "### Glossy, {} bands\n\nThe glossy sweep's transfer ({} samples), both signals (coefficients and "
        "matrices) at the same K x N; error and frames with the diffuse part and the lobe e = {:g}, rho_s = 0.5, "
        "the error over {} views around the mesh (eye_ring), frames from prt render's default camera. "
        "Uncompressed {} a vertex, frame {}.\n\n{}\n",
        g.bands, g.samples, g.gloss, rep.compression_eyes.size(),
        bytes_text(double(g.uncompressed_bytes) / double(V)), frame(g.uncompressed_frame_ms),
        compression_table(rep.rows, r.front, "cpca glossy", V));
  md += "![bytes and frame time against error](compression.png)\n\n";
  return md;
}

int run_report_command(ReportArgs& a) {
  ReportOptions opt = report_command_options(a);
  std::error_code ec;
  fs::create_directories(a.out, ec);
  if (ec || !fs::is_directory(a.out)) throw Error("--out: cannot create the directory " + a.out);
  for_path("--out", [&] { check_writable((fs::path(a.out) / "report.md").string()); });
  const std::string cache = a.no_cache ? std::string() : a.cache.empty() ? (fs::path(a.out) / "cache").string() : a.cache;
  std::unique_ptr<tbb::global_control> limit;
  if (a.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);

  const auto t0 = std::chrono::steady_clock::now();
  const Mesh mesh = load_mesh(a.mesh, a.mesh_opt);
  const EnvMap map = load_envmap(a.env);
  require_finite(map);
  if (map.is_cube()) throw Error(a.env + ": prt report needs a lat-long (2:1) map, not " + map.source_layout);
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n", describe(mesh), describe(map));
  Gl gl;
  std::string frames_why;
  opt.frame_timer = [&](const Transfer& t, const CompressedTransfer* c, std::span<const glm::dvec3> light,
                        double gloss, double specular) {
    return time_frames(gl, mesh, map, t, c, light, gloss, specular, frames_why);
  };
  const bool tty = isatty(2);
  const ReportLog log = [&](const std::string& line) {
    if (!a.quiet) fmt::print(stderr, "{}{}\n", tty ? "\r\033[K" : "", line);
  };
  const std::optional<Report> computed = run_with_progress(
      a.quiet, "report", [&](const Progress& progress) { return run_report(mesh, map, opt, cache, progress, log); });
  if (!computed) return 130;
  const Report& rep = *computed;
  const ReportRun run{a, opt, rep, pareto_front(rep.rows), mesh.vertex_count(), sample_fits(rep),
                      gl.renderer ? gl.renderer->device() : std::string(), frames_why};
  const std::size_t V = run.V;
  nlohmann::json meta = report_meta(run);

  std::string pictures_note;
  if (!rep.image_reference.empty()) {
    try {
      meta["pictures"] = render_pictures(gl, mesh, rep, opt.albedo, a.out, a.image_size);
      meta["reference_image"] = "images/reference.png";
      meta["image_samples"] = rep.image_samples;
      meta["image_noise"] = rep.image_reference_noise;
    } catch (const Error& e) {
      pictures_note = fmt::format("no pictures: {}", e.what());
    }
  }
  write_text_file((fs::path(a.out) / "report.csv").string(), csv_text(rep.rows, run.front, V));
  write_text_file((fs::path(a.out) / "report.json").string(), meta.dump(2) + "\n");
  std::string plots_note = a.no_plots ? "plots skipped (--no-plots)" : run_plots(a.out);

  std::string md = report_intro(run, meta);
  md += sweep_sections(run);
  if (run.has("compression")) md += compression_section(run);
  if (meta.contains("pictures"))
    md += fmt::format("## Pictures\n\n![reference, settings and error heat maps](images.png)\n\nThe reference here "
                      "has {} samples at every vertex (noise floor {:.3g}); heat maps show |result - reference| / "
                      "mean |reference| per vertex.\n\n",
                      rep.image_samples, rep.image_reference_noise);
  md += "## Notes\n\n";
  for (const std::string& n : rep.notes) md += "- " + n + "\n";
  if (!pictures_note.empty()) md += "- " + pictures_note + "\n";
  if (!plots_note.empty()) md += "- " + plots_note + "\n";
  if (run.has("compression") && !frames_why.empty()) md += "- no frame times: " + frames_why + "\n";
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const bool all_sweeps = a.sweeps == ReportArgs{}.sweeps;
  md += fmt::format("- Report made in {:.1f} s by `prt report{}{} {} {}`.\n", secs, a.quick ? " --quick" : "",
                    all_sweeps ? std::string() : " --sweeps " + a.sweeps, a.mesh, a.env);
  write_text_file((fs::path(a.out) / "report.md").string(), md);
  if (!pictures_note.empty()) fmt::print(stderr, "warning: {}\n", pictures_note);
  if (run.has("compression") && !frames_why.empty()) fmt::print(stderr, "warning: no frame times: {}\n", frames_why);
  if (!plots_note.empty()) fmt::print(stderr, "warning: {}\n", plots_note);
  if (!a.quiet) fmt::print(stderr, "wrote {}/report.md, report.csv, plots ({:.1f} s)\n", a.out, secs);
  return 0;
}

}  // namespace

Run add_report(CLI::App& app) {
  auto a = std::make_shared<ReportArgs>();
  CLI::App* s = app.add_subcommand(
      "report",
      "Speed against error on a model and map: tables, CSV and plots over bands, samples, bounces, K and compression");
  s->footer(
      "Runs the ground truth once (cached in DIR/cache), then precomputes and relights every setting of the grid\n"
      "(full: bands 3..16, samples 64..4096, bounces 0..3, wavelet K 10..1000, clustered PCA 1..256 clusters x\n"
      "1..16 vectors; --quick: a smaller grid and\n"
      "reference) and writes DIR/report.md, report.csv, report.json and PNG plots (python3-matplotlib).\n"
      "See docs/REPORT.md. Ctrl-C stops without writing.\n"
      "Example: prt report bunny.off forest.exr --out bunny-report --quick");
  s->add_option("MESH", a->mesh, "Mesh file: OBJ, PLY, OFF, STL, glTF/GLB")->check(path_value())->required();
  s->add_option("ENV", a->env, "Lat-long environment map (EXR, HDR, ...)")->check(path_value())->required();
  s->add_option("-o,--out", a->out, "Output directory")->check(path_value())->capture_default_str();
  s->add_flag("--quick", a->quick, "Small grid and reference (under a minute for ~40k vertices on 2 cores)");
  add_shared(s, SharedOption::Albedo, a->albedo, "Diffuse albedo");
  s->add_option("--cache", a->cache, "Directory of cached references (default DIR/cache)")->check(path_value());
  s->add_flag("--no-cache", a->no_cache, "Always recompute the references");
  s->add_flag("--no-plots", a->no_plots, "Tables only (no Python)");
  s->add_option("--sweeps", a->sweeps, "Which sweeps, comma-separated: bands, samples, bounces, terms, glossy, compression")
      ->capture_default_str();
  s->add_option("--image-size", a->image_size, "Picture size in pixels")->check(int_range(16, 4096))->capture_default_str();
  s->add_flag("--weld", a->mesh_opt.weld, "Merge vertices that share a position before precomputing");
  add_shared(s, SharedOption::Threads, a->threads, "Worker threads");
  s->add_flag("-q,--quiet", a->quiet, "No progress or summary on stderr");
  return [a] { return run_report_command(*a); };
}

}  // namespace prt::cli
