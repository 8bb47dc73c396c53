// Probe volumes (prt/probes.h; docs/PROBES.md "Relighting"): ProbeRelighter,
// each stored probe's incident light from its visibility under a map.
#include <prt/probes.h>

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/hash.h>
#include <prt/io.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/sun.h>

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

// ---- relighting ------------------------------------------------------------------------

namespace {

// The texel of direction d in a cube of face size r: face * r^2 + v * r + u;
// *at: where in it, x + 256 y in 1/256ths of the texel.
std::size_t cube_texel(const glm::dvec3& d, int r, std::uint16_t* at = nullptr) {
  double s = 0, t = 0;
  const int face = cube_face_coords(d, s, t);
  const double fu = std::clamp((s + 1) * 0.5 * r, 0.0, double(r) - 1e-9), fv = std::clamp((t + 1) * 0.5 * r, 0.0, double(r) - 1e-9);
  const int u = int(fu), v = int(fv);
  if (at) *at = std::uint16_t(std::min(255, int((fu - u) * 256)) + 256 * std::min(255, int((fv - v) * 256)));
  return (std::size_t(face) * r + std::size_t(v)) * r + std::size_t(u);
}

// A bright pixel's share of each sub-texel of its texel (bit 4 sy + sx of
// a partial texel's mask), from where it lies (`at`, as cube_texel gives
// it): bilinear between the sub-texels' centres, clamped at the texel's
// border. Summed over a mask's visible sub-texels, the visible area of a
// sub-texel-sized box at the pixel (a sun that an edge half hides gets
// half its light, not all or nothing). Up to 4 (cell, weight) pairs.
void sub_texel_weights(std::uint16_t at, int cell[4], float weight[4]) {
  const float x = std::clamp(float(at & 255u) / 64.0f - 0.5f, 0.0f, 3.0f), y = std::clamp(float(at >> 8) / 64.0f - 0.5f, 0.0f, 3.0f);
  const int x0 = std::min(int(x), 2), y0 = std::min(int(y), 2);
  const float a = x - float(x0), b = y - float(y0);
  cell[0] = 4 * y0 + x0;
  cell[1] = cell[0] + 1;
  cell[2] = cell[0] + 4;
  cell[3] = cell[0] + 5;
  weight[0] = (1 - a) * (1 - b);
  weight[1] = a * (1 - b);
  weight[2] = (1 - a) * b;
  weight[3] = a * b;
}

// Bilinear lookup in a cube of face n (within the face, clamped at its edges).
glm::vec3 cube_bilinear(const std::vector<glm::vec3>& cube, int n, const glm::dvec3& d) {
  double s = 0, t = 0;
  const int face = cube_face_coords(d, s, t);
  const double fu = std::clamp((s + 1) * 0.5 * n - 0.5, 0.0, double(n - 1)), fv = std::clamp((t + 1) * 0.5 * n - 0.5, 0.0, double(n - 1));
  const int u0 = std::min(int(fu), n - 2 < 0 ? 0 : n - 2), v0 = std::min(int(fv), n - 2 < 0 ? 0 : n - 2);
  const int u1 = std::min(u0 + 1, n - 1), v1 = std::min(v0 + 1, n - 1);
  const float a = float(fu - u0), b = float(fv - v0);
  const glm::vec3* f = cube.data() + std::size_t(face) * std::size_t(n) * std::size_t(n);
  const auto at = [&](int u, int v) { return f[std::size_t(v) * std::size_t(n) + std::size_t(u)]; };
  return (1 - b) * ((1 - a) * at(u0, v0) + a * at(u1, v0)) + b * ((1 - a) * at(u0, v1) + a * at(u1, v1));
}

// One probe's SH (before the bounce): its nodes' sums (or the whole minus
// them) plus its partial texels. Inlined into relight_range's clones (AVX2
// where the CPU has it).
struct ProbeSums {
  const ProbeTransfer* t;
  const float* sums;
  const float* total;  // stride floats
  const std::int32_t* cell_slot;
  const float* cell_sums;
  std::size_t stride, nodes_per_face, r;
};

constexpr int kPopcount4[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};

inline int popcount16(std::uint16_t m) {
  return kPopcount4[m & 15] + kPopcount4[(m >> 4) & 15] + kPopcount4[(m >> 8) & 15] + kPopcount4[m >> 12];
}

// Adds `from` x f (or 1) into `to`, `stride` floats; W: 8-float vectors (GCC
// and Clang vector extensions: one AVX op, or two SSE ops in the baseline
// clone).
typedef float Float8 __attribute__((vector_size(32)));
typedef float Float8Unaligned __attribute__((vector_size(32), aligned(4), may_alias));

template <std::size_t W>
struct Lanes {
  Float8 v[W];
  void load(const float* p) {
    for (std::size_t i = 0; i < W; ++i) v[i] = reinterpret_cast<const Float8Unaligned*>(p)[i];
  }
  void add(const float* p) {
    for (std::size_t i = 0; i < W; ++i) v[i] += reinterpret_cast<const Float8Unaligned*>(p)[i];
  }
  void add(const float* p, float f) {
    for (std::size_t i = 0; i < W; ++i) v[i] += reinterpret_cast<const Float8Unaligned*>(p)[i] * f;
  }
  void sub(const float* p) {
    for (std::size_t i = 0; i < W; ++i) v[i] -= reinterpret_cast<const Float8Unaligned*>(p)[i];
  }
};

// The same for any stride (a multiple of 8), in loops.
struct AnyLanes {
  std::size_t n;
  float v[8 * 8 * 3 + 8] = {};  // nc <= 64 (8 bands), padded
  void load(const float* p) { std::copy_n(p, n, v); }
  void add(const float* p) {
    for (std::size_t j = 0; j < n; ++j) v[j] += p[j];
  }
  void add(const float* p, float f) {
    for (std::size_t j = 0; j < n; ++j) v[j] += p[j] * f;
  }
  void sub(const float* p) {
    for (std::size_t j = 0; j < n; ++j) v[j] -= p[j];
  }
};

// One probe's SH (before the bounce): its nodes' sums (or the whole minus
// them) plus its partial texels: a texel without bright pixels by its
// visible fraction, one with them by its visible sub-texels' sums (at most
// 8 adds: the texel minus the hidden ones when fewer). Inlined into
// relight_range's clones (AVX2 where the CPU has it).
template <class L>
__attribute__((always_inline)) inline void probe_sums(const ProbeSums& c, std::size_t s, L& acc, L& part, float* out) {
  const ProbeTransfer& t = *c.t;
  const std::size_t stride = c.stride;
  {
    // Two chains of adds (the adds' latency, not the loads, bounds one).
    L other = acc;
    std::uint64_t i = t.vis_offsets[s];
    for (; i + 1 < t.vis_offsets[s + 1]; i += 2) {
      acc.add(c.sums + std::size_t(t.vis_nodes[i]) * stride);
      other.add(c.sums + std::size_t(t.vis_nodes[i + 1]) * stride);
    }
    if (i < t.vis_offsets[s + 1]) acc.add(c.sums + std::size_t(t.vis_nodes[i]) * stride);
    acc.add(reinterpret_cast<const float*>(&other.v[0]));
  }
  for (std::uint64_t i = t.partial_offsets[s]; i < t.partial_offsets[s + 1]; ++i) {
    const std::size_t id = t.partial_nodes[i];
    const std::size_t face = std::size_t(id >= c.nodes_per_face) + std::size_t(id >= 2 * c.nodes_per_face) +
                             std::size_t(id >= 3 * c.nodes_per_face) + std::size_t(id >= 4 * c.nodes_per_face) +
                             std::size_t(id >= 5 * c.nodes_per_face);  // id / nodes_per_face, without a division
    const std::size_t texel = face * c.r * c.r + (id - face * c.nodes_per_face);
    const std::uint16_t mask = t.partial_mask[i];
    const int visible = popcount16(mask);
    const std::int32_t slot = c.cell_slot[texel];
    if (slot < 0) {
      part.add(c.sums + id * stride, float(visible) / 16.0f);
      continue;
    }
    const float* cells = c.cell_sums + std::size_t(slot) * 16 * stride;
    if (visible <= 8) {
      for (unsigned m = mask; m != 0; m &= m - 1) part.add(cells + std::size_t(__builtin_ctz(m)) * stride);
    } else {
      part.add(c.sums + id * stride);
      for (unsigned m = std::uint16_t(~mask); m != 0; m &= m - 1) part.sub(cells + std::size_t(__builtin_ctz(m)) * stride);
    }
  }
  const float* part_v = reinterpret_cast<const float*>(&part.v[0]);
  if (t.vis_complement[s]) {
    L res = acc;
    res.load(c.total);
    res.add(part_v);
    res.sub(reinterpret_cast<const float*>(&acc.v[0]));
    std::memcpy(out, res.v, stride * sizeof(float));
  } else {
    acc.add(part_v);
    std::memcpy(out, acc.v, stride * sizeof(float));
  }
}

// The map, downsampled by an integer factor f (solid-angle weighted sums of
// f x f blocks) to about 16 pixels across a visibility texel of a cube of
// face `r`: each block's direction, power and radiance, and a lookup from a
// direction to its block (the smooth cube is resampled from it).
struct MapBlocks {
  std::vector<glm::vec3> radiance;  // per block, in grid order
  std::vector<glm::vec3> dirs;      // unit
  std::vector<glm::vec3> power;     // radiance x solid angle
  std::function<std::size_t(const glm::dvec3&)> block_of;
};

MapBlocks map_blocks(const EnvMap& map, int r) {
  MapBlocks b;
  std::vector<glm::vec3>& radiance = b.radiance;
  std::function<std::size_t(const glm::dvec3&)>& block_of = b.block_of;
  const auto add_block = [&](const glm::dvec3& dir, double omega, const glm::dvec3& power) {
    radiance.push_back(omega > 0 ? glm::vec3(power / omega) : glm::vec3(0.0f));
    b.dirs.push_back(glm::vec3(glm::length(dir) > 0 ? glm::normalize(dir) : glm::dvec3(0, 0, 1)));
    b.power.push_back(glm::vec3(power));
  };
  if (map.is_cube()) {
    const int N = map.width;
    int f = 1;
    while (N % (2 * f) == 0 && N / (2 * f) >= 2 * r) f *= 2;
    const int nb = N / f;
    for (int face = 0; face < 6; ++face)
      for (int by = 0; by < N; by += f)
        for (int bx = 0; bx < N; bx += f) {
          glm::dvec3 dir(0.0), power(0.0);
          double omega = 0;
          for (int y = by; y < by + f; ++y)
            for (int x = bx; x < bx + f; ++x) {
              const double w = cube_texel_solid_angle(x, y, N);
              const float* c = map.rgb.data() + ((std::size_t(face) * N + std::size_t(y)) * N + std::size_t(x)) * 3;
              dir += cube_texel_direction(face, x, y, N) * w;
              power += glm::dvec3(c[0], c[1], c[2]) * w;
              omega += w;
            }
          add_block(dir, omega, power);
        }
    block_of = [nb](const glm::dvec3& d) { return cube_texel(d, nb); };
  } else {
    const int W = map.width, H = map.height;
    int f = 1;
    while (W % (2 * f) == 0 && H % (2 * f) == 0 && W / (2 * f) >= 16 * r) f *= 2;
    const int wb = W / f, hb = H / f;
    for (int by = 0; by < H; by += f)
      for (int bx = 0; bx < W; bx += f) {
        glm::dvec3 dir(0.0), power(0.0);
        double omega = 0;
        for (int y = by; y < by + f; ++y)
          for (int x = bx; x < bx + f; ++x) {
            const double w = latlong_pixel_solid_angle(y, W, H);
            const float* c = map.rgb.data() + (std::size_t(y) * W + std::size_t(x)) * 3;
            dir += latlong_direction(x + 0.5, y + 0.5, W, H) * w;
            power += glm::dvec3(c[0], c[1], c[2]) * w;
            omega += w;
          }
        add_block(dir, omega, power);
      }
    block_of = [wb, hb](const glm::dvec3& d) {
      double px = 0, py = 0;
      latlong_pixel(d, wb, hb, px, py);
      const int x = std::clamp(int(std::floor(px)), 0, wb - 1), y = std::clamp(int(std::floor(py)), 0, hb - 1);
      return std::size_t(y) * std::size_t(wb) + std::size_t(x);
    };
  }
  return b;
}

// The bright pixels (prt/sun.h, bright_cells): radiance over
// kProbeBrightRatio times the map's mean and kProbeLocalRatio times the
// mean around them (8 lookups 4 texels away: a sun up to a few degrees
// wide, not the inside of a bright window), the brightest 1/64 of the
// pixels at most, in increasing order. They are splatted exactly each
// frame; the rest is resampled.
std::vector<std::uint32_t> bright_blocks(const MapBlocks& blocks, int r) {
  std::vector<float> luminance(blocks.radiance.size());
  for (std::size_t i = 0; i < luminance.size(); ++i) luminance[i] = abs_luminance(blocks.radiance[i]);
  double power = 0;
  for (const glm::vec3& p : blocks.power) power += double(abs_luminance(p));
  SphereCells cells;
  cells.luminance = luminance;
  cells.power = power;
  cells.direction = [&](std::size_t i) { return glm::dvec3(blocks.dirs[i]); };
  cells.cell_of = blocks.block_of;
  cells.ring_step = 8.0 / r;  // about 4 texels at a face's centre, in radians
  return bright_cells(cells);
}

}  // namespace

