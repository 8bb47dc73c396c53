// Haar wavelets on cube maps and the per-frame environment resampler
// (see prt/wavelet.h for the layout and the paper).
#include <prt/wavelet.h>

#include <prt/error.h>
#include <prt/names.h>

#include <fmt/format.h>

#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace prt::wavelet {

bool valid_resolution(int r) { return r >= 2 && r <= 256 && (r & (r - 1)) == 0; }

void check_resolution(int r, const char* what) {
  if (!valid_resolution(r))
    throw Error(fmt::format("{} must be a power of two between 2 and 256, got {}", what, r));
}

// ---- transforms -------------------------------------------------------------

namespace {

template <typename T>
std::vector<T>& scratch(int r) {
  thread_local std::vector<T> s;
  if (s.size() < std::size_t(r) * r) s.resize(std::size_t(r) * r);
  return s;
}

template <typename T>
void forward_impl(T* f, int r) {
  PRT_CHECK(valid_resolution(r));
  T* tmp = scratch<T>(r).data();
  const T k = T(M_SQRT1_2);
  for (int s = r; s >= 2; s /= 2) {
    const int h = s / 2;
    for (int y = 0; y < s; ++y) {  // rows of the low-pass square
      T* row = f + std::size_t(y) * r;
      for (int i = 0; i < h; ++i) {
        tmp[i] = (row[2 * i] + row[2 * i + 1]) * k;
        tmp[h + i] = (row[2 * i] - row[2 * i + 1]) * k;
      }
      std::copy(tmp, tmp + s, row);
    }
    for (int i = 0; i < h; ++i) {  // columns: rows 2i, 2i+1 -> rows i, h+i
      const T* a = f + std::size_t(2 * i) * r;
      const T* b = a + r;
      T* lo = tmp + std::size_t(i) * s;
      T* hi = tmp + std::size_t(h + i) * s;
      for (int x = 0; x < s; ++x) {
        lo[x] = (a[x] + b[x]) * k;
        hi[x] = (a[x] - b[x]) * k;
      }
    }
    for (int y = 0; y < s; ++y) std::copy(tmp + std::size_t(y) * s, tmp + std::size_t(y + 1) * s, f + std::size_t(y) * r);
  }
}

template <typename T>
void inverse_impl(T* f, int r) {
  PRT_CHECK(valid_resolution(r));
  T* tmp = scratch<T>(r).data();
  const T k = T(M_SQRT1_2);
  for (int s = 2; s <= r; s *= 2) {
    const int h = s / 2;
    for (int i = 0; i < h; ++i) {  // columns first (the forward step's reverse order)
      const T* lo = f + std::size_t(i) * r;
      const T* hi = f + std::size_t(h + i) * r;
      T* a = tmp + std::size_t(2 * i) * s;
      T* b = a + s;
      for (int x = 0; x < s; ++x) {
        a[x] = (lo[x] + hi[x]) * k;
        b[x] = (lo[x] - hi[x]) * k;
      }
    }
    for (int y = 0; y < s; ++y) std::copy(tmp + std::size_t(y) * s, tmp + std::size_t(y + 1) * s, f + std::size_t(y) * r);
    for (int y = 0; y < s; ++y) {
      T* row = f + std::size_t(y) * r;
      for (int i = 0; i < h; ++i) {
        tmp[2 * i] = (row[i] + row[h + i]) * k;
        tmp[2 * i + 1] = (row[i] - row[h + i]) * k;
      }
      std::copy(tmp, tmp + s, row);
    }
  }
}

}  // namespace

void haar_forward(float* face, int r) { forward_impl(face, r); }
void haar_inverse(float* face, int r) { inverse_impl(face, r); }
void haar_forward(double* face, int r) { forward_impl(face, r); }
void haar_inverse(double* face, int r) { inverse_impl(face, r); }

void forward_cube(float* planar, int r, int channels) {
  const std::size_t n = std::size_t(r) * r;
  for (int f = 0; f < 6 * channels; ++f) forward_impl(planar + f * n, r);
}

void inverse_cube(float* planar, int r, int channels) {
  const std::size_t n = std::size_t(r) * r;
  for (int f = 0; f < 6 * channels; ++f) inverse_impl(planar + f * n, r);
}

int support_size(int index_in_face, int r) {
  PRT_CHECK(valid_resolution(r));
  PRT_CHECK_OP(index_in_face, <, r * r);
  PRT_CHECK_OP(index_in_face, >=, 0);
  const int m = std::max(index_in_face % r, index_in_face / r);
  if (m == 0) return r;
  int level = 0;  // floor(log2(m)): m in [s/2, s) with s = 2^(level+1)
  while ((m >> (level + 1)) != 0) ++level;
  return r >> level;
}

// ---- term selection -----------------------------------------------------------

