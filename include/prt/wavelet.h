// prt/wavelet.h - Haar wavelets on cube maps, for all-frequency relighting
// (Ng, Ramamoorthi & Hanrahan, "All-Frequency Shadows Using Non-linear
// Wavelet Lighting Approximation", SIGGRAPH 2003).
//
// Cube maps follow docs/CONVENTIONS.md ("Cube maps"): faces +X, -X, +Y, -Y,
// +Z, -Z, each r x r, row 0 at the top. The resolution r is a power of two
// in [2, 256].
//
// Index layout. A cube array holds 6 r^2 values; value j = face r^2 + y r + x
// (row-major within a face, row 0 at the top), both before the transform
// (texel (u = x, v = y)) and after it (wavelet coefficient j).
//
// Planar RGB. Lighting travels as one float array of 3 * 6 r^2 values,
// channel-major: [channel][j], channel c starting at c * 6 r^2.
//
// Transform. Each face separately gets the orthonormal 2-D Haar transform in
// the non-standard decomposition (Stollnitz, DeRose & Salesin, "Wavelets for
// Computer Graphics: A Primer", 1995): for s = r, r/2, ..., 2, one 1-D step on
// every row of the current low-pass s x s square (top-left corner), then one
// on every column of it. A 1-D step of length s maps pairs (a, b) to the
// average (a + b)/sqrt(2), stored in [0, s/2), and the difference
// (a - b)/sqrt(2), stored in [s/2, s). Every step is orthonormal, so the
// transform is (Parseval: sum of squares kept, the inverse is the transpose).
// After it, within a face:
//   (0, 0)                           the scaling coefficient, face sum / r;
//   m = max(x, y) in [s/2, s), s = 2, 4, ..., r: the wavelets of level s, in
//     three s/2 x s/2 quadrants: x >= s/2, y < s/2 varies along x;
//     x < s/2, y >= s/2 varies along y; both >= s/2: the diagonal one.
//   Each wavelet of level s is supported on a square of 2r/s x 2r/s texels:
//   r for the coarsest (s = 2), 2 for the finest (s = r).
#pragma once

#include <prt/envmap.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace prt::wavelet {

// True for a power of two in [2, 256].
bool valid_resolution(int r);
// Throws prt::Error("<what> must be a power of two between 2 and 256, got ...").
void check_resolution(int r, const char* what = "cube resolution");
// Values in one cube array: 6 r^2.
inline std::size_t cube_size(int r) { return std::size_t(6) * r * r; }

// ---- transforms -------------------------------------------------------------
// In-place Haar transform of one r x r face (row-major), and its inverse.
// r must be valid_resolution(). Thread-safe (scratch is per thread).
void haar_forward(float* face, int r);
void haar_inverse(float* face, int r);
void haar_forward(double* face, int r);
void haar_inverse(double* face, int r);

// All 6 faces of `channels` planar cube arrays (channels * 6 r^2 values).
void forward_cube(float* planar, int r, int channels = 3);
void inverse_cube(float* planar, int r, int channels = 3);

// Side, in texels, of the square support of the basis function at
// `index_in_face` (< r^2) of a face of size r: r for the scaling function and
// the coarsest wavelets, 2 for the finest.
int support_size(int index_in_face, int r);

// ---- non-linear approximation ---------------------------------------------
// The most terms a frame keeps (prt relight, render, view --terms 1 to 2^30;
// K >= 6 r^2 keeps all of a cube's, 393,216 at r = 256).
inline constexpr int kMaxTerms = 1 << 30;

enum class Selection {
  Magnitude,     // w_j = |c_j|
  AreaWeighted,  // w_j = |c_j| support_j^2 / r^2 (Ng et al.: favours coarse terms)
};

// Picks the K terms of largest weight among the 6 r^2 coefficients of
// `channels` planar arrays (`coeffs`, channels * 6 r^2 values; |c_j| is the
// Euclidean norm over the channels). Writes exactly min(K, 6 r^2) indices to
// `out`, sorted ascending (column order for wavelet_relight). Ties are broken
// by the smaller index, so the choice is deterministic. O(6 r^2) expected.
// Throws prt::Error for K < 0 or K > kMaxTerms.
void select_terms(std::span<const float> coeffs, int channels, int r, int K, Selection selection,
                  std::vector<std::uint32_t>& out);

