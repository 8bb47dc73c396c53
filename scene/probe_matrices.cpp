// Probe volumes (prt/probes.h; docs/PROBES.md): each probe's SH transfer
// matrix and their file (prt export --matrices).
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

// ---- the SH matrices' file (prt export --matrices; docs/PROBES.md) -----------------------
// (The probe volume's own file is a section family of the transfer format:
// scene/transfer_io_probes.cpp.)

namespace {

class Out {
 public:
  void raw(const void* data, std::size_t n) {
    const std::size_t at = bytes.size();
    bytes.resize(at + n);
    if (n > 0) std::memcpy(bytes.data() + at, data, n);
  }
  template <typename T>
  void put(const T& v) {
    raw(&v, sizeof(T));
  }
  std::vector<unsigned char> bytes;
};

}  // namespace

// ---- SH matrices ---------------------------------------------------------------------------

std::vector<float> probe_sh_matrices(const ProbeTransfer& t, int in_bands, int& channels) {
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw Error("probe volume: " + p);
  if (in_bands < 1 || in_bands > kMaxProbeMatrixBands)
    throw Error(fmt::format("probe SH matrices: {} input bands (1 to {})", in_bands, kMaxProbeMatrixBands));
  const int r = t.cube_res, no = sh::num_coeffs(t.bands), ni = sh::num_coeffs(in_bands);
  const int big = std::max(t.bands, in_bands);
  const std::size_t per = std::size_t(no) * std::size_t(ni);
  const std::size_t per_face = (4 * std::size_t(r) * std::size_t(r) - 1) / 3, nodes = 6 * per_face;
  // Per node: the integral of Y_k Y_j over its texels (4 x 4 directions a
  // finest texel, one per sub-texel, each a 16th of its solid angle).
  std::vector<double> node(nodes * per, 0.0);
  const auto sub_direction = [&](int face, int u, int v, int q) {
    return glm::normalize(cube_direction(face, 2.0 * (u + ((q & 3) + 0.5) / 4) / r - 1.0, 2.0 * (v + ((q >> 2) + 0.5) / 4) / r - 1.0));
  };
  std::vector<double> y(static_cast<std::size_t>(sh::num_coeffs(big)));
  for (int face = 0; face < 6; ++face)
    for (int v = 0; v < r; ++v)
      for (int u = 0; u < r; ++u) {
        const double w = cube_texel_solid_angle(u, v, r) / 16.0;
        double* nd = node.data() + std::size_t(probe_node_id(r, face, 0, u, v)) * per;
        for (int q = 0; q < 16; ++q) {
          const glm::dvec3 d = sub_direction(face, u, v, q);
          sh::eval(big, d.x, d.y, d.z, y.data());
          for (int k = 0; k < no; ++k)
            for (int j = 0; j < ni; ++j) nd[std::size_t(k) * ni + std::size_t(j)] += w * y[std::size_t(k)] * y[std::size_t(j)];
        }
      }
  for (int face = 0; face < 6; ++face)
    for (int l = 1; (r >> l) >= 1; ++l)
      for (int yy = 0; yy < (r >> l); ++yy)
        for (int xx = 0; xx < (r >> l); ++xx) {
          double* dst = node.data() + std::size_t(probe_node_id(r, face, l, xx, yy)) * per;
          for (int q = 0; q < 4; ++q) {
            const double* src = node.data() + std::size_t(probe_node_id(r, face, l - 1, 2 * xx + (q & 1), 2 * yy + (q >> 1))) * per;
            for (std::size_t i = 0; i < per; ++i) dst[i] += src[i];
          }
        }
  std::vector<double> whole(per, 0.0);
  for (int face = 0; face < 6; ++face) {
    const int top = std::countr_zero(unsigned(r));
    const double* root = node.data() + std::size_t(probe_node_id(r, face, top, 0, 0)) * per;
    for (std::size_t i = 0; i < per; ++i) whole[i] += root[i];
  }
  channels = t.mode == TransferMode::Interreflected ? t.channels : 1;
  const std::size_t P = t.probes(), stride = std::size_t(channels) * per;
  std::vector<float> out(P * stride, 0.0f);
  const std::vector<std::uint32_t> slots = t.stored_slots();
  const int nb = t.mode == TransferMode::Interreflected ? sh::num_coeffs(t.bounce_bands) : 0;
  std::vector<double> m(per);
  for (std::size_t p = 0; p < P; ++p) {
    if (t.state[p] == ProbeState::Invalid) continue;
    if (t.state[p] == ProbeState::Sky) {
      m = whole;
    } else {
      const std::size_t s = slots[p];
      std::fill(m.begin(), m.end(), 0.0);
      for (std::uint64_t i = t.vis_offsets[s]; i < t.vis_offsets[s + 1]; ++i) {
        const double* src = node.data() + std::size_t(t.vis_nodes[i]) * per;
        for (std::size_t q = 0; q < per; ++q) m[q] += src[q];
      }
      if (t.vis_complement[s])
        for (std::size_t q = 0; q < per; ++q) m[q] = whole[q] - m[q];
      for (std::uint64_t i = t.partial_offsets[s]; i < t.partial_offsets[s + 1]; ++i) {
        const std::size_t id = t.partial_nodes[i], face = id / per_face, at = id - face * per_face;
        const int u = int(at % std::size_t(r)), v = int(at / std::size_t(r));
        const double w = cube_texel_solid_angle(u, v, r) / 16.0;
        for (int q = 0; q < 16; ++q)
          if ((t.partial_mask[i] >> q) & 1u) {
            const glm::dvec3 d = sub_direction(int(face), u, v, q);
            sh::eval(big, d.x, d.y, d.z, y.data());
            for (int k = 0; k < no; ++k)
              for (int j = 0; j < ni; ++j) m[std::size_t(k) * ni + std::size_t(j)] += w * y[std::size_t(k)] * y[std::size_t(j)];
          }
      }
    }
    for (int c = 0; c < channels; ++c) {
      float* dst = out.data() + p * stride + std::size_t(c) * per;
      for (std::size_t q = 0; q < per; ++q) dst[q] = float(m[q]);
      if (nb > 0 && t.state[p] == ProbeState::Stored) {
        const float* B = t.bounce.data() + std::size_t(slots[p]) * t.bounce_floats_per_probe() +
                         (t.channels == 1 ? 0 : std::size_t(c) * std::size_t(no) * std::size_t(nb));
        for (int k = 0; k < no; ++k)
          for (int j = 0; j < std::min(ni, nb); ++j) dst[std::size_t(k) * ni + std::size_t(j)] += B[std::size_t(k) * nb + std::size_t(j)];
      }
    }
  }
  return out;
}