void select_terms(std::span<const float> coeffs, int channels, int r, int K, Selection selection,
                  std::vector<std::uint32_t>& out) {
  check_resolution(r);
  if (K < 0 || K > kMaxTerms) throw Error(fmt::format("the number of wavelet terms must be 0 to {}, got {}", kMaxTerms, K));
  PRT_CHECK(channels >= 1);
  const std::size_t n = cube_size(r), rr = std::size_t(r) * r;
  PRT_CHECK_OP(coeffs.size(), >=, n * channels);
  out.clear();
  if (std::size_t(K) >= n) {
    out.resize(n);
    for (std::size_t j = 0; j < n; ++j) out[j] = std::uint32_t(j);
    return;
  }
  // Squared weights (same order as the weights): |c|^2, times (area / r^2)^2.
  struct Term {
    double w;
    std::uint32_t j;
  };
  std::vector<Term> terms(n);
  for (std::size_t j = 0; j < n; ++j) {
    double w = 0.0;
    for (int c = 0; c < channels; ++c) {
      const double v = coeffs[std::size_t(c) * n + j];
      w += v * v;
    }
    if (selection == Selection::AreaWeighted) {
      const double side = support_size(int(j % rr), r), a = side * side / double(rr);
      w *= a * a;
    }
    terms[j] = {w, std::uint32_t(j)};
  }
  // A strict total order (weight descending, then index ascending) makes the
  // chosen set unique.
  auto before = [](const Term& a, const Term& b) { return a.w > b.w || (a.w == b.w && a.j < b.j); };
  std::nth_element(terms.begin(), terms.begin() + K, terms.end(), before);
  out.resize(std::size_t(K));
  for (int i = 0; i < K; ++i) out[i] = terms[i].j;
  std::sort(out.begin(), out.end());
}

// ---- CubeSplatter -------------------------------------------------------------

namespace {

// cube_face_coords in float: the face and the face coordinates (s, t) in [-1, 1].
inline int face_coords(const glm::vec3& d, float& s, float& t) {
  const float ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  int face;
  float m;
  if (ax >= ay && ax >= az) {
    m = ax;
    if (d.x > 0) { face = kPosX; s = -d.z; t = -d.y; }
    else { face = kNegX; s = d.z; t = -d.y; }
  } else if (ay >= az) {
    m = ay;
    if (d.y > 0) { face = kPosY; s = d.x; t = d.z; }
    else { face = kNegY; s = d.x; t = -d.z; }
  } else {
    m = az;
    if (d.z > 0) { face = kPosZ; s = d.x; t = -d.y; }
    else { face = kNegZ; s = -d.x; t = -d.y; }
  }
  s /= m;
  t /= m;
  return face;
}

// Splat weights along one axis, in texel units, of a tent centred on x with
// half-width w (a box of side w convolved with itself): the texels in
// [-1, r] it overlaps (-1 and r are the neighbouring faces' edge texels) and
// the tent's integral over each; the tent is clipped to [-1, r + 1) and
// renormalised, so the weights sum to 1. Returns the count (1 to 3).
inline int tent_weights(double x, double w, int r, int* texel, double* weight) {
  w = std::min(w, 1.0);  // keeps the tent within one texel of the face, and 3 texels wide at most
  if (!(w > 0.0)) {
    texel[0] = std::clamp(int(std::floor(x)), -1, r);
    weight[0] = 1.0;
    return 1;
  }
  const double lo = std::max(x - w, -1.0), hi = std::min(x + w, double(r + 1)), inv_w = 1.0 / w;
  auto cdf = [&](double y) {  // integral of the unit tent up to y, for y in [lo, hi]
    const double t = (y - x) * inv_w;
    return t <= 0.0 ? 0.5 * (1.0 + t) * (1.0 + t) : 1.0 - 0.5 * (1.0 - t) * (1.0 - t);
  };
  const int i0 = std::clamp(int(std::floor(lo)), -1, r), i1 = std::clamp(int(std::ceil(hi)) - 1, i0, r);
  const double c0 = cdf(lo), c1 = cdf(hi), inv = 1.0 / (c1 - c0);
  double prev = c0;
  int k = 0;
  for (int i = i0; i <= i1; ++i, ++k) {
    const double c = i == i1 ? c1 : cdf(double(i + 1));
    texel[k] = i;
    weight[k] = (c - prev) * inv;
    prev = c;
  }
  return k;
}

// Largest power of two b dividing n with b * size <= limit (at least 1).
int block_size(int n, double size, double limit) {
  int b = 1;
  while (n % (2 * b) == 0 && 2 * b * size <= limit) b *= 2;
  return b;
}

}  // namespace

