// prt/wavelet_playback.h - drawing wavelet (all-frequency) transfers with
// prt::Renderer.
//
// A wavelet transfer (prt/wavelet_transfer.h; Ng, Ramamoorthi & Hanrahan
// 2003) has no cheap rotation of its lighting, so it is relit on the CPU
// every frame and the renderer draws the result as vertex colours
// (Shading::VertexColors). Per frame, with the environment rotated by R
// (light from d arrives from R d, as for Renderer::set_environment_rotation):
//   1. the rotated map is resampled into the transfer's 6 r^2 cube texels
//      (wavelet::CubeSplatter: every sample of the map splatted once),
//   2. Haar-transformed per face, and the K largest terms kept by the
//      selection (wavelet::FrameLighting::update),
//   3. every vertex relit from those K terms (wavelet_relight: a sparse sum
//      over the K columns, multi-threaded), and
//   4. (frame() only) the colours uploaded with Renderer::set_vertex_colors
//      (12 bytes per vertex cross the bus) and VertexColors selected.
// Steps 1-2 cost about 3 ms whatever K is (a 69k-sample map, cube 32^2 x 6),
// step 3 grows with K and the transfer's density: on a 37,706-vertex mesh,
// 2 cores, 6 ms per frame at K = 100 and 30 ms at K = 1000 in all
// (docs/WAVELETS.md, "Per-frame cost").
//
// Ownership: a WaveletPlayback holds a reference to the transfer, not a
// copy; the transfer must outlive it and stay unchanged. It owns the
// lighting (the map's samples, built in the constructor and by
// set_environment: O(map pixels), the map itself is not kept) and one colour
// per vertex. It holds no renderer: frame() draws into the one it is given,
// which must have the transfer's mesh uploaded (Renderer::set_mesh(mesh,
// transfer.albedo, transfer.vertex_colors)). Not thread-safe: one per
// rendering thread.
//
//   prt::Renderer r;
//   r.set_mesh(mesh, wt.albedo, wt.vertex_colors);
//   r.set_environment(env);
//   prt::WaveletPlayback playback(wt, env);
//   for (each frame) {
//     r.set_environment_rotation(R);
//     playback.frame(r, R, 100);
//     prt::Image img = r.render(camera, 640, 480);
//   }
#pragma once

#include <prt/envmap.h>
#include <prt/wavelet.h>
#include <prt/wavelet_transfer.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <vector>

namespace prt {

class Renderer;

class WaveletPlayback {
 public:
  // Builds the lighting of `env` at the transfer's cube resolution. Throws
  // prt::Error for an empty map or a transfer with an invalid resolution.
  WaveletPlayback(const WaveletTransfer& transfer, const EnvMap& env);
  // Another map (drop-in, map cycling): rebuilds the lighting.
  void set_environment(const EnvMap& env);

  // Steps 1-3: each vertex's linear RGB radiance under the map rotated by
  // R, from K terms (K >= 6 r^2: all of them). Throws prt::Error for K < 0.
  // The result stays in colors() until the next call.
  const std::vector<glm::vec3>& relight(const glm::dmat3& R, int K,
                                        wavelet::Selection selection = wavelet::Selection::AreaWeighted);
  // relight(), then step 4 into `renderer`. Returns the CPU milliseconds
  // of steps 1-3 (lighting and sparse sum; the upload is not counted).
  // Contract (prt::InternalError): the renderer has a mesh of the
  // transfer's vertex count uploaded.
  double frame(Renderer& renderer, const glm::dmat3& R, int K,
               wavelet::Selection selection = wavelet::Selection::AreaWeighted);

  // The last relight()'s colours (one per vertex; zeros before the first).
  const std::vector<glm::vec3>& colors() const { return colors_; }
  // The last frame's lighting: its Haar coefficients and the terms kept.
  const wavelet::FrameLighting& lighting() const { return lighting_; }
  const WaveletTransfer& transfer() const { return transfer_; }
  int cube_res() const { return transfer_.cube_res; }

 private:
  const WaveletTransfer& transfer_;
  wavelet::FrameLighting lighting_;
  std::vector<glm::vec3> colors_;
};

}  // namespace prt
