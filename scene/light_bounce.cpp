// The lights' bounce operator (prt/light_bounce.h; docs/LIGHTS.md "Bounce").
#include <prt/light_bounce.h>

#include <prt/error.h>
#include <prt/probes.h>

#include <fmt/format.h>
#include <glm/gtc/packing.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace prt {

std::size_t LightBounce::bytes() const {
  // The weights as a file stores them: 16-bit halves (docs/FORMAT.md "Light-bounce operator").
  return (patch.size() + parent.size() + offsets.size() + source.size() + cluster_offsets.size() +
          cluster_source.size()) *
             sizeof(std::uint32_t) +
         (weight.size() + cluster_weight.size()) * sizeof(std::uint16_t) + probes.bytes();
}

namespace {

// What is wrong with rows of (patch, `per_entry` weights) entries, or "";
// `signed_weights`: the weights may be negative (SH coefficients).
std::string rows_problem(const char* what, std::span<const std::uint32_t> offsets, std::span<const std::uint32_t> source,
                         std::span<const float> weight, std::uint32_t patches, std::size_t per_entry = 1,
                         bool signed_weights = false) {
  if (weight.size() != source.size() * per_entry)
    return fmt::format("light bounce: {} sources and {} weights ({}s, {} weights an entry)", source.size(),
                       weight.size(), what, per_entry);
  if (offsets.front() != 0 || offsets.back() != source.size())
    return fmt::format("light bounce: {} offsets run from {} to {} over {} entries", what, offsets.front(),
                       offsets.back(), source.size());
  // Every offset before any row is read: non-decreasing up to the entries,
  // no row then reaches past them.
  const std::size_t rows = offsets.size() - 1;
  for (std::size_t i = 0; i < rows; ++i)
    if (offsets[i + 1] < offsets[i]) return fmt::format("light bounce: {} {}'s offsets decrease", what, i);
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::uint32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
      if (source[e] >= patches) return fmt::format("light bounce: {} {} names patch {} of {}", what, i, source[e], patches);
      if (e > offsets[i] && source[e] <= source[e - 1])
        return fmt::format("light bounce: {} {}'s patches do not increase", what, i);
      for (std::size_t k = 0; k < per_entry; ++k) {
        const float w = weight[e * per_entry + k];
        if (!(signed_weights || w >= 0.0f) || !std::isfinite(w))
          return fmt::format("light bounce: {} {} has the weight {}", what, i, w);
        if (glm::unpackHalf1x16(glm::packHalf1x16(w)) != w)
          return fmt::format("light bounce: {} {} has the weight {}, not a half-precision value", what, i, w);
      }
    }
  }
  return "";
}

// What is wrong with an operator's probe rows, or "" (none is fine).
std::string probe_rows_problem(const LightBounce::ProbeRows& r, std::uint32_t patches) {
  if (r.empty()) {
    if (r.dims != std::array<int, 3>{0, 0, 0} || r.bands != 0 || !r.source.empty() || !r.weight.empty())
      return "light bounce: probe entries without the probes' row offsets";
    return "";
  }
  if (const std::string p = probe_dims_problem(r.dims); !p.empty()) return "light bounce: probe rows' grid: " + p;
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(r.min[a]) || !std::isfinite(r.max[a]) || r.max[a] < r.min[a])
      return fmt::format("light bounce: the probe rows' box runs from {} to {} along axis {}", r.min[a], r.max[a], a);
  if (r.bands < 1 || r.bands > 8) return fmt::format("light bounce: probe rows of {} bands (1 to 8)", r.bands);
  const std::size_t probes = std::size_t(r.dims[0]) * std::size_t(r.dims[1]) * std::size_t(r.dims[2]);
  if (r.offsets.size() != probes + 1)
    return fmt::format("light bounce: {} probe row offsets for {} probes (expected {})", r.offsets.size(), probes,
                       probes + 1);
  return rows_problem("probe row", r.offsets, r.source, r.weight, patches, std::size_t(r.bands) * r.bands, true);
}

}  // namespace

