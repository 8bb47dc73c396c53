// Probe volumes (prt/probes.h; docs/PROBES.md): the visibility quadtree's
// node ids, the octahedral depth map, and the visibility-aware weights that
// interpolate probes at a point.
#include <prt/probes.h>

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/hash.h>
#include <prt/io.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <limits>


namespace prt {

// ---- the visibility quadtree ------------------------------------------------------------

namespace {

std::size_t level_offset(int r, int level) {
  std::size_t o = 0;
  for (int l = 0; l < level; ++l) o += std::size_t(r >> l) * std::size_t(r >> l);
  return o;
}

}  // namespace

std::uint16_t probe_node_id(int r, int face, int level, int x, int y) {
  const std::size_t per_face = (4 * std::size_t(r) * std::size_t(r) - 1) / 3;
  return std::uint16_t(std::size_t(face) * per_face + level_offset(r, level) + std::size_t(y) * std::size_t(r >> level) +
                       std::size_t(x));
}

std::vector<std::uint16_t> probe_visibility_nodes(std::span<const std::uint32_t> bits, int r, bool& complement) {
  PRT_CHECK(r >= 1 && r <= 64 && std::has_single_bit(unsigned(r)));
  PRT_CHECK(bits.size() * 32 >= std::size_t(6) * r * r);
  const int levels = std::countr_zero(unsigned(r)) + 1;
  // Per face, counts of set bits per node, bottom-up.
  std::vector<std::uint16_t> on, off;
  std::vector<std::uint32_t> count;
  for (int face = 0; face < 6; ++face) {
    count.assign(level_offset(r, levels), 0);
    for (int v = 0; v < r; ++v)
      for (int u = 0; u < r; ++u) {
        const std::size_t i = (std::size_t(face) * r + std::size_t(v)) * r + std::size_t(u);
        count[std::size_t(v) * r + std::size_t(u)] = (bits[i >> 5] >> (i & 31)) & 1u;
      }
    for (int l = 1; l < levels; ++l) {
      const int size = r >> l;
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          std::uint32_t c = 0;
          for (int q = 0; q < 4; ++q)
            c += count[level_offset(r, l - 1) + std::size_t(2 * y + (q >> 1)) * std::size_t(2 * size) + std::size_t(2 * x + (q & 1))];
          count[level_offset(r, l) + std::size_t(y) * size + std::size_t(x)] = c;
        }
    }
    struct Node { int level, x, y; };
    std::vector<Node> stack{{levels - 1, 0, 0}};
    while (!stack.empty()) {
      const Node n = stack.back();
      stack.pop_back();
      const std::uint32_t c = count[level_offset(r, n.level) + std::size_t(n.y) * std::size_t(r >> n.level) + std::size_t(n.x)];
      const std::uint32_t full = std::uint32_t(1) << (2 * n.level);
      if (c == full) on.push_back(probe_node_id(r, face, n.level, n.x, n.y));
      else if (c == 0) off.push_back(probe_node_id(r, face, n.level, n.x, n.y));
      else
        for (int q = 3; q >= 0; --q) stack.push_back({n.level - 1, 2 * n.x + (q & 1), 2 * n.y + (q >> 1)});
    }
  }
  complement = off.size() < on.size();
  return complement ? off : on;
}

// ---- octahedral map ------------------------------------------------------------------

glm::dvec2 octahedral_encode(const glm::dvec3& d) {
  const double s = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
  double x = d.x / s, y = d.y / s;
  if (d.z < 0) {
    const double ox = (1.0 - std::abs(y)) * (x >= 0 ? 1.0 : -1.0), oy = (1.0 - std::abs(x)) * (y >= 0 ? 1.0 : -1.0);
    x = ox;
    y = oy;
  }
  return {x * 0.5 + 0.5, y * 0.5 + 0.5};
}

glm::dvec3 octahedral_decode(const glm::dvec2& uv) {
  double x = uv.x * 2 - 1, y = uv.y * 2 - 1;
  const double z = 1.0 - std::abs(x) - std::abs(y);
  if (z < 0) {
    const double ox = (1.0 - std::abs(y)) * (x >= 0 ? 1.0 : -1.0), oy = (1.0 - std::abs(x)) * (y >= 0 ? 1.0 : -1.0);
    x = ox;
    y = oy;
  }
  return glm::normalize(glm::dvec3(x, y, z));
}

// ---- visibility-aware weights -------------------------------------------------------

