// bench/bare_trace.h - the baseline of the transfer benchmarks: the same
// rays as a transfer pass, traced by bare Embree with no SH work.
#pragma once

#include "ray_scene.h"

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <vector>

namespace prt_bench {

// For every point (position, normal), the 8-wide occlusion packets of the
// directions above its horizon, from p + offset n; returns the hits (so the
// work is not optimised away).
inline long trace_bare(const prt::detail::RayScene& scene, const glm::vec3* positions, const glm::vec3* normals,
                       std::size_t count, const std::vector<glm::vec3>& dirs, float offset) {
  std::atomic<long> hits{0};
  tbb::parallel_for(std::size_t(0), (count + 63) / 64, [&](std::size_t block) {
    prt::detail::enable_ftz_daz();
    long local = 0;
    glm::vec3 batch[8];
    for (std::size_t v = block * 64; v < std::min(count, block * 64 + 64); ++v) {
      const glm::vec3 n = normals[v], o = positions[v] + offset * n;
      int k = 0;
      for (const glm::vec3& d : dirs) {
        if (glm::dot(n, d) <= 0.0f) continue;
        batch[k++] = d;
        if (k == 8) {
          local += __builtin_popcount(scene.occluded8(o, batch, 8, offset));
          k = 0;
        }
      }
      if (k) local += __builtin_popcount(scene.occluded8(o, batch, k, offset));
    }
    hits += local;
  });
  return hits.load();
}

}  // namespace prt_bench