void write_probe_matrices(const std::string& path, const ProbeTransfer& t, const std::vector<float>& matrices,
                          int in_bands, int channels) {
  const std::size_t no = std::size_t(sh::num_coeffs(t.bands)), ni = std::size_t(sh::num_coeffs(in_bands));
  PRT_CHECK(matrices.size() == t.probes() * std::size_t(channels) * no * ni);
  Out o;
  o.raw("PRTPMAT1", 8);
  o.put(std::uint32_t(t.probes()));
  for (int a = 0; a < 3; ++a) o.put(std::uint32_t(t.grid.dims[std::size_t(a)]));
  for (int a = 0; a < 3; ++a) o.put(t.grid.min[a]);
  for (int a = 0; a < 3; ++a) o.put(t.grid.max[a]);
  o.put(std::uint32_t(no));
  o.put(std::uint32_t(ni));
  o.put(std::uint32_t(channels));
  o.put(std::uint32_t(0));
  for (std::size_t p = 0; p < t.probes(); ++p) {
    o.put(t.positions[p]);
    o.put(std::uint32_t(t.state[p]));
  }
  o.raw(matrices.data(), matrices.size() * sizeof(float));
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f.write(reinterpret_cast<const char*>(o.bytes.data()), std::streamsize(o.bytes.size()));
    f.close();
    if (!f) throw Error(path + ": write failed");
  });
}

}  // namespace prt