double probe_visibility(const ProbeTransfer& t, std::size_t slot, const glm::dvec3& dir, double distance) {
  const int N = t.depth_res;
  const std::uint16_t* m = t.depth.data() + slot * 2 * std::size_t(N) * N;
  const glm::dvec2 uv = octahedral_encode(dir);
  const double fx = uv.x * N - 0.5, fy = uv.y * N - 0.5;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  // Octahedral border: a texel past an edge is its mirror across the edge's midpoint.
  const auto texel = [&](int x, int y) {
    if (x < 0) { x = -x - 1; y = N - 1 - y; }
    else if (x >= N) { x = 2 * N - 1 - x; y = N - 1 - y; }
    if (y < 0) { y = -y - 1; x = N - 1 - x; }
    else if (y >= N) { y = 2 * N - 1 - y; x = N - 1 - x; }
    return std::size_t(std::clamp(y, 0, N - 1)) * N + std::size_t(std::clamp(x, 0, N - 1));
  };
  double mean = 0, mean2 = 0;
  for (int dy = 0; dy <= 1; ++dy)
    for (int dx = 0; dx <= 1; ++dx) {
      const double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
      const std::size_t i = texel(x0 + dx, y0 + dy);
      mean += w * m[2 * i] / 65535.0;
      mean2 += w * m[2 * i + 1] / 65535.0;
    }
  const double cap = t.depth_cap;
  mean *= cap;
  mean2 *= cap * cap;
  if (distance <= mean) return 1.0;
  const double var = std::max(mean2 - mean * mean, 1e-8 * cap * cap);
  const double d = distance - mean;
  double v = var / (var + d * d);
  v = v * v * v;
  if (v < 0.2) v *= v * v / 0.04;  // DDGI's crush: a little light does not leak
  return v;
}

ProbeWeights trilinear_weights(const ProbeGrid& g, const glm::dvec3& p) {
  int i0[3];
  double f[3];
  const glm::dvec3 s = g.spacing();
  for (int a = 0; a < 3; ++a) {
    const int n = g.dims[std::size_t(a)];
    double x = s[a] > 0 ? (p[a] - g.min[a]) / s[a] : 0.0;
    if (!(x >= 0)) x = 0;  // NaN (a query point that is not finite) too: int(NaN) is undefined
    x = std::clamp(x, 0.0, double(n - 1));
    i0[a] = std::min(int(std::floor(x)), n - 2);
    f[a] = x - i0[a];
  }
  ProbeWeights w;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    w.probe[std::size_t(c)] = std::uint32_t(g.index(i0[0] + dx, i0[1] + dy, i0[2] + dz));
    w.weight[std::size_t(c)] = float((dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]));
  }
  w.count = 8;
  return w;
}

ProbeWeights probe_weights(const ProbeTransfer& t, std::span<const std::uint32_t> slots, const glm::dvec3& p,
                           const glm::dvec3& n, const ProbeVisibility& visible) {
  const glm::dvec3 s = t.grid.spacing();
  double smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (s[a] > 0) smallest = std::min(smallest, s[a]);
  if (!std::isfinite(smallest)) smallest = 0;
  const double nl = glm::length(n);
  // The depth moments see a surface point's own surface: look from a
  // tenth of a spacing off it. Traced visibility starts its segments off the
  // surface itself and needs no bias (a bias would carry a point inside a
  // box out through its wall).
  const glm::dvec3 q = nl > 0 && !visible ? p + n / nl * (0.1 * smallest) : p;
  ProbeWeights w = trilinear_weights(t.grid, p);
  PRT_CHECK(slots.size() == t.state.size());
  double sum = 0;
  for (int c = 0; c < 8; ++c) {
    const std::uint32_t probe = w.probe[std::size_t(c)];
    double weight = w.weight[std::size_t(c)];
    if (weight > 0) {
      if (t.state[probe] == ProbeState::Invalid) {
        weight = 0;
      } else if (visible) {
        weight *= visible(glm::dvec3(t.positions[probe]), q);
      } else if (t.state[probe] == ProbeState::Stored) {
        const glm::dvec3 d = q - glm::dvec3(t.positions[probe]);
        const double dist = glm::length(d);
        if (dist > 0) weight *= probe_visibility(t, slots[probe], d / dist, dist);
      }
    }
    w.weight[std::size_t(c)] = float(weight);
    sum += weight;
  }
  const double norm = 1.0 / std::max(sum, kProbeMinWeight);
  for (float& x : w.weight) x = float(x * norm);
  return w;
}

glm::dvec3 lambert_from_sh(std::span<const glm::vec3> sh, int bands, const glm::dvec3& n) {
  const int nc = sh::num_coeffs(bands);
  PRT_CHECK(sh.size() >= std::size_t(nc));
  std::vector<double> y(static_cast<std::size_t>(nc));
  const glm::dvec3 u = glm::normalize(n);
  sh::eval(bands, u.x, u.y, u.z, y.data());
  glm::dvec3 out(0.0);
  for (int l = 0; l < bands; ++l) {
    const double a = sh::clamped_cosine_factor(l) / M_PI;
    for (int m = -l; m <= l; ++m) {
      const int k = sh::index(l, m);
      out += a * y[std::size_t(k)] * glm::dvec3(sh[std::size_t(k)]);
    }
  }
  return out;
}

}  // namespace prt