void CubeSplatter::add_block(const glm::dvec3& weighted_dir, const glm::dvec3& centroid, const glm::dvec3& e,
                             double omega) {
  if (e.x == 0.0 && e.y == 0.0 && e.z == 0.0) return;  // no energy: nothing to splat
  const double lw = glm::length(weighted_dir), lc = glm::length(centroid);
  glm::dvec3 d = lw > 0.0 ? weighted_dir / lw : lc > 0.0 ? centroid / lc : glm::dvec3(0, 1, 0);
  samples_.push_back({glm::vec3(d), glm::vec3(e), float(std::sqrt(omega))});
}

CubeSplatter::CubeSplatter(const EnvMap& map, int r) : r_(r) {
  check_resolution(r);
  if (map.width <= 0 || map.height <= 0 || map.rgb.size() < map.pixel_count() * 3 || map.rgb.empty())
    throw Error(map.source + ": empty environment map");
  omega_.resize(std::size_t(r) * r);
  for (int v = 0; v < r; ++v)
    for (int u = 0; u < r; ++u) omega_[std::size_t(v) * r + u] = cube_texel_solid_angle(u, v, r);
  // Each face with a one-texel ring: ring texels are the neighbouring faces'
  // texels there (found through the ring texel's direction).
  const int g = r + 2;
  ring_.resize(std::size_t(6) * g * g);
  for (int f = 0; f < 6; ++f)
    for (int v = -1; v <= r; ++v)
      for (int u = -1; u <= r; ++u) {
        double s, t;
        const int face = cube_face_coords(cube_direction(f, 2.0 * (u + 0.5) / r - 1.0, 2.0 * (v + 0.5) / r - 1.0), s, t);
        const int tu = std::clamp(int((s + 1.0) * 0.5 * r), 0, r - 1), tv = std::clamp(int((t + 1.0) * 0.5 * r), 0, r - 1);
        ring_[(std::size_t(f) * g + v + 1) * g + u + 1] = std::uint32_t((face * r + tv) * r + tu);
      }
  // Merged blocks stay within half the side of a mean texel (1/4 its solid angle).
  const double limit = 0.5 * std::sqrt(4.0 * M_PI / double(cube_size(r)));

  // Accumulates one pixel into the current block.
  glm::dvec3 wdir(0.0), cdir(0.0), e(0.0);
  double block_omega = 0.0;
  auto add_pixel = [&](const float* L, const glm::dvec3& d, double omega) {
    const glm::dvec3 le = glm::dvec3(L[0], L[1], L[2]) * omega;
    e += le;
    energy_ += le;
    wdir += (std::abs(le.x) + std::abs(le.y) + std::abs(le.z)) * d;
    cdir += omega * d;
    block_omega += omega;
  };
  auto flush = [&] {
    add_block(wdir, cdir, e, block_omega);
    wdir = cdir = e = glm::dvec3(0.0);
    block_omega = 0.0;
  };

  if (!map.is_cube()) {
    const int W = map.width, H = map.height;
    const double dth = M_PI / H, dph = 2.0 * M_PI / W;
    // Row and column tables of latlong_direction at pixel centres.
    std::vector<double> st(H), ct(H), sp(W), cp(W), row_omega(H);
    for (int y = 0; y < H; ++y) {
      st[y] = std::sin(dth * (y + 0.5));
      ct[y] = std::cos(dth * (y + 0.5));
      row_omega[y] = latlong_pixel_solid_angle(y, W, H);
    }
    for (int x = 0; x < W; ++x) {
      sp[x] = std::sin(dph * (x + 0.5));
      cp[x] = std::cos(dph * (x + 0.5));
    }
    const int b = std::min(block_size(H, dth, limit), block_size(W, dph, limit));
    for (int y0 = 0; y0 < H; y0 += b) {
      // Widest part of this band of rows: sin(theta) at its edge nearest the equator.
      const double t0 = dth * y0, t1 = dth * (y0 + b);
      const double smax = (t0 <= M_PI / 2 && t1 >= M_PI / 2) ? 1.0 : std::max(std::sin(t0), std::sin(t1));
      int m = 1;  // merge m blocks along phi while the block stays narrow enough
      while ((W / b) % (2 * m) == 0 && 2 * m * b * dph * smax <= limit) m *= 2;
      const int bw = m * b;
      for (int x0 = 0; x0 < W; x0 += bw) {
        for (int y = y0; y < y0 + b; ++y)
          for (int x = x0; x < x0 + bw; ++x)
            add_pixel(&map.rgb[(std::size_t(y) * W + x) * 3], {-st[y] * sp[x], ct[y], st[y] * cp[x]}, row_omega[y]);
        flush();
      }
    }
  } else {
    const int N = map.width;
    std::vector<double> src_omega(std::size_t(N) * N);
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) src_omega[std::size_t(v) * N + u] = cube_texel_solid_angle(u, v, N);
    const int b = block_size(N, 2.0 / N, limit);  // texels are widest (2/N rad) at a face's centre
    for (int face = 0; face < 6; ++face)
      for (int v0 = 0; v0 < N; v0 += b)
        for (int u0 = 0; u0 < N; u0 += b) {
          for (int v = v0; v < v0 + b; ++v)
            for (int u = u0; u < u0 + b; ++u)
              add_pixel(&map.rgb[((std::size_t(face) * N + v) * N + u) * 3], cube_texel_direction(face, u, v, N),
                        src_omega[std::size_t(v) * N + u]);
          flush();
        }
  }
}

