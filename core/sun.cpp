// Bright compact sources (prt/sun.h; docs/LIGHTS.md "The sun (`--sun
// auto`)"): the bright-cell test, shared with the probe relighter, and the
// sun split.
#include <prt/sun.h>

#include <prt/error.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <queue>
#include <unordered_set>
#include <utility>

namespace prt {

std::vector<std::uint32_t> bright_cells(const SphereCells& cells) {
  const std::span<const float> luminance = cells.luminance;
  PRT_CHECK(luminance.size() < (std::size_t(1) << 32));
  std::vector<std::uint32_t> bright;
  const float threshold = float(kProbeBrightRatio * cells.power / (4.0 * std::numbers::pi));
  const double step = cells.ring_step;
  const auto local_mean = [&](const glm::dvec3& d) {
    const glm::dvec3 a = std::abs(d.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    const glm::dvec3 t1 = glm::normalize(glm::cross(d, a)), t2 = glm::cross(d, t1);
    double sum = 0;
    for (int q = 0; q < 8; ++q) {
      const double phi = q * std::numbers::pi / 4;
      const std::size_t c = cells.cell_of(glm::normalize(d + step * (std::cos(phi) * t1 + std::sin(phi) * t2)));
      PRT_CHECK_OP(c, <, luminance.size());
      sum += double(luminance[c]);
    }
    return sum / 8;
  };
  for (std::size_t i = 0; i < luminance.size(); ++i) {
    const float l = luminance[i];
    if (l > threshold && double(l) > kProbeLocalRatio * local_mean(cells.direction(i))) bright.push_back(std::uint32_t(i));
  }
  const std::size_t cap = luminance.size() / 64;
  if (bright.size() > cap) {
    std::nth_element(bright.begin(), bright.begin() + std::ptrdiff_t(cap), bright.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return luminance[a] > luminance[b]; });
    bright.resize(cap);
    std::sort(bright.begin(), bright.end());
  }
  return bright;
}

namespace {

// A map's own pixels as cells: index y W + x (lat-long) or (face N + v) N + u
// (cube, face size N).
class MapCells {
 public:
  explicit MapCells(const EnvMap& map) : map_(map), cube_(map.is_cube()), w_(map.width), h_(map.height) {
    if (cube_) {
      omega_.resize(std::size_t(w_) * std::size_t(w_));
      for (int v = 0; v < w_; ++v)
        for (int u = 0; u < w_; ++u) omega_[std::size_t(v) * std::size_t(w_) + std::size_t(u)] = cube_texel_solid_angle(u, v, w_);
    } else {
      omega_.resize(std::size_t(h_));
      for (int y = 0; y < h_; ++y) omega_[std::size_t(y)] = latlong_pixel_solid_angle(y, w_, h_);
    }
    PRT_CHECK_OP(map.pixel_count(), ==, (cube_ ? 6 * omega_.size() : omega_.size() * std::size_t(w_)));
  }

  std::size_t size() const { return map_.pixel_count(); }
  glm::vec3 radiance(std::size_t i) const {
    const float* c = map_.rgb.data() + 3 * i;
    return {c[0], c[1], c[2]};
  }
  double solid_angle(std::size_t i) const { return cube_ ? omega_[i % omega_.size()] : omega_[i / std::size_t(w_)]; }

  glm::dvec3 direction(std::size_t i) const {
    if (cube_) {
      const std::size_t face = i / omega_.size(), t = i % omega_.size();
      return cube_texel_direction(int(face), int(t % std::size_t(w_)), int(t / std::size_t(w_)), w_);
    }
    return latlong_direction(double(i % std::size_t(w_)) + 0.5, double(i / std::size_t(w_)) + 0.5, w_, h_);
  }