std::string light_bounce_problem(const LightBounce& b, std::size_t points) {
  if (b.bounces == 0) {
    if (b.patches != 0 || !b.patch.empty() || !b.parent.empty() || !b.offsets.empty() || !b.source.empty() ||
        !b.weight.empty() || !b.cluster_offsets.empty() || !b.cluster_source.empty() || !b.cluster_weight.empty() ||
        !b.probes.empty() || !b.probes.source.empty() || !b.probes.weight.empty())
      return "a light-bounce operator of 0 bounces holds arrays";
    return "";
  }
  if (b.bounces < 0 || b.bounces > kMaxLightBounces)
    return fmt::format("light bounce: {} bounces (1 to {})", b.bounces, kMaxLightBounces);
  if (b.patch.size() != points) return fmt::format("light bounce: {} patch indices for {} points", b.patch.size(), points);
  if (b.offsets.size() != points + 1)
    return fmt::format("light bounce: {} row offsets for {} points (expected {})", b.offsets.size(), points, points + 1);
  if (b.patches == 0 && points > 0) return "light bounce: no source patches";
  // Before the array of that size (a damaged file's count could be 2^32 - 1):
  // each level's patches hold at least one point each.
  if (b.patches > std::uint64_t(points) * kMaxPatchLevels)
    return fmt::format("light bounce: {} source patches for {} points (at most {} levels of patches, each holding at "
                       "least one point)",
                       b.patches, points, kMaxPatchLevels);
  if (b.parent.size() != b.patches)
    return fmt::format("light bounce: {} parents for {} patches", b.parent.size(), b.patches);
  std::vector<std::uint8_t> used(b.patches, 0);
  for (std::size_t i = 0; i < points; ++i) {
    if (b.patch[i] >= b.patches)
      return fmt::format("light bounce: point {} is in patch {} of {}", i, b.patch[i], b.patches);
    used[b.patch[i]] = 1;
  }
  for (std::uint32_t p = 0; p < b.patches; ++p) {
    if (b.parent[p] != LightBounce::kNoParent && (b.parent[p] <= p || b.parent[p] >= b.patches))
      return fmt::format("light bounce: patch {}'s parent is {} (a later patch of {}, or none)", p, b.parent[p],
                         b.patches);
    if (!used[p]) return fmt::format("light bounce: patch {} holds no point", p);
    if (b.parent[p] != LightBounce::kNoParent) used[b.parent[p]] = 1;  // parents follow their children
  }
  if (std::string p = rows_problem("row", b.offsets, b.source, b.weight, b.patches); !p.empty()) return p;
  if (std::string p = probe_rows_problem(b.probes, b.patches); !p.empty()) return p;
  if (b.cluster_offsets.empty()) {
    if (!b.cluster_source.empty() || !b.cluster_weight.empty())
      return "light bounce: cluster entries without the clusters' row offsets";
    return "";
  }
  if (b.cluster_offsets.size() != std::size_t(b.patches) + 1)
    return fmt::format("light bounce: {} cluster row offsets for {} patches (expected {})", b.cluster_offsets.size(),
                       b.patches, std::size_t(b.patches) + 1);
  return rows_problem("cluster row", b.cluster_offsets, b.cluster_source, b.cluster_weight, b.patches);
}

LightBounce link_clusters(const LightBounce& b, int offset) {
  if (offset < 0) throw Error(fmt::format("light bounce: cluster offset {} (0 or more)", offset));
  if (!b.cluster_offsets.empty()) throw Error("light bounce: the operator's links already reach clusters");
  LightBounce out = b;
  if (b.empty()) return out;
  out.offsets.assign(1, 0);
  out.source.clear();
  out.weight.clear();
  // Each patch's level above the finest (children come before parents) and points.
  std::vector<int> level(b.patches, 0);
  std::vector<std::uint32_t> members(b.patches, 0);
  for (std::uint32_t p : b.patch) ++members[p];
  for (std::uint32_t p = 0; p < b.patches; ++p)
    if (b.parent[p] != LightBounce::kNoParent) {
      level[b.parent[p]] = level[p] + 1;
      members[b.parent[p]] += members[p];
    }
  std::vector<std::vector<std::pair<std::uint32_t, double>>> rows(b.patches);
  std::vector<std::uint32_t> chain;
  for (std::size_t i = 0; i < b.points(); ++i) {
    chain.clear();
    for (std::uint32_t q = b.patch[i]; q != LightBounce::kNoParent; q = b.parent[q]) chain.push_back(q);
    for (std::uint32_t e = b.offsets[i]; e < b.offsets[i + 1]; ++e) {
      const int r = level[b.source[e]] - offset;
      if (r <= 0) {
        out.source.push_back(b.source[e]);
        out.weight.push_back(b.weight[e]);
      } else {
        const std::uint32_t q = chain[std::min<std::size_t>(std::size_t(r), chain.size() - 1)];
        rows[q].emplace_back(b.source[e], double(b.weight[e]) / members[q]);
      }
    }
    out.offsets.push_back(std::uint32_t(out.source.size()));
  }
  out.cluster_offsets.assign(1, 0);
  for (auto& row : rows) {
    std::sort(row.begin(), row.end());
    for (std::size_t k = 0; k < row.size();) {
      double w = 0;
      const std::uint32_t src = row[k].first;
      for (; k < row.size() && row[k].first == src; ++k) w += row[k].second;
      const float h = glm::unpackHalf1x16(glm::packHalf1x16(float(w)));
      if (h > 0.0f) {
        out.cluster_source.push_back(src);
        out.cluster_weight.push_back(h);
      }
    }
    out.cluster_offsets.push_back(std::uint32_t(out.cluster_source.size()));
  }
  if (out.cluster_source.empty()) out.cluster_offsets.clear();  // nothing moved: no cluster rows (a version-8 file)
  return out;
}