void CubeSplatter::resample(const glm::dmat3& R, std::vector<float>& planar_out) {
  const std::size_t n = cube_size(r_), rr = std::size_t(r_) * r_, S = samples_.size();
  // Fixed chunking from the sample count alone: at most 8 chunks of >= 4096.
  constexpr std::size_t kMinChunk = 4096, kMaxChunks = 8;
  const std::size_t chunks = std::clamp<std::size_t>((S + kMinChunk - 1) / kMinChunk, 1, kMaxChunks);
  const std::size_t per = (S + chunks - 1) / chunks;
  scratch_.resize(chunks * n * 3);
  const glm::mat3 Rf(R);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    double* acc = scratch_.data() + c * n * 3;
    std::fill(acc, acc + n * 3, 0.0);
    const std::size_t s1 = std::min(S, (c + 1) * per);
    const float half_r = 0.5f * float(r_);
    const std::ptrdiff_t g = r_ + 2;
    for (std::size_t s = c * per; s < s1; ++s) {
      const Sample& smp = samples_[s];
      float fs, ft;
      const int face = face_coords(Rf * smp.dir, fs, ft);
      // Footprint: a square of the sample's solid angle, in face coordinates
      // (d omega = ds dt / q^(3/2), q = 1 + s^2 + t^2), in texel units.
      const float q = 1.0f + fs * fs + ft * ft;
      const double half = smp.sqrt_omega * std::sqrt(q * std::sqrt(q)) * half_r;
      const std::uint32_t* ring = ring_.data() + std::size_t(face) * g * g + g + 1;  // (u, v) at ring[v g + u]
      int tu[3], tv[3];
      double wu[3], wv[3];
      const int nu = tent_weights((fs + 1.0f) * half_r, half, r_, tu, wu);
      const int nv = tent_weights((ft + 1.0f) * half_r, half, r_, tv, wv);
      for (int a = 0; a < nv; ++a) {
        const std::uint32_t* row = ring + std::ptrdiff_t(tv[a]) * g;
        const glm::dvec3 ev = glm::dvec3(smp.energy) * wv[a];
        for (int b = 0; b < nu; ++b) {
          double* p = acc + std::size_t(row[tu[b]]) * 3;
          p[0] += ev.x * wu[b];
          p[1] += ev.y * wu[b];
          p[2] += ev.z * wu[b];
        }
      }
    }
  });
  planar_out.resize(3 * n);
  constexpr std::size_t kTexelBlock = 1024;
  tbb::parallel_for(std::size_t(0), (n + kTexelBlock - 1) / kTexelBlock, [&](std::size_t blk) {
    const std::size_t j1 = std::min(n, (blk + 1) * kTexelBlock);
    for (std::size_t j = blk * kTexelBlock; j < j1; ++j) {
      double sum[3] = {0.0, 0.0, 0.0};
      for (std::size_t c = 0; c < chunks; ++c) {
        const double* a = scratch_.data() + (c * n + j) * 3;
        sum[0] += a[0];
        sum[1] += a[1];
        sum[2] += a[2];
      }
      const double inv = 1.0 / omega_[j % rr];
      for (int ch = 0; ch < 3; ++ch) planar_out[ch * n + j] = float(sum[ch] * inv);
    }
  });
}

// ---- FrameLighting -------------------------------------------------------------

FrameLighting::FrameLighting(const EnvMap& map, int cube_res) : splatter_(map, cube_res) {}

void FrameLighting::update(const glm::dmat3& R, int K, Selection selection) {
  if (K < 0 || K > kMaxTerms) throw Error(fmt::format("the number of wavelet terms must be 0 to {}, got {}", kMaxTerms, K));
  const int r = splatter_.resolution();
  splatter_.resample(R, coeffs_);
  forward_cube(coeffs_.data(), r, 3);
  select_terms(coeffs_, 3, r, K, selection, terms_);
}

namespace {
constexpr EnumName<Selection> kSelectionNames[] = {{Selection::AreaWeighted, "area"},
                                                   {Selection::Magnitude, "magnitude"}};
}  // namespace

Selection parse_selection(std::string_view name) { return parse_enum(kSelectionNames, name, "wavelet term selection"); }

std::string_view selection_name(Selection s) { return enum_name(kSelectionNames, s); }

}  // namespace prt::wavelet