  std::size_t cell_of(const glm::dvec3& d) const {
    if (cube_) {
      double s = 0, t = 0;
      const int face = cube_face_coords(d, s, t);
      const int u = std::clamp(int(std::floor((s + 1) * 0.5 * w_)), 0, w_ - 1);
      const int v = std::clamp(int(std::floor((t + 1) * 0.5 * w_)), 0, w_ - 1);
      return (std::size_t(face) * std::size_t(w_) + std::size_t(v)) * std::size_t(w_) + std::size_t(u);
    }
    double px = 0, py = 0;
    latlong_pixel(d, w_, h_, px, py);
    const int x = std::clamp(int(std::floor(px)), 0, w_ - 1), y = std::clamp(int(std::floor(py)), 0, h_ - 1);
    return std::size_t(y) * std::size_t(w_) + std::size_t(x);
  }

  // The distinct 8-neighbours of cell i, itself excluded; returns how many.
  // Lat-long: x wraps at the seam, a row past a pole continues on the far
  // side of it (x + W/2). Cube: a texel past a face's edge is the one its
  // centre's direction falls in.
  int neighbours(std::size_t i, std::size_t out[8]) const {
    int count = 0;
    const auto add = [&](std::size_t j) {
      if (j != i && std::find(out, out + count, j) == out + count) out[count++] = j;
    };
    if (cube_) {
      const std::size_t face = i / omega_.size(), t = i % omega_.size();
      const int u = int(t % std::size_t(w_)), v = int(t / std::size_t(w_));
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu >= 0 && uu < w_ && vv >= 0 && vv < w_) {
            add((face * std::size_t(w_) + std::size_t(vv)) * std::size_t(w_) + std::size_t(uu));
          } else {
            const double s = 2.0 * (uu + 0.5) / w_ - 1.0, tt = 2.0 * (vv + 0.5) / w_ - 1.0;
            add(cell_of(glm::normalize(cube_direction(int(face), s, tt))));
          }
        }
      return count;
    }
    const int x = int(i % std::size_t(w_)), y = int(i / std::size_t(w_));
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        int xx = x + dx, yy = y + dy;
        if (yy < 0 || yy >= h_) {  // over the pole
          yy = yy < 0 ? -1 - yy : 2 * h_ - 1 - yy;
          xx += w_ / 2;
        }
        xx = ((xx % w_) + w_) % w_;
        add(std::size_t(yy) * std::size_t(w_) + std::size_t(xx));
      }
    return count;
  }

 private:
  const EnvMap& map_;
  bool cube_;
  int w_, h_;
  std::vector<double> omega_;  // per row (lat-long) or per texel of a face (cube)
};

// The sun's pixels: the bright cells 8-connected to the brightest one
// (`seed`), brightest first while they fit in kMaxSunSolidAngle. Sorted.
// *capped: whether connected bright cells were left out.
std::vector<std::size_t> grow_sun(const MapCells& cells, std::span<const float> luminance,
                                  const std::vector<std::uint32_t>& bright, std::size_t seed, bool* capped) {
  const auto is_bright = [&](std::size_t i) { return std::binary_search(bright.begin(), bright.end(), std::uint32_t(i)); };
  // Brightest first; between equals the lower index (deterministic).
  const auto dimmer = [&](std::size_t a, std::size_t b) {
    return luminance[a] < luminance[b] || (luminance[a] == luminance[b] && a > b);
  };
  std::priority_queue<std::size_t, std::vector<std::size_t>, decltype(dimmer)> front(dimmer);
  std::unordered_set<std::size_t> seen{seed};
  front.push(seed);
  std::vector<std::size_t> sun;
  double omega = 0;
  *capped = false;
  while (!front.empty()) {
    const std::size_t i = front.top();
    front.pop();
    if (omega + cells.solid_angle(i) > kMaxSunSolidAngle) {
      *capped = true;
      break;
    }
    omega += cells.solid_angle(i);
    sun.push_back(i);
    std::size_t next[8];
    const int n = cells.neighbours(i, next);
    for (int k = 0; k < n; ++k)
      if (is_bright(next[k]) && seen.insert(next[k]).second) front.push(next[k]);
  }
  std::sort(sun.begin(), sun.end());
  return sun;
}

