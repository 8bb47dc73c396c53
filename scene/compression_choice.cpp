// What a compression's size was chosen for (prt/compressed_transfer.h,
// CompressionChoiceRecord): its checks, its JSON form (docs/FORMAT.md, kind
// 12) and its description for prt info.
#include <prt/compressed_transfer.h>

#include <prt/error.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace prt {

std::string compression_choice_problem(const CompressionChoiceRecord& r) {
  if (!(r.target > 0 && r.target < 1)) return fmt::format("choice: target {} is not in (0, 1)", r.target);
  if (r.statistic != "p95" && r.statistic != "mean")
    return fmt::format("choice: statistic '{}' is not p95 or mean", r.statistic);
  if (r.metric != "band" && r.metric != "plain") return fmt::format("choice: metric '{}' is not band or plain", r.metric);
  if (r.maps.empty()) return "choice: no lighting map";
  if (r.rotations < 1) return fmt::format("choice: {} rotations (at least 1)", r.rotations);
  if (r.eyes < 0) return fmt::format("choice: {} eyes", r.eyes);
  if ((r.eyes > 0) != (!r.exponents.empty() && !r.speculars.empty()))
    return "choice: glossy exponents and strengths go with eyes, and only with them";
  const auto bad = [](double x) { return !std::isfinite(x) || x < 0; };
  for (double x : {r.mean, r.p95, r.max, r.bound})
    if (bad(x)) return fmt::format("choice: a measured error of {}", x);
  for (const auto* v : {&r.exponents, &r.speculars})
    if (std::any_of(v->begin(), v->end(), [&](double x) { return bad(x) || x == 0; }))
      return "choice: an exponent or strength that is not finite and positive";
  if (r.mean > r.max || r.p95 > r.max) return "choice: a mean or p95 above the max";
  if (r.samples < 1 || r.vertices < 1) return "choice: no samples or vertices measured";
  return {};
}

std::string compression_choice_json(const CompressionChoiceRecord& r) {
  nlohmann::ordered_json j;
  j["target"] = r.target;
  j["statistic"] = r.statistic;
  j["metric"] = r.metric;
  j["search"] = r.exhaustive ? "exhaustive" : "quick";
  j["maps"] = r.maps;
  j["spectra"] = r.spectra;
  j["sun"] = r.sun;
  j["rotations"] = r.rotations;
  j["seed"] = r.seed;
  j["eyes"] = r.eyes;
  j["exponents"] = r.exponents;
  j["speculars"] = r.speculars;
  j["measured"] = {{"mean", r.mean},       {"p95", r.p95},         {"max", r.max},
                   {"bound", r.bound},     {"samples", r.samples}, {"vertices", r.vertices}};
  return j.dump();
}

CompressionChoiceRecord parse_compression_choice(std::string_view text) {
  nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw Error("choice: not a JSON object");
  CompressionChoiceRecord r;
  try {
    r.target = j.at("target").get<double>();
    r.statistic = j.at("statistic").get<std::string>();
    r.metric = j.at("metric").get<std::string>();
    const std::string search = j.at("search").get<std::string>();
    if (search != "quick" && search != "exhaustive") throw Error("choice: search '" + search + "' is not quick or exhaustive");
    r.exhaustive = search == "exhaustive";
    r.maps = j.at("maps").get<std::vector<std::string>>();
    r.spectra = j.at("spectra").get<std::vector<std::string>>();
    r.sun = j.at("sun").get<bool>();
    r.rotations = j.at("rotations").get<int>();
    r.seed = j.at("seed").get<std::uint64_t>();
    r.eyes = j.at("eyes").get<int>();
    r.exponents = j.at("exponents").get<std::vector<double>>();
    r.speculars = j.at("speculars").get<std::vector<double>>();
    const nlohmann::json& m = j.at("measured");
    r.mean = m.at("mean").get<double>();
    r.p95 = m.at("p95").get<double>();
    r.max = m.at("max").get<double>();
    r.bound = m.at("bound").get<double>();
    r.samples = m.at("samples").get<std::uint64_t>();
    r.vertices = m.at("vertices").get<std::uint64_t>();
  } catch (const nlohmann::json::exception& e) {
    // at(): a key missing; get<>(): a value of the wrong type.
    throw Error(std::string("choice: ") + e.what());
  }
  if (auto p = compression_choice_problem(r); !p.empty()) throw Error(p);
  return r;
}

std::string describe_choice(const CompressionChoiceRecord& r) {
  const auto list = [](const auto& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + fmt::format("{}", x);
    return s;
  };
  std::string s = fmt::format("chosen for a {} relit error of at most {:g}% ({} metric, {} search) over {} map{} ({}) x "
                              "{} rotation{}",
                              r.statistic, 100 * r.target, r.metric, r.exhaustive ? "exhaustive" : "quick",
                              r.maps.size(), r.maps.size() == 1 ? "" : "s", list(r.maps), r.rotations,
                              r.rotations == 1 ? "" : "s");
  if (!r.spectra.empty()) s += fmt::format(" taking their own spectra and those of {} in turn", list(r.spectra));
  if (r.sun) s += fmt::format(", and a point light (the sun) x {} rotation{}", r.rotations, r.rotations == 1 ? "" : "s");
  if (r.eyes > 0)
    s += fmt::format("; {} eyes on a sphere, exponents {}, specular {}", r.eyes, list(r.exponents), list(r.speculars));
  s += fmt::format(": measured mean {:.3f}%, p95 {:.3f}%, max {:.3f}% over {} samples on {} vertices; transfer-space "
                   "bound {:.3f}%",
                   100 * r.mean, 100 * r.p95, 100 * r.max, r.samples, r.vertices, 100 * r.bound);
  return s;
}

}  // namespace prt
