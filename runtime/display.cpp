// The CPU version of the display pass (exposure, tone map). See prt/render.h.
#include <prt/render.h>

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

}  // namespace prt
