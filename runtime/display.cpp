// The CPU version of the display pass (exposure, tone map). See prt/render.h.
#include <prt/render.h>

#include <prt/filter.h>

#include <algorithm>
#include <cmath>

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

}  // namespace prt