ProbeRelighter::ProbeRelighter(const ProbeTransfer& t, const EnvMap& map) : t_(t) {
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw Error("probe volume: " + p);
  require_finite(map);
  nc_ = sh::num_coeffs(t.bands);
  stride_ = (std::size_t(nc_) * 3 + 7) / 8 * 8;
  const int r = t.cube_res;
  levels_ = std::countr_zero(unsigned(r)) + 1;  // sizes r, r/2, ..., 1
  level_offset_.resize(std::size_t(levels_) + 1, 0);
  for (int l = 0; l < levels_; ++l)
    level_offset_[std::size_t(l) + 1] = level_offset_[std::size_t(l)] + std::size_t(r >> l) * std::size_t(r >> l);
  nodes_per_face_ = level_offset_.back();
  // Nodes on 64-byte boundaries (a 3-band node is two cache lines, not three).
  sums_.assign(6 * nodes_per_face_ * stride_ + 16, 0.0f);
  sums_at_ = std::size_t((64 - reinterpret_cast<std::uintptr_t>(sums_.data()) % 64) % 64 / sizeof(float));
  total_.assign(std::size_t(nc_), glm::vec3(0.0f));

  MapBlocks blocks = map_blocks(map, r);
  bright_ = bright_blocks(blocks, r);
  const std::vector<glm::vec3>& radiance = blocks.radiance;
  const auto& block_of = blocks.block_of;
  dirs_ = std::move(blocks.dirs);
  power_ = std::move(blocks.power);

  // The smooth cube (face 2r, map frame): per texel, the mean of 4 x 4
  // nearest lookups of the blocks, bright ones as 0.
  {
    std::vector<glm::vec3> dim = radiance;
    for (std::uint32_t i : bright_) dim[i] = glm::vec3(0.0f);
    const int n = 2 * r;
    smooth_.assign(6 * std::size_t(n) * std::size_t(n), glm::vec3(0.0f));
    tbb::parallel_for(0, 6 * n, [&](int row) {
      const int face = row / n, y = row % n;
      for (int x = 0; x < n; ++x) {
        glm::vec3 sum(0.0f);
        for (int sy = 0; sy < 4; ++sy)
          for (int sx = 0; sx < 4; ++sx)
            sum += dim[block_of(cube_direction(face, 2.0 * (x + (sx + 0.5) / 4) / n - 1.0, 2.0 * (y + (sy + 0.5) / 4) / n - 1.0))];
        smooth_[(std::size_t(face) * n + std::size_t(y)) * n + std::size_t(x)] = sum / 16.0f;
      }
    });
    // The finest texels' quarters (the 2r cube's texels, world frame).
    quarter_dir_.resize(smooth_.size());
    quarter_y_.resize(smooth_.size() * std::size_t(nc_));
    std::vector<double> y(static_cast<std::size_t>(nc_));
    for (int face = 0; face < 6; ++face)
      for (int v = 0; v < n; ++v)
        for (int u = 0; u < n; ++u) {
          const std::size_t q = (std::size_t(face) * n + std::size_t(v)) * n + std::size_t(u);
          const glm::dvec3 d = cube_texel_direction(face, u, v, n);
          quarter_dir_[q] = glm::vec3(d);
          const double w = cube_texel_solid_angle(u, v, n);
          sh::eval(t.bands, d.x, d.y, d.z, y.data());
          for (int k = 0; k < nc_; ++k) quarter_y_[q * std::size_t(nc_) + std::size_t(k)] = float(y[std::size_t(k)] * w);
        }
  }
  if (t.mode == TransferMode::Interreflected) {
    // The bounce side: the map's first bounce_bands bands, point quadrature
    // over the blocks (the light the surfaces get goes through this band
    // limit, docs/PROBES.md).
    const int nb = sh::num_coeffs(t.bounce_bands);
    bounce_sh_.assign(std::size_t(nb), glm::dvec3(0.0));
    std::vector<double> y(static_cast<std::size_t>(nb));
    for (std::size_t i = 0; i < dirs_.size(); ++i) {
      sh::eval(t.bounce_bands, double(dirs_[i].x), double(dirs_[i].y), double(dirs_[i].z), y.data());
      for (int k = 0; k < nb; ++k) bounce_sh_[std::size_t(k)] += y[std::size_t(k)] * glm::dvec3(power_[i]);
    }
    bounce_rot_ = bounce_sh_;
  }

  slot_ = t.stored_slots();
  set_rotation(glm::dmat3(1.0));
}