// L_rim: the solid-angle-weighted mean radiance of the pixels 8-adjacent to
// the sun's (sorted) and not in it; *brightest: the largest luminance among
// them. False when there are none.
bool rim_radiance(const MapCells& cells, const std::vector<std::size_t>& sun, glm::dvec3& rim, float* brightest) {
  std::vector<std::size_t> ring;
  for (std::size_t i : sun) {
    std::size_t next[8];
    const int n = cells.neighbours(i, next);
    for (int k = 0; k < n; ++k)
      if (!std::binary_search(sun.begin(), sun.end(), next[k])) ring.push_back(next[k]);
  }
  std::sort(ring.begin(), ring.end());
  ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
  glm::dvec3 sum(0.0);
  double omega = 0;
  *brightest = 0;
  for (std::size_t i : ring) {
    *brightest = std::max(*brightest, abs_luminance(cells.radiance(i)));
    sum += glm::dvec3(cells.radiance(i)) * cells.solid_angle(i);
    omega += cells.solid_angle(i);
  }
  if (!(omega > 0)) return false;
  rim = sum / omega;
  return true;
}

double rec709(const glm::dvec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

}  // namespace

std::optional<SunSplit> split_sun(const EnvMap& map) {
  require_finite(map);
  const MapCells cells(map);
  const std::size_t n = cells.size();
  if (n == 0) return std::nullopt;
  std::vector<float> luminance(n);
  double power = 0;  // luminance x solid angle, in pixel order
  for (std::size_t i = 0; i < n; ++i) {
    luminance[i] = abs_luminance(cells.radiance(i));
    power += double(luminance[i]) * cells.solid_angle(i);
  }
  if (!(power > 0)) return std::nullopt;
  SphereCells sphere;
  sphere.luminance = luminance;
  sphere.power = power;
  sphere.direction = [&](std::size_t i) { return cells.direction(i); };
  sphere.cell_of = [&](const glm::dvec3& d) { return cells.cell_of(d); };
  sphere.ring_step = kSunRingStep;
  const std::vector<std::uint32_t> bright = bright_cells(sphere);
  if (bright.empty()) return std::nullopt;
  std::size_t seed = bright[0];
  for (std::uint32_t b : bright)
    if (luminance[b] > luminance[seed]) seed = b;
  if (cells.solid_angle(seed) > kMaxSunSolidAngle) return std::nullopt;  // a map too coarse for a compact sun

  bool capped = false;
  const std::vector<std::size_t> pixels = grow_sun(cells, luminance, bright, seed, &capped);
  SunSplit split{Sun{}, map};
  Sun& sun = split.sun;
  float rim_peak = 0;
  if (!rim_radiance(cells, pixels, sun.rim, &rim_peak)) return std::nullopt;
  // Cut by the cap: a sun's glow there is far below its peak; an area
  // light's plateau (a studio lamp, a window) is not.
  if (capped && !(double(luminance[seed]) > kProbeLocalRatio * double(rim_peak))) return std::nullopt;

  const glm::vec3 floor(sun.rim);
  glm::dvec3 toward(0.0);
  for (std::size_t i : pixels) {
    float* c = split.sky.rgb.data() + 3 * i;
    const double omega = cells.solid_angle(i);
    glm::dvec3 excess;
    for (int k = 0; k < 3; ++k) {
      const float sky = std::min(c[k], floor[k]);
      excess[k] = (double(c[k]) - double(sky)) * omega;  // >= 0, exact up to the product's rounding
      c[k] = sky;
    }
    sun.irradiance += excess;
    toward += cells.direction(i) * rec709(excess);
    sun.solid_angle += omega;
  }
  sun.pixels = pixels.size();
  const double sun_power = rec709(sun.irradiance);
  if (!(sun_power > 0) || !(glm::length(toward) > 0)) return std::nullopt;
  sun.direction = glm::normalize(toward);
  sun.power_fraction = sun_power / power;
  split.sky.stats = compute_stats(split.sky.rgb.data(), n);
  return split;
}

}  // namespace prt
