// The lights' bounce operator (prt/light_bounce.h; docs/LIGHTS.md "Bounce").
#include <prt/light_bounce.h>

#include <prt/error.h>

#include <fmt/format.h>
#include <glm/gtc/packing.hpp>
#include <tbb/parallel_for.h>

#include <cmath>
#include <numbers>

namespace prt {

std::size_t LightBounce::bytes() const {
  // The weights as a file stores them: 16-bit halves (docs/FORMAT.md "Light-bounce operator").
  return (patch.size() + parent.size() + offsets.size() + source.size()) * sizeof(std::uint32_t) +
         weight.size() * sizeof(std::uint16_t);
}

std::string light_bounce_problem(const LightBounce& b, std::size_t points) {
  if (b.bounces == 0) {
    if (b.patches != 0 || !b.patch.empty() || !b.parent.empty() || !b.offsets.empty() || !b.source.empty() ||
        !b.weight.empty())
      return "a light-bounce operator of 0 bounces holds arrays";
    return "";
  }
  if (b.bounces < 0 || b.bounces > kMaxLightBounces)
    return fmt::format("light bounce: {} bounces (1 to {})", b.bounces, kMaxLightBounces);
  if (b.patch.size() != points) return fmt::format("light bounce: {} patch indices for {} points", b.patch.size(), points);
  if (b.offsets.size() != points + 1)
    return fmt::format("light bounce: {} row offsets for {} points (expected {})", b.offsets.size(), points, points + 1);
  if (b.weight.size() != b.source.size())
    return fmt::format("light bounce: {} sources and {} weights", b.source.size(), b.weight.size());
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
  if (b.offsets.front() != 0 || b.offsets.back() != b.source.size())
    return fmt::format("light bounce: row offsets run from {} to {} over {} entries", b.offsets.front(), b.offsets.back(),
                       b.source.size());
  // Every offset before any row is read: non-decreasing up to entries(), no
  // row then reaches past the entries.
  for (std::size_t i = 0; i < points; ++i)
    if (b.offsets[i + 1] < b.offsets[i]) return fmt::format("light bounce: row {}'s offsets decrease", i);
  for (std::size_t i = 0; i < points; ++i) {
    for (std::uint32_t e = b.offsets[i]; e < b.offsets[i + 1]; ++e) {
      if (b.source[e] >= b.patches)
        return fmt::format("light bounce: row {} names patch {} of {}", i, b.source[e], b.patches);
      if (e > b.offsets[i] && b.source[e] <= b.source[e - 1])
        return fmt::format("light bounce: row {}'s patches do not increase", i);
      if (!(b.weight[e] >= 0.0f) || !std::isfinite(b.weight[e]))
        return fmt::format("light bounce: row {} has the weight {}", i, b.weight[e]);
      if (glm::unpackHalf1x16(glm::packHalf1x16(b.weight[e])) != b.weight[e])
        return fmt::format("light bounce: row {} has the weight {}, not a half-precision value", i, b.weight[e]);
    }
  }
  return "";
}

std::vector<glm::vec3> light_bounce(const LightBounce& b, std::span<const glm::vec3> direct,
                                    std::span<const glm::vec3> albedo) {
  const std::size_t P = b.points();
  if (direct.size() != P || albedo.size() != P)
    throw Error(fmt::format("light bounce: {} points, {} direct radiances and {} albedos (expected as many of each)", P,
                            direct.size(), albedo.size()));
  std::vector<glm::dvec3> emitted(direct.begin(), direct.end()), patch_mean(b.patches), next(P), total(P, glm::dvec3(0.0));
  std::vector<std::uint32_t> members(b.patches, 0);
  for (std::uint32_t p : b.patch) ++members[p];
  for (std::uint32_t p = 0; p < b.patches; ++p)
    if (b.parent[p] != LightBounce::kNoParent) members[b.parent[p]] += members[p];
  for (int k = 0; k < b.bounces; ++k) {
    // Each patch's radiance: the mean of its points' (children come before
    // their parents: the sums go up the levels in one pass).
    std::fill(patch_mean.begin(), patch_mean.end(), glm::dvec3(0.0));
    for (std::size_t i = 0; i < P; ++i) patch_mean[b.patch[i]] += emitted[i];
    for (std::uint32_t p = 0; p < b.patches; ++p)
      if (b.parent[p] != LightBounce::kNoParent) patch_mean[b.parent[p]] += patch_mean[p];
    for (std::uint32_t p = 0; p < b.patches; ++p) patch_mean[p] /= double(members[p]);
    tbb::parallel_for(std::size_t(0), P, [&](std::size_t i) {
      glm::dvec3 e(0.0);
      for (std::uint32_t q = b.offsets[i]; q < b.offsets[i + 1]; ++q) e += double(b.weight[q]) * patch_mean[b.source[q]];
      next[i] = glm::dvec3(albedo[i]) / std::numbers::pi * e;
    });
    for (std::size_t i = 0; i < P; ++i) total[i] += next[i];
    emitted.swap(next);
  }
  return std::vector<glm::vec3>(total.begin(), total.end());
}

}  // namespace prt