void ProbeRelighter::set_rotation(const glm::dmat3& R) {
  const int r = t_.cube_res, n = 2 * r;
  const std::size_t stride = stride_, texels = 6 * std::size_t(r) * std::size_t(r);
  const glm::dmat3 Rt = glm::transpose(R);
  // The smooth part: each finest texel's four quarters, sampled in the map
  // frame (R^T d) and weighted by their exact Y_k omega (parallel).
  smooth0_.assign(texels * stride, 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, texels, 512), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t texel = range.begin(); texel < range.end(); ++texel) {
      const std::size_t face = texel / (std::size_t(r) * r), v = (texel / std::size_t(r)) % std::size_t(r), u = texel % std::size_t(r);
      float* out = smooth0_.data() + texel * stride;
      for (int q = 0; q < 4; ++q) {
        const std::size_t i = (face * std::size_t(n) + 2 * v + std::size_t(q >> 1)) * std::size_t(n) + 2 * u + std::size_t(q & 1);
        const glm::vec3 L = cube_bilinear(smooth_, n, Rt * glm::dvec3(quarter_dir_[i]));
        const float* y = quarter_y_.data() + i * std::size_t(nc_);
        for (int k = 0; k < nc_; ++k)
          for (int c = 0; c < 3; ++c) out[std::size_t(k) * 3 + std::size_t(c)] += y[k] * L[c];
      }
    }
  });
  // The bright pixels, exactly: their texel, sub-texel and Y_k(R w) L omega,
  // bucketed by texel (a counting sort, in pixel order within a texel).
  const std::size_t B = bright_.size();
  std::vector<std::uint32_t> texel_of(B);
  std::vector<std::uint16_t> at_of(B);
  std::vector<float> sh_of(B * stride, 0.0f);
  {
    std::vector<double> y(static_cast<std::size_t>(nc_));
    for (std::size_t b = 0; b < B; ++b) {
      const std::uint32_t i = bright_[b];
      const glm::dvec3 d = R * glm::dvec3(dirs_[i]);
      texel_of[b] = std::uint32_t(cube_texel(d, r, &at_of[b]));
      sh::eval(t_.bands, d.x, d.y, d.z, y.data());
      for (int k = 0; k < nc_; ++k)
        for (int c = 0; c < 3; ++c) sh_of[b * stride + std::size_t(k) * 3 + std::size_t(c)] = float(y[std::size_t(k)] * double(power_[i][c]));
    }
  }
  std::vector<std::uint32_t> offset(texels + 1, 0);
  for (std::uint32_t texel : texel_of) ++offset[texel + 1];
  for (std::size_t i = 0; i < texels; ++i) offset[i + 1] += offset[i];
  std::vector<std::uint32_t> order(B);
  {
    std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
    for (std::size_t b = 0; b < B; ++b) order[fill[texel_of[b]]++] = std::uint32_t(b);
  }
  // Texels with bright pixels: the sums of their 16 sub-texels (a 16th of
  // the smooth part each, plus the bright pixels' shares), which partial
  // texels there add up by their masks.
  cell_slot_.assign(texels, -1);
  std::size_t slots = 0;
  for (std::size_t texel = 0; texel < texels; ++texel)
    if (offset[texel + 1] > offset[texel]) cell_slot_[texel] = std::int32_t(slots++);
  cell_sums_.assign(slots * 16 * stride, 0.0f);
  for (std::size_t texel = 0; texel < texels; ++texel) {
    if (cell_slot_[texel] < 0) continue;
    float* cells = cell_sums_.data() + std::size_t(cell_slot_[texel]) * 16 * stride;
    const float* sm = smooth0_.data() + texel * stride;
    for (int q = 0; q < 16; ++q)
      for (std::size_t j = 0; j < stride; ++j) cells[std::size_t(q) * stride + j] = sm[j] / 16.0f;
    for (std::uint32_t i = offset[texel]; i < offset[texel + 1]; ++i) {
      const std::uint32_t b = order[i];
      int cell[4];
      float weight[4];
      sub_texel_weights(at_of[b], cell, weight);
      for (int q = 0; q < 4; ++q)
        for (std::size_t j = 0; j < stride; ++j) cells[std::size_t(cell[q]) * stride + j] += weight[q] * sh_of[std::size_t(b) * stride + j];
    }
  }
  // The pyramid, per face (parallel): level 0 the smooth part plus the
  // bright pixels (in double), each level the sum of its 4 children.
  std::vector<std::vector<double>> face_total(6, std::vector<double>(stride, 0.0));
  tbb::parallel_for(0, 6, [&](int face) {
    std::vector<double> cur(std::size_t(r) * r * stride), next;
    const std::size_t first = std::size_t(face) * r * r;
    for (std::size_t i = 0; i < std::size_t(r) * r; ++i) {
      double* a = cur.data() + i * stride;
      const float* sm = smooth0_.data() + (first + i) * stride;
      for (std::size_t j = 0; j < stride; ++j) a[j] = double(sm[j]);
      for (std::uint32_t b = offset[first + i]; b < offset[first + i + 1]; ++b)
        for (std::size_t j = 0; j < stride; ++j) a[j] += double(sh_of[std::size_t(order[b]) * stride + j]);
    }
    for (int l = 0; l < levels_; ++l) {
      const int size = r >> l;
      float* out = sums_.data() + sums_at_ + (std::size_t(face) * nodes_per_face_ + level_offset_[std::size_t(l)]) * stride;
      for (std::size_t i = 0; i < cur.size(); ++i) out[i] = float(cur[i]);
      if (l + 1 == levels_) {
        face_total[std::size_t(face)] = cur;
        break;
      }
      const int half = size / 2;
      next.assign(std::size_t(half) * half * stride, 0.0);
      for (int v = 0; v < size; ++v)
        for (int u = 0; u < size; ++u) {
          const double* src = cur.data() + (std::size_t(v) * size + std::size_t(u)) * stride;
          double* dst = next.data() + (std::size_t(v / 2) * half + std::size_t(u / 2)) * stride;
          for (std::size_t j = 0; j < stride; ++j) dst[j] += src[j];
        }
      cur.swap(next);
    }
  });
  total_padded_.assign(stride, 0.0f);
  for (std::size_t j = 0; j < stride; ++j) {
    double sum = 0;
    for (int face = 0; face < 6; ++face) sum += face_total[std::size_t(face)][j];
    total_padded_[j] = float(sum);
  }
  for (int k = 0; k < nc_; ++k)
    for (int c = 0; c < 3; ++c) total_[std::size_t(k)][c] = total_padded_[std::size_t(k) * 3 + std::size_t(c)];
  if (!bounce_sh_.empty()) {
    bounce_rot_.resize(bounce_sh_.size());
    sh::Rotation(t_.bounce_bands, R).apply(bounce_sh_, bounce_rot_);
  }
}

