// prt compare: error of one vertex CSV against a reference one.
#include "commands.h"
#include "lightmap_inputs.h"

#include <prt/vertex_csv.h>
#include <prt/accuracy.h>
#include <prt/compare.h>
#include <prt/envmap.h>
#include <prt/lightmap.h>

#include <glm/geometric.hpp>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>

namespace prt::cli {

namespace {

struct CompareArgs {
  std::string a, b;
  bool json = false;
};

// JSON has no infinity: a black reference's infinite relative errors become null.
nlohmann::json number(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

bool is_exr(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return ext == ".exr";
}

// One page of two lightmaps (RGBA EXR, A = 1 at covered texels: prt
// relight and prt reference --lightmap): the covered texels' RGB appended to
// `a` and `b` (B's standard errors to `se`), in texel order.
void read_lightmap_page(const std::string& pa, const std::string& pb, std::vector<glm::vec3>& a,
                        std::vector<glm::vec3>& b, std::vector<glm::vec3>& se) {
  const RgbaImage ia = read_exr_rgba(pa), ib = read_exr_rgba(pb);
  if (ia.width != ib.width || ia.height != ib.height)
    throw Error(fmt::format("{} is {}x{} but {} is {}x{}: not lightmaps of the same atlas", pa, ia.width, ia.height, pb,
                            ib.width, ib.height));
  std::size_t differ = 0;
  for (std::size_t i = 0; i < std::size_t(ia.width) * ia.height; ++i) {
    const bool ca = ia.rgba[4 * i + 3] > 0.5f, cb = ib.rgba[4 * i + 3] > 0.5f;
    if (ca != cb) ++differ;
    if (!ca || !cb) continue;
    a.emplace_back(ia.rgba[4 * i], ia.rgba[4 * i + 1], ia.rgba[4 * i + 2]);
    b.emplace_back(ib.rgba[4 * i], ib.rgba[4 * i + 1], ib.rgba[4 * i + 2]);
    if (!ib.std_error.empty()) se.emplace_back(ib.std_error[3 * i], ib.std_error[3 * i + 1], ib.std_error[3 * i + 2]);
  }
  if (differ)
    throw Error(fmt::format("{} and {} cover different texels ({} differ in A): not lightmaps of the same scene and atlas",
                            pa, pb, differ));
}

// The files of a lightmap: `path`, or for "<UDIM>" in it every page from
// 1001 up that exists (what prt relight and prt reference write for a
// lightmap of many pages: page_path, lightmap_inputs.h).
std::vector<std::string> lightmap_pages(const std::string& path) {
  const auto page = [&](int p) { return page_path(path, p, kMaxLightmapPages); };
  if (path.find("<UDIM>") == std::string::npos) {
    if (!std::filesystem::exists(path) && std::filesystem::exists(page(0)))
      throw Error(fmt::format("{} does not exist but {} does: a lightmap of many pages; compare them all with <UDIM> "
                              "in both paths (NAME.<UDIM>.exr)",
                              path, page(0)));
    return {path};
  }
  std::vector<std::string> out;
  for (int p = 0; p < kMaxLightmapPages && std::filesystem::exists(page(p)); ++p) out.push_back(page(p));
  if (out.empty()) throw Error(fmt::format("{}: no page of it exists (the first would be {})", path, page(0)));
  return out;
}

// Two lightmaps, each one EXR or its pages (lightmap_pages): the covered
// texels' RGB, page after page, in texel order.
void read_lightmaps(const std::string& pa, const std::string& pb, std::vector<glm::vec3>& a, std::vector<glm::vec3>& b,
                    std::vector<glm::vec3>& se) {
  const std::vector<std::string> fa = lightmap_pages(pa), fb = lightmap_pages(pb);
  const bool udim_a = pa.find("<UDIM>") != std::string::npos, udim_b = pb.find("<UDIM>") != std::string::npos;
  if (udim_a != udim_b)
    throw Error(fmt::format("{} and {}: give <UDIM> in both paths (the pages of two lightmaps) or in neither", pa, pb));
  if (fa.size() != fb.size())
    throw Error(fmt::format("{} has {} pages but {} has {}: not lightmaps of the same atlas", pa, fa.size(), pb,
                            fb.size()));
  for (std::size_t p = 0; p < fa.size(); ++p) read_lightmap_page(fa[p], fb[p], a, b, se);
  if (a.empty()) throw Error(fmt::format("{}: no covered texel (A = 1): not a prt lightmap", pa));
}

int run_compare(const CompareArgs& args) {
  std::vector<glm::vec3> se;
  std::vector<glm::vec3> a, b;
  if (is_exr(args.a) || is_exr(args.b)) {
    if (!is_exr(args.a) || !is_exr(args.b))
      throw Error("prt compare takes two vertex CSVs or two lightmap EXRs, not one of each: " + args.a + ", " + args.b);
    read_lightmaps(args.a, args.b, a, b, se);
  } else {
    a = read_vertex_csv(args.a);
    b = read_vertex_csv(args.b, &se);
  }
  if (a.size() != b.size())
    throw Error(fmt::format("{} has {} vertices but {} has {}: not results for the same mesh", args.a, a.size(),
                            args.b, b.size()));
  const CompareResult r = compare_vertices(a, b);

  // The reference's own noise, when it carries standard errors: differences
  // of this size are not resolved by it, and subtracting it in quadrature
  // estimates the error against the exact answer (prt/accuracy.h).
  std::optional<Accuracy> acc;
  if (!se.empty()) acc = measure_accuracy(whole_error_set(b, se), a);
  if (args.json) {
    nlohmann::ordered_json j;
    j["a"] = args.a;
    j["b"] = args.b;
    j["vertices"] = r.vertices;
    j["rel_rms"] = number(r.rel_rms);
    j["p99_rel"] = number(r.p99_rel);
    j["max_rel"] = number(r.max_rel);
    j["max_rel_vertex"] = r.max_vertex;
    j["eps"] = r.eps;
    j["mean_ref"] = r.mean_ref;
    j["rms_abs"] = r.rms_abs;
    j["max_abs"] = r.max_abs;
    j["ref_noise_rel_rms"] = acc ? nlohmann::json(acc->noise_floor) : nlohmann::json(nullptr);
    j["rel_rms_noise_corrected"] = acc ? nlohmann::json(acc->rel_rms) : nlohmann::json(nullptr);
    j["definitions"] =
        "norms are Euclidean over RGB; rel_rms = sqrt(sum |a-b|^2 / sum |b|^2); per-vertex e = |a-b| / max(|b|, eps), "
        "eps = 1e-3 x mean |b|; p99 by nearest rank; b is the reference; rel_rms_noise_corrected = "
        "sqrt(max(0, sum |a-b|^2 - sum |se|^2) / sum |b|^2)";
    fmt::print("{}\n", j.dump(2));
    return 0;
  }
  fmt::print("{} vs {} (reference): {} vertices\n", args.a, args.b, r.vertices);
  fmt::print("  relative RMS error       {:.6g}   sqrt(sum |a-b|^2 / sum |b|^2)\n", r.rel_rms);
  fmt::print("  99th percentile rel.     {:.6g}   per vertex |a-b| / max(|b|, eps)\n", r.p99_rel);
  fmt::print("  max relative error       {:.6g}   at vertex {}\n", r.max_rel, r.max_vertex);
  fmt::print("  eps                      {:.6g}   = 1e-3 x mean |b| ({:.6g})\n", r.eps, r.mean_ref);
  fmt::print("  RMS / max absolute       {:.6g} / {:.6g}\n", r.rms_abs, r.max_abs);
  if (acc) {
    fmt::print("  reference noise          {:.6g}   relative RMS of its standard errors\n", acc->noise_floor);
    fmt::print("  noise-corrected rel. RMS {:.6g}   its noise subtracted in quadrature\n", acc->rel_rms);
  }
  return 0;
}

}  // namespace

Run add_compare(CLI::App& app) {
  auto a = std::make_shared<CompareArgs>();
  CLI::App* s = app.add_subcommand("compare", "Error of per-vertex radiance A.csv against a reference B.csv");
  s->footer(
      "Files: vertex,r,g,b[,se_r,se_g,se_b] as written by prt relight and prt reference; or two lightmaps (RGBA\n"
      "EXR of prt relight and prt reference --lightmap), compared over their covered texels (A = 1; the texels\n"
      "are the 'vertices' below); a lightmap of many pages with <UDIM> in both paths (lm.<UDIM>.exr: its pages\n"
      "from lm.1001.exr up, compared as one).\n"
      "Norms are Euclidean over RGB. eps keeps near-black vertices from dominating the relative errors.\n"
      "Example: prt compare cow_prt.csv cow_ref.csv --json");
  s->add_option("A", a->a, "CSV (or lightmap EXR) to judge")->check(path_value())->required();
  s->add_option("B", a->b, "Reference CSV (or lightmap EXR)")->check(path_value())->required();
  s->add_flag("--json", a->json, "Print the numbers as JSON");
  return [a] { return run_compare(*a); };
}

}  // namespace prt::cli
