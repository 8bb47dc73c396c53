// Wavelet transfers relit on the CPU per frame and drawn as vertex colours.
// See prt/wavelet_playback.h.
#include <prt/render.h>
#include <prt/wavelet_playback.h>

#include <chrono>

namespace prt {

WaveletPlayback::WaveletPlayback(const WaveletTransfer& t, const EnvMap& env)
    : transfer_(t), lighting_(env, t.cube_res), colors_(t.vertices) {}

void WaveletPlayback::set_environment(const EnvMap& env) {
  lighting_ = wavelet::FrameLighting(env, transfer_.cube_res);
}

const std::vector<glm::vec3>& WaveletPlayback::relight(const glm::dmat3& R, int K, wavelet::Selection selection) {
  lighting_.update(R, K, selection);
  wavelet_relight(transfer_, lighting_.coefficients().data(), lighting_.terms(), colors_);
  return colors_;
}

double WaveletPlayback::frame(Renderer& r, const glm::dmat3& R, int K, wavelet::Selection selection) {
  const auto t0 = std::chrono::steady_clock::now();
  relight(R, K, selection);
  const double ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.set_vertex_colors(colors_);
  r.set_shading(Shading::VertexColors);
  return ms;
}

}  // namespace prt