// ---- environment map -> cube texels -------------------------------------------
// Resamples an environment map (lat-long or cube, EnvMap) to texel-average
// radiance on a cube of resolution r, under a rotation, fast enough to run
// every frame.
//
// Built once per map and r: the map's pixels become source samples
// (direction, radiance x solid angle), using the exact pixel solid angles.
// Where the map is much finer than the cube, blocks of pixels are merged
// first (lat-long rows near the poles merge further along phi) until a block
// is no wider than half a mean cube texel (about 1/4 of its solid angle). A
// merged sample keeps the block's exact energy per channel and sits at the
// block's radiance-weighted mean direction, so a one-pixel sun stays at its
// own direction. Blocks with zero radiance are dropped.
//
// resample(R): light from d arrives from R d (docs/CONVENTIONS.md,
// "Rotations"). Each sample is splatted around R d with a separable tent in
// the face coordinates of cube_face_coords, of half-width a = the side of a
// square of the sample's solid angle there (at most one texel): its energy is
// shared among the texels by the tent's integral over each; what falls off
// the face goes to the neighbouring face's edge texel. A sample whose tent
// lies inside one texel lands wholly in the texel containing R d. Energies
// are summed in double and divided by the texel's exact solid angle.
// Splatting a footprint rather than a point keeps a constant map nearly
// constant instead of aliased (measured: a few % per texel when blocks are
// half a texel wide; the sum over texels is exact). Energy is exact: sum_i l_i omega_i equals the map's sum
// of L omega over its pixels, per channel, to float rounding of the samples.
// Deterministic: a fixed chunking of the samples, independent of the thread
// count, and per-chunk sums added in chunk order.
class CubeSplatter {
 public:
  // Throws prt::Error for an invalid r or an empty map.
  CubeSplatter(const EnvMap& map, int r);

  // planar_out: resized to 3 * 6 r^2, texel-average radiance [channel][texel].
  // Reuses internal scratch: do not call concurrently on one object.
  void resample(const glm::dmat3& R, std::vector<float>& planar_out);

  int resolution() const { return r_; }
  std::size_t sample_count() const { return samples_.size(); }
  // Sum over the map's pixels of L omega, per channel, in double.
  const glm::dvec3& energy() const { return energy_; }
  // Exact solid angle of cube texel j (j < 6 r^2).
  double texel_solid_angle(std::size_t j) const { return omega_[j % (std::size_t(r_) * r_)]; }

 private:
  struct Sample {
    glm::vec3 dir;     // unit
    glm::vec3 energy;  // radiance x solid angle, per channel
    float sqrt_omega;  // sqrt of the sample's solid angle: its footprint's side
  };
  void add_block(const glm::dvec3& weighted_dir, const glm::dvec3& centroid, const glm::dvec3& energy, double omega);

  int r_ = 0;
  std::vector<Sample> samples_;
  std::vector<double> omega_;    // texel solid angles of one face (the same on all six)
  std::vector<std::uint32_t> ring_;  // per face, (r+2)^2: cube texel of (u, v) in [-1, r]^2
  std::vector<double> scratch_;  // per-chunk accumulators
  glm::dvec3 energy_{0.0};
};

// ---- per-frame lighting ----------------------------------------------------------
// The lighting side of a frame (Ng et al. 2003, section 4): resample the
// rotated environment into the cube (CubeSplatter), Haar-transform it
// (forward_cube) and keep the K largest terms (select_terms). Built once per
// map and resolution; update() runs every frame. Owns its buffers; not
// thread-safe (one object per rendering thread).
class FrameLighting {
 public:
  // Throws prt::Error for an invalid cube_res or an empty map (CubeSplatter).
  FrameLighting(const EnvMap& map, int cube_res);

  // Resamples with rotation R (light from d arrives from R d; docs/CONVENTIONS.md,
  // "Rotations"), transforms, and selects K terms (K >= 6 r^2: all of them, in
  // index order). Throws prt::Error for K < 0 or K > kMaxTerms. Deterministic.
  void update(const glm::dmat3& R, int K, Selection selection);

  // After update(): planar [3][6 r^2] Haar coefficients of the texel-average
  // radiance (all of them; terms() says which to use).
  const std::vector<float>& coefficients() const { return coeffs_; }
  // After update(): the min(K, 6 r^2) selected indices, ascending.
  const std::vector<std::uint32_t>& terms() const { return terms_; }
  int resolution() const { return splatter_.resolution(); }
  const CubeSplatter& splatter() const { return splatter_; }

 private:
  CubeSplatter splatter_;
  std::vector<float> coeffs_;
  std::vector<std::uint32_t> terms_;
};

// "area" or "magnitude" (the command line's --selection); throws prt::Error otherwise.
Selection parse_selection(std::string_view name);
std::string_view selection_name(Selection s);

}  // namespace prt::wavelet