namespace {
// Each patch's points (children come before their parents).
std::vector<std::uint32_t> patch_members(const LightBounce& b) {
  std::vector<std::uint32_t> members(b.patches, 0);
  for (std::uint32_t p : b.patch) ++members[p];
  for (std::uint32_t p = 0; p < b.patches; ++p)
    if (b.parent[p] != LightBounce::kNoParent) members[b.parent[p]] += members[p];
  return members;
}

// Each patch's radiance, the mean of its points' (the sums go up the levels
// in one pass).
template <class Radiance>
void patch_means(const LightBounce& b, const std::vector<std::uint32_t>& members, const Radiance& radiance,
                 std::vector<glm::dvec3>& mean) {
  mean.assign(b.patches, glm::dvec3(0.0));
  for (std::size_t i = 0; i < b.points(); ++i) mean[b.patch[i]] += glm::dvec3(radiance[i]);
  for (std::uint32_t p = 0; p < b.patches; ++p)
    if (b.parent[p] != LightBounce::kNoParent) mean[b.parent[p]] += mean[p];
  for (std::uint32_t p = 0; p < b.patches; ++p) mean[p] /= double(members[p]);
}
}  // namespace

std::vector<glm::vec3> light_bounce_at_probes(const LightBounce& b, std::span<const glm::vec3> leaving) {
  if (b.probes.empty()) throw Error("light bounce: the operator has no probe rows (prt precompute --probes)");
  if (leaving.size() != b.points())
    throw Error(fmt::format("light bounce: {} radiances for {} points", leaving.size(), b.points()));
  std::vector<glm::dvec3> mean;
  patch_means(b, patch_members(b), leaving, mean);
  const std::size_t nc = std::size_t(b.probes.bands) * std::size_t(b.probes.bands);
  std::vector<glm::vec3> out(b.probes.probes() * nc);
  tbb::parallel_for(std::size_t(0), b.probes.probes(), [&](std::size_t q) {
    std::vector<glm::dvec3> c(nc, glm::dvec3(0.0));
    for (std::uint32_t e = b.probes.offsets[q]; e < b.probes.offsets[q + 1]; ++e)
      for (std::size_t k = 0; k < nc; ++k) c[k] += double(b.probes.weight[e * nc + k]) * mean[b.probes.source[e]];
    for (std::size_t k = 0; k < nc; ++k) out[q * nc + k] = glm::vec3(c[k]);
  });
  return out;
}

std::vector<glm::vec3> light_bounce(const LightBounce& b, std::span<const glm::vec3> direct,
                                    std::span<const glm::vec3> albedo) {
  const std::size_t P = b.points();
  if (direct.size() != P || albedo.size() != P)
    throw Error(fmt::format("light bounce: {} points, {} direct radiances and {} albedos (expected as many of each)", P,
                            direct.size(), albedo.size()));
  std::vector<glm::dvec3> emitted(direct.begin(), direct.end()), patch_mean(b.patches), pushed(b.patches), next(P),
      total(P, glm::dvec3(0.0));
  const std::vector<std::uint32_t> members = patch_members(b);
  const auto row = [&](std::span<const std::uint32_t> offsets, std::span<const std::uint32_t> source,
                       std::span<const float> weight, std::size_t i) {
    glm::dvec3 e(0.0);
    for (std::uint32_t q = offsets[i]; q < offsets[i + 1]; ++q) e += double(weight[q]) * patch_mean[source[q]];
    return e;
  };
  for (int k = 0; k < b.bounces; ++k) {
    patch_means(b, members, emitted, patch_mean);
    // The clusters' rows, pushed down the levels (parents first) to the finest.
    std::fill(pushed.begin(), pushed.end(), glm::dvec3(0.0));
    if (!b.cluster_offsets.empty()) {
      tbb::parallel_for(std::uint32_t(0), b.patches, [&](std::uint32_t q) {
        pushed[q] = row(b.cluster_offsets, b.cluster_source, b.cluster_weight, q);
      });
      for (std::uint32_t q = b.patches; q-- > 0;)
        if (b.parent[q] != LightBounce::kNoParent) pushed[q] += pushed[b.parent[q]];
    }
    tbb::parallel_for(std::size_t(0), P, [&](std::size_t i) {
      const glm::dvec3 e = row(b.offsets, b.source, b.weight, i) + pushed[b.patch[i]];
      next[i] = glm::dvec3(albedo[i]) / std::numbers::pi * e;
    });
    for (std::size_t i = 0; i < P; ++i) total[i] += next[i];
    emitted.swap(next);
  }
  return std::vector<glm::vec3>(total.begin(), total.end());
}

}  // namespace prt
