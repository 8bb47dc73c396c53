// The CPU version of the display pass (exposure, tone map). See prt/render.h.
#include <prt/render.h>

#include <prt/error.h>
#include <prt/filter.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace prt {

float tone_map(float linear, const Display& d) {
  const float v = std::max(linear * float(std::exp2(d.exposure)), 0.0f);
  switch (d.tone_map) {
    case ToneMap::Reinhard: return v / (1.0f + v);
    case ToneMap::Aces: return std::clamp(v * (2.51f * v + 0.03f) / (v * (2.43f * v + 0.59f) + 0.14f), 0.0f, 1.0f);
    case ToneMap::Clamp: break;
  }
  return std::min(v, 1.0f);
}

void tone_map(std::vector<float>& rgb, const Display& d) {
  for (float& v : rgb) v = tone_map(v, d);
}

void finish_frame(std::vector<float>& rgb, const Display& d, bool linear) {
  if (!linear) return tone_map(rgb, d);
  const float gain = float(std::exp2(d.exposure));
  if (gain != 1.0f)
    for (float& v : rgb) v *= gain;
}

double auto_exposure(const std::vector<glm::dvec3>& light) {
  const double peak = sh::peak_diffuse_radiance(light);
  return peak > 0 ? std::clamp(-std::log2(peak), -64.0, 64.0) : 0.0;
}

double frame_exposure(std::span<const float> rgb, std::span<const float> coverage) {
  PRT_CHECK_OP(rgb.size() % 3, ==, 0u);  // RGB triples
  const std::size_t n = rgb.size() / 3;
  if (!coverage.empty()) PRT_CHECK_OP(coverage.size(), ==, n);  // one coverage value a pixel
  const auto gather = [&](bool covered_only) {
    std::vector<float> top;
    top.reserve(n);
    for (std::size_t p = 0; p < n; ++p) {
      if (covered_only && !(coverage[p] >= 0.5f)) continue;
      const float r = rgb[3 * p], g = rgb[3 * p + 1], b = rgb[3 * p + 2];
      if (!std::isfinite(r) || !std::isfinite(g) || !std::isfinite(b)) continue;
      top.push_back(std::max({r, g, b, 0.0f}));
    }
    return top;
  };
  std::vector<float> top = gather(!coverage.empty());
  if (top.empty()) top = gather(false);  // nothing covered: the frame is the background
  if (top.empty()) return 0;
  // The nearest-rank percentile: index floor(q (n - 1)), so that n = 1 gives
  // that pixel and q = 1 the maximum.
  const std::size_t k = std::size_t(kAutoExposurePercentile * double(top.size() - 1));
  std::nth_element(top.begin(), top.begin() + std::ptrdiff_t(k), top.end());
  const double v = top[k];
  return v > 0 ? std::clamp(std::log2(kAutoExposureTarget / v), -kMaxExposureStops, kMaxExposureStops) : 0.0;
}

}  // namespace prt