std::span<const glm::vec3> ProbeRelighter::sky() const { return total_; }

// Probes [begin, end) (of `probes` when given, else all), their SH to out.
// Compiled for AVX2 and for the baseline; the CPU picks at load time.
__attribute__((target_clones("avx2", "default")))
void ProbeRelighter::relight_range(std::size_t begin, std::size_t end, const std::uint32_t* probes, glm::vec3* out) const {
  const ProbeSums c{&t_, sums_.data() + sums_at_, total_padded_.data(), cell_slot_.data(), cell_sums_.data(), stride_, nodes_per_face_,
                    std::size_t(t_.cube_res)};
  const int nb = t_.bounce.empty() ? 0 : sh::num_coeffs(t_.bounce_bands);
  alignas(32) float sh[8 * 8 * 3 + 8];
  for (std::size_t i = begin; i < end; ++i) {
    const std::size_t probe = probes ? probes[i] : i;
    glm::vec3* o = out + i * std::size_t(nc_);
    const ProbeState st = t_.state[probe];
    if (st == ProbeState::Invalid) {
      std::fill(o, o + nc_, glm::vec3(0.0f));
      continue;
    }
    if (st == ProbeState::Sky) {
      std::copy(total_.begin(), total_.end(), o);
      continue;
    }
    const std::size_t s = slot_[probe];
    if (stride_ == 32) {  // 3 bands
      Lanes<4> acc{}, part{};
      probe_sums(c, s, acc, part, sh);
    } else {
      AnyLanes acc{stride_}, part{stride_};
      probe_sums(c, s, acc, part, sh);
    }
    for (int k = 0; k < nc_; ++k)
      for (int ch = 0; ch < 3; ++ch) o[k][ch] = sh[std::size_t(k) * 3 + std::size_t(ch)];
    if (nb > 0) {
      const float* B = t_.bounce.data() + s * t_.bounce_floats_per_probe();
      for (int ch = 0; ch < 3; ++ch) {
        const float* Bc = B + (t_.channels == 1 ? 0 : std::size_t(ch) * std::size_t(nc_) * std::size_t(nb));
        for (int k = 0; k < nc_; ++k) {
          double v = 0;
          const float* row = Bc + std::size_t(k) * std::size_t(nb);
          for (int j = 0; j < nb; ++j) v += double(row[j]) * bounce_rot_[std::size_t(j)][ch];
          o[k][ch] += float(v);
        }
      }
    }
  }
}

void ProbeRelighter::relight(std::vector<glm::vec3>& out) const {
  const std::size_t P = t_.probes();
  out.resize(P * std::size_t(nc_));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, P, 256), [&](const tbb::blocked_range<std::size_t>& range) {
    relight_range(range.begin(), range.end(), nullptr, out.data());
  });
}

void ProbeRelighter::relight(std::span<const std::uint32_t> probes, std::vector<glm::vec3>& out) const {
  out.resize(probes.size() * std::size_t(nc_));
  for (std::uint32_t p : probes)
    if (p >= t_.probes()) throw Error(fmt::format("probe {} of {}", p, t_.probes()));
  relight_range(0, probes.size(), probes.data(), out.data());
}

}  // namespace prt
