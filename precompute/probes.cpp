// Probe volumes, traced (prt/precompute.h compute_probe_transfer; the data
// and relighting in prt/probes.h, docs/PROBES.md).
#include <prt/precompute.h>

#include <prt/error.h>
#include <prt/sh.h>

#include "progress_ticker.h"
#include "random.h"
#include "ray_scene.h"
#include "transfer_impl.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <iterator>
#include <limits>
#include <memory>
#include <vector>

namespace prt {

namespace {

// One probe's result before the stored ones are packed.
struct ProbeRecord {
  ProbeState state = ProbeState::Sky;
  glm::vec3 position{0.0f};
  std::vector<std::uint16_t> nodes, partial_nodes;
  std::vector<std::uint16_t> partial_mask;
  bool complement = false;
  std::vector<std::uint16_t> depth;
  std::vector<float> bounce;
};

void check_probe_options(const ProbeOptions& o) {
  if (o.mode != TransferMode::Shadowed && o.mode != TransferMode::Interreflected)
    throw Error("--probes: --mode shadowed or interreflected (probes are occluded by the scene)");
  if (o.bands < 1 || o.bands > 8) throw Error(fmt::format("--probes: --bands {} (1 to 8)", o.bands));
  if (o.cube_res < 4 || o.cube_res > 64 || !std::has_single_bit(unsigned(o.cube_res)))
    throw Error(fmt::format("--probe-cube {} (a power of two, 4 to 64)", o.cube_res));
  if (o.depth_res < 2 || o.depth_res > 32) throw Error(fmt::format("probe depth map size {} (2 to 32)", o.depth_res));
  const int k = int(std::lround(std::sqrt(double(o.rays_per_texel))));
  if (o.rays_per_texel < 1 || k * k != o.rays_per_texel || k > 8)
    throw Error(fmt::format("--probe-rays {} (a square: 1, 4, 9, ... 64)", o.rays_per_texel));
  // The bounce bands' range holds whatever the mode (as the command's --bounce-bands 1 to 16).
  if (o.bounce_bands < 1 || o.bounce_bands > 16) throw Error(fmt::format("--bounce-bands {} (1 to 16)", o.bounce_bands));
  if (o.mode == TransferMode::Interreflected && (o.bounces < 1 || o.bounces > kMaxProbeBounces))
    throw Error(fmt::format("--bounces {} (1 to {} for probes)", o.bounces, kMaxProbeBounces));
  if (o.threads < 0 || o.threads > kMaxThreads)
    throw Error(fmt::format("--threads must be between 0 (every core) and {}, got {}", kMaxThreads, o.threads));
}

// The header of the probe volume compute_probe_transfer returns, its depth
// cap and bounce channels; `smallest`: the grid's smallest nonzero spacing.
ProbeTransfer probe_header(const Scene& scene, const ProbeGrid& grid, const ProbeOptions& o, double& smallest) {
  ProbeTransfer t;
  t.grid = grid;
  t.bands = o.bands;
  t.cube_res = o.cube_res;
  t.depth_res = o.depth_res;
  t.mode = o.mode;
  t.rays_per_texel = o.rays_per_texel;
  t.seed = o.seed;
  t.scene_hash = scene.hash();
  const glm::dvec3 sp = grid.spacing();
  const double largest = std::max({sp.x, sp.y, sp.z});
  smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (sp[a] > 0) smallest = std::min(smallest, sp[a]);
  if (!std::isfinite(smallest)) smallest = largest > 0 ? largest : 1.0;
  // A cell's diagonal is at most sqrt(3) x its longest side: every corner
  // probe of a query's cell lies within the cap.
  t.depth_cap = float(2.0 * (largest > 0 ? largest : smallest));
  // Albedo of the bounce matrices: grey everywhere -> one channel.
  bool grey = true;
  if (o.mode == TransferMode::Interreflected) {
    t.bounces = o.bounces;
    t.bounce_bands = o.bounce_bands;
    if (o.override_albedo) {
      grey = o.albedo.x == o.albedo.y && o.albedo.y == o.albedo.z;
    } else {
      // The materials' base colours; a texture varies inside a triangle: coloured.
      for (const Material& m : scene.materials)
        if (m.base_color.x != m.base_color.y || m.base_color.y != m.base_color.z || m.base_color_texture >= 0) grey = false;
    }
    t.channels = grey ? 1 : 3;
  }
  return t;
}

// What tracing the probes needs: the scene and its rays, the volume's
// header, the cube sizes. Traced at base = r / 4 with kk^2 rays per texel;
// a base texel that is neither all visible nor all blocked (or borders one
// of another class) is traced again at r: 2 x 2 rays per finest texel, and
// 4 x 4 more where those disagree.
struct ProbeTracing {
  const Scene& scene;
  const detail::RayScene& rays;
  const ProbeOptions& o;
  const ProbeTransfer& t;
  float offset;
  int r, kk, N;  // cube resolution, sqrt(rays per base texel), depth map size
  int nc, nb;  // coefficients of the transfer and (interreflected) of the bounce light
  int base, refine;
  std::size_t words;  // of the visibility bits
  double lift;  // a probe nearer a surface than this is moved 2 x this off it
};

// ---- the random numbers ------------------------------------------------------------
// Every draw is keyed by what it is for, never by the order the rays are
// traced in: the probes are traced in wavefronts (a block of probes' rays
// at once, by Embree on the CPU's threads or by ProbeOptions::tracer), and
// the file is the same whichever traces them (but for the rays that the
// two see differently) and whatever the thread count. One generator per
// (probe, base texel) jitters its kk^2 rays, one per (probe, base ray)
// draws its bounce path's directions, one per (probe, finest texel)
// jitters its 4 + 16 refinement rays: stream = probe << 24 | kind << 20 |
// index, index < 2^20 (base rays: at most 6 16^2 64 = 98,304; finest
// texels 6 64^2 = 24,576), probe < kMaxProbes = 2^24: no two coincide
// (Rng mixes the stream by an odd multiplier, a bijection).
enum class Draw : std::uint64_t { BaseTexel = 0, BouncePath = 1, FinestTexel = 2 };
static_assert(kMaxProbes <= (std::size_t(1) << 24), "probe_rng's streams");
static_assert(std::size_t(6) * 16 * 16 * 64 < (std::size_t(1) << 20), "probe_rng's streams");

detail::Rng probe_rng(const ProbeTracing& tr, std::size_t p, Draw kind, std::size_t index) {
  return detail::Rng(tr.o.seed, (std::uint64_t(p) << 24) | (std::uint64_t(kind) << 20) | std::uint64_t(index));
}

// A diffuse path from a front hit of a probe's base ray, between bounces.
struct BouncePath {
  detail::Rng rng;     // the path's stream (Draw::BouncePath)
  glm::dvec3 origin;   // the last hit
  glm::dvec3 weight;   // the base ray's solid angle x the albedos so far
  glm::dvec3 w{0.0};   // the next ray's direction
  glm::vec3 dir0;      // the probe's ray the path started from
  glm::vec3 from{0.0f};  // the next ray's origin
  detail::Hit hit;     // the last hit
  bool alive = true;
};

// A finest texel refined (Draw::FinestTexel), and whether its 2 x 2 rays disagreed.
struct RefineTask {
  detail::Rng rng;
  int face, fu, fv;
  bool mixed = false;
};

// One probe's sums, reset for each block.
struct ProbeScratch {
  explicit ProbeScratch(const ProbeTracing& tr)
      : bits(tr.words), cls(std::size_t(6) * tr.base * tr.base), m1(std::size_t(tr.N) * tr.N),
        m2(std::size_t(tr.N) * tr.N), count(std::size_t(tr.N) * tr.N),
        bounce(std::size_t(tr.t.channels) * tr.nc * tr.nb), yk(static_cast<std::size_t>(tr.nc)),
        yj(static_cast<std::size_t>(std::max(tr.nb, 1))) {}

  glm::vec3 x{0.0f};  // the probe's position
  std::vector<std::uint32_t> bits;  // the finest texels that see the map
  std::vector<std::uint8_t> cls;  // per base texel: 0 all blocked, 1 all visible, 2 mixed
  std::vector<double> m1, m2, count;  // depth moments per octahedral texel
  std::vector<double> bounce;
  std::vector<double> yk, yj;
  std::size_t back = 0, hit_count = 0, total = 0;
  std::vector<BouncePath> paths;    // started by its base rays, in ray order
  std::vector<RefineTask> refines;  // its edge texels' finest texels, in texel order
};

// ---- wavefronts ----------------------------------------------------------------------

// Base rays a block of probes traces at most (kProbeBlock probes at most;
// the defaults, r = 64 and 16 rays a base texel: 24,576 rays a probe, 10
// probes a block): the block's bounce paths (152 bytes each, one per front
// hit) stay within 38 MiB, kept with the probes' scratch from block to block.
constexpr std::size_t kBlockRays = std::size_t(1) << 18;
constexpr std::size_t kProbeBlock = 256;
// Rays one wavefront hands to the tracer at most (a block's base rays are
// one wavefront; refinement's may be more): their origins, directions and
// hits (and the tracer's RayHits) take at most 60 MiB; the GL tracer
// dispatches them in chunks of its own.
constexpr std::size_t kWaveRays = std::size_t(1) << 20;

// One wavefront's rays, all from tnear = the offset, and their closest hits.
struct Wave {
  bool occlusion = false;  // only whether each ray hits matters (Embree: occluded8, hits[i].triangle 0 when it does)
  std::vector<glm::vec3> origins, dirs;
  std::vector<detail::Hit> hits;
  std::vector<RayHit> traced;  // ProbeOptions::tracer's
};

// fn(i) for i in [0, n), in parallel (flush-to-zero on each worker, as Embree wants).
template <class Fn>
void for_each_parallel(std::size_t n, std::size_t grain, Fn&& fn) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& range) {
    detail::enable_ftz_daz();
    for (std::size_t i = range.begin(); i < range.end(); ++i) fn(i);
  });
}

// Embree on the CPU's threads (robust): rays in fixed groups of 8, each run
// of one origin inside a group through intersect8 (a lone ray through
// intersect1; occlusion waves through occluded8), so that a ray takes the
// same call whatever the thread count.
void trace_wave_embree(const ProbeTracing& tr, Wave& w) {
  const std::size_t n = w.origins.size();
  for_each_parallel((n + 7) / 8, 64, [&](std::size_t g) {
    const std::size_t end = std::min(n, 8 * g + 8);
    for (std::size_t a = 8 * g; a < end;) {
      std::size_t b = a + 1;
      while (b < end && w.origins[b] == w.origins[a]) ++b;
      if (w.occlusion) {
        const std::uint32_t blocked = tr.rays.occluded8(w.origins[a], w.dirs.data() + a, int(b - a), tr.offset);
        for (std::size_t i = a; i < b; ++i) w.hits[i].triangle = (blocked >> (i - a)) & 1u ? 0u : ~0u;
      } else if (b - a == 1) {
        w.hits[a] = tr.rays.intersect1(w.origins[a], w.dirs[a], tr.offset);
      } else {
        tr.rays.intersect8(w.origins[a], w.dirs.data() + a, int(b - a), tr.offset, w.hits.data() + a);
      }
      a = b;
    }
  });
}

// The wavefront's closest hits: Embree's, or ProbeOptions::tracer's (which
// side was struck from the mesh, as Embree's hits say it).
void trace_wave(const ProbeTracing& tr, Wave& w) {
  const std::size_t n = w.origins.size();
  w.hits.assign(n, detail::Hit{});
  if (!tr.o.tracer) return trace_wave_embree(tr, w);
  w.traced.assign(n, RayHit{});
  tr.o.tracer->trace_rays(w.origins, w.dirs, tr.offset, w.traced);
  const Mesh& mesh = tr.scene.mesh;
  for_each_parallel(n, 4096, [&](std::size_t i) {
    const RayHit& h = w.traced[i];
    if (!h.hit()) return;
    if (h.triangle >= mesh.triangles.size())
      throw Error(fmt::format("probe tracer: triangle {} of {} hit", h.triangle, mesh.triangles.size()));
    detail::Hit& out = w.hits[i];
    out.triangle = h.triangle;
    out.u = h.u;
    out.v = h.v;
    out.t = h.t;
    out.front = detail::front_facing(mesh, h.triangle, w.dirs[i]);
  });
}

// The tasks of probes [0, n) of a block, count(q) of probe q's, k rays
// each, traced in wavefronts of at most kWaveRays rays (in probe order, a
// probe's tasks in order): make(q, j, origins, dirs) sets task j of probe
// q's k rays (in parallel: each task draws from its own streams);
// take(q, j, dirs, hits) reads them, a probe's tasks in order on one
// thread, probes in parallel.
template <class Count, class Make, class Take>
void trace_tasks(const ProbeTracing& tr, Wave& w, std::size_t n, int k, Count&& count, Make&& make, Take&& take) {
  const std::size_t kz = std::size_t(k), per = std::max<std::size_t>(kWaveRays / kz, 1);
  std::vector<std::size_t> start(n + 1, 0);  // probe q's tasks: [start[q], start[q + 1])
  for (std::size_t q = 0; q < n; ++q) start[q + 1] = start[q] + count(q);
  for (std::size_t first = 0; first < start[n]; first += per) {
    const std::size_t size = std::min(per, start[n] - first);
    const std::size_t q0 = std::size_t(std::upper_bound(start.begin(), start.end(), first) - start.begin()) - 1;
    const std::size_t q1 = std::size_t(std::lower_bound(start.begin(), start.end(), first + size) - start.begin());
    w.origins.resize(size * kz);
    w.dirs.resize(size * kz);
    // Probe q's tasks in this wavefront: [max(start[q], first), min(start[q + 1], first + size)).
    const auto each = [&](std::size_t q, auto&& fn) {
      for (std::size_t g = std::max(start[q], first); g < std::min(start[q + 1], first + size); ++g)
        fn(g - start[q], (g - first) * kz);
    };
    for_each_parallel(q1 - q0, 1, [&](std::size_t i) {
      each(q0 + i, [&](std::size_t j, std::size_t at) { make(q0 + i, j, &w.origins[at], &w.dirs[at]); });
    });
    trace_wave(tr, w);
    for_each_parallel(q1 - q0, 1, [&](std::size_t i) {
      each(q0 + i, [&](std::size_t j, std::size_t at) { take(q0 + i, j, &w.dirs[at], &w.hits[at]); });
    });
  }
}

// ---- the base cube -------------------------------------------------------------------

void set_bit(const ProbeTracing& tr, ProbeScratch& sc, int face, int u, int v) {
  const std::size_t i2 = (std::size_t(face) * tr.r + std::size_t(v)) * tr.r + std::size_t(u);
  sc.bits[i2 >> 5] |= 1u << (i2 & 31);
}

// One ray of the base cube: depth moments, back faces; a front hit starts
// a bounce path (interreflected).
void take_ray(const ProbeTracing& tr, ProbeScratch& sc, std::size_t p, std::size_t ray,
              glm::vec3 d, const detail::Hit& hit, double omega) {
  const int N = tr.N;
  ++sc.total;
  double depth = tr.t.depth_cap;
  if (hit.hit()) {
    ++sc.hit_count;
    depth = std::min(double(hit.t), double(tr.t.depth_cap));
    if (!hit.front) ++sc.back;
  }
  const glm::dvec2 uv = octahedral_encode(glm::dvec3(d));
  const std::size_t o2 =
      std::size_t(std::clamp(int(uv.y * N), 0, N - 1)) * N + std::size_t(std::clamp(int(uv.x * N), 0, N - 1));
  sc.m1[o2] += depth;
  sc.m2[o2] += depth * depth;
  sc.count[o2] += 1;
  if (tr.nb == 0 || !hit.hit() || !hit.front) return;
  const glm::dvec3 dd(d);
  sc.paths.push_back(BouncePath{probe_rng(tr, p, Draw::BouncePath, ray), glm::dvec3(sc.x) + dd * double(hit.t),
                                glm::dvec3(omega), glm::dvec3(0.0), d, glm::vec3(0.0f), hit, true});
}

// The base cubes of probes [p0, p0 + n) (scratch[q]: probe p0 + q's):
// kk^2 jittered rays per texel, each texel classed (0 all blocked, 1 all
// visible, 2 mixed); the bounce paths they start (each probe's in ray order).
void trace_base_cubes(const ProbeTracing& tr, std::size_t p0, std::size_t n, std::vector<ProbeScratch>& scratch,
                      Wave& w) {
  const int kk = tr.kk, base = tr.base, k = kk * kk;
  const std::size_t texels = std::size_t(6) * base * base;
  const auto make = [&](std::size_t q, std::size_t texel, glm::vec3* org, glm::vec3* dirs) {
    const int face = int(texel / (std::size_t(base) * base)), v = int(texel / base % base), u = int(texel % base);
    detail::Rng rng = probe_rng(tr, p0 + q, Draw::BaseTexel, texel);
    for (int s = 0; s < k; ++s) {
      const int a = s % kk, b = s / kk;
      const double s1 = 2.0 * (u + (a + rng.uniform()) / kk) / base - 1.0;
      const double t1 = 2.0 * (v + (b + rng.uniform()) / kk) / base - 1.0;
      dirs[s] = glm::vec3(glm::normalize(cube_direction(face, s1, t1)));
      org[s] = scratch[q].x;
    }
  };
  const auto take = [&](std::size_t q, std::size_t texel, const glm::vec3* dirs, const detail::Hit* hits) {
    const int v = int(texel / base % base), u = int(texel % base);
    const double omega = cube_texel_solid_angle(u, v, base) / k;
    int escapes = 0;
    for (int s = 0; s < k; ++s) {
      escapes += !hits[s].hit();
      take_ray(tr, scratch[q], p0 + q, texel * k + s, dirs[s], hits[s], omega);
    }
    scratch[q].cls[texel] = std::uint8_t(escapes == k ? 1 : escapes == 0 ? 0 : 2);
  };
  trace_tasks(tr, w, n, k, [&](std::size_t) { return texels; }, make, take);
}

// ---- bounce paths --------------------------------------------------------------------

// The next ray of path `pa` (cosine-weighted about the shading normal at
// its last hit, the albedo there taken into its weight); false where the
// hit's normal is degenerate (the path ends).
bool next_bounce(const ProbeTracing& tr, BouncePath& pa) {
  const Mesh& mesh = tr.scene.mesh;
  const detail::Hit& h = pa.hit;
  const glm::uvec3& tri = mesh.triangles[h.triangle];
  const float w0 = 1.0f - h.u - h.v;
  glm::dvec3 ns = glm::dvec3(mesh.normals[tri[0]] * w0 + mesh.normals[tri[1]] * h.u + mesh.normals[tri[2]] * h.v);
  if (!(glm::length(ns) > 0)) {
    const glm::vec3 a = mesh.positions[tri[0]], b = mesh.positions[tri[1]], c = mesh.positions[tri[2]];
    ns = glm::dvec3(glm::cross(b - a, c - a));
  }
  if (!(glm::length(ns) > 0)) return false;
  ns = glm::normalize(ns);
  const glm::vec3 albedo =
      tr.o.override_albedo ? tr.o.albedo : glm::clamp(tr.scene.albedo(h.triangle, h.u, h.v), 0.0f, 1.0f);
  pa.weight *= glm::dvec3(albedo);
  pa.w = detail::sample_cosine(pa.rng, ns);
  pa.from = glm::vec3(pa.origin + ns * double(tr.offset));
  return true;
}

// Path `pa`'s ray met `h`: an escape lights the probe through the
// band-limited map (albedo x Y_k(d0) omega x Y_j(w)) and ends the path, as
// a back face does (black); a front hit continues it.
void end_bounce(const ProbeTracing& tr, ProbeScratch& sc, BouncePath& pa, const detail::Hit& h) {
  if (h.hit()) {
    pa.alive = h.front;  // back faces are black
    pa.origin = glm::dvec3(pa.from) + pa.w * double(h.t);
    pa.hit = h;
    return;
  }
  pa.alive = false;
  const int nc = tr.nc, nb = tr.nb, channels = tr.t.channels;
  const glm::dvec3 d(pa.dir0);
  sh::eval(tr.o.bands, d.x, d.y, d.z, sc.yk.data());
  sh::eval(tr.o.bounce_bands, pa.w.x, pa.w.y, pa.w.z, sc.yj.data());
  for (int c = 0; c < channels; ++c) {
    const double wc = channels == 1 ? pa.weight.x : pa.weight[c];
    double* B = sc.bounce.data() + std::size_t(c) * nc * nb;
    for (int kq = 0; kq < nc; ++kq)
      for (int jq = 0; jq < nb; ++jq)
        B[std::size_t(kq) * nb + std::size_t(jq)] += wc * sc.yk[std::size_t(kq)] * sc.yj[std::size_t(jq)];
  }
}

// The block's bounce paths (scratch[q].paths, q < n), a wavefront per
// bounce: every live path's next ray at once.
void trace_bounces(const ProbeTracing& tr, std::vector<ProbeScratch>& scratch, std::size_t n, Wave& w) {
  const auto dead = [](const BouncePath& pa) { return !pa.alive; };
  const auto prune = [&](std::size_t q) {
    std::vector<BouncePath>& paths = scratch[q].paths;
    paths.erase(std::remove_if(paths.begin(), paths.end(), dead), paths.end());
  };
  for (int bounce = 0; bounce < tr.o.bounces; ++bounce) {
    for_each_parallel(n, 1, [&](std::size_t q) {
      for (BouncePath& pa : scratch[q].paths) pa.alive = next_bounce(tr, pa);
      prune(q);
    });
    trace_tasks(
        tr, w, n, 1, [&](std::size_t q) { return scratch[q].paths.size(); },
        [&](std::size_t q, std::size_t j, glm::vec3* org, glm::vec3* dirs) {
          org[0] = scratch[q].paths[j].from;
          dirs[0] = glm::vec3(scratch[q].paths[j].w);
        },
        [&](std::size_t q, std::size_t j, const glm::vec3*, const detail::Hit* hits) {
          end_bounce(tr, scratch[q], scratch[q].paths[j], hits[0]);
        });
    for_each_parallel(n, 1, prune);
  }
}

// ---- refinement ----------------------------------------------------------------------

// A probe's finest texels to refine, in (face, v, u, y, x) order: those of
// mixed base texels and of those beside a texel of another class (an edge
// that slipped between the base rays: a sliver of sky at a grazing
// angle); the finest texels of the other all-visible base texels set.
void plan_refinement(const ProbeTracing& tr, ProbeScratch& sc, std::size_t p) {
  const int kk = tr.kk, base = tr.base, refine = tr.refine;
  sc.refines.clear();
  for (int face = 0; face < 6; ++face)
    for (int v = 0; v < base; ++v)
      for (int u = 0; u < base; ++u) {
        const std::uint8_t c0 = sc.cls[(std::size_t(face) * base + std::size_t(v)) * base + std::size_t(u)];
        bool edge = c0 == 2 || kk == 1;
        for (int dv = -1; dv <= 1 && !edge; ++dv)
          for (int du = -1; du <= 1 && !edge; ++du) {
            const int nu = u + du, nv = v + dv;
            if (nu < 0 || nv < 0 || nu >= base || nv >= base) continue;
            edge = sc.cls[(std::size_t(face) * base + std::size_t(nv)) * base + std::size_t(nu)] != c0;
          }
        for (int y = 0; y < refine; ++y)
          for (int x2 = 0; x2 < refine; ++x2) {
            const int fu = u * refine + x2, fv = v * refine + y;
            if (!edge && c0 == 1) set_bit(tr, sc, face, fu, fv);
            if (!edge) continue;
            const std::size_t texel = (std::size_t(face) * tr.r + std::size_t(fv)) * tr.r + std::size_t(fu);
            sc.refines.push_back(RefineTask{probe_rng(tr, p, Draw::FinestTexel, texel), face, fu, fv});
          }
      }
}

// `count` jittered directions of a finest texel, `side` x `side` sub-texels.
void refine_dirs(const ProbeTracing& tr, RefineTask& task, int side, int count, glm::vec3* dirs) {
  for (int c = 0; c < count; ++c) {
    const double s1 = 2.0 * (task.fu + ((c % side) + task.rng.uniform()) / side) / tr.r - 1.0;
    const double t1 = 2.0 * (task.fv + ((c / side) + task.rng.uniform()) / side) / tr.r - 1.0;
    dirs[c] = glm::vec3(glm::normalize(cube_direction(task.face, s1, t1)));
  }
}

// The finest texels of the block's probes (scratch[q].refines, q < n):
// 2 x 2 jittered rays each, visible when all escape; where some do
// (mixed), 4 x 4 more, one per sub-texel (partial_mask, bit 4 sy + sx).
void refine_texels(const ProbeTracing& tr, std::size_t p0, std::size_t n, std::vector<ProbeScratch>& scratch,
                   std::vector<ProbeRecord>& records, Wave& w) {
  const auto count = [&](std::size_t q) { return scratch[q].refines.size(); };
  w.occlusion = true;  // a ProbeOptions::tracer traces closest hits all the same
  const auto make = [&](int side, std::size_t q, std::size_t j, glm::vec3* org, glm::vec3* dirs) {
    std::fill(org, org + side * side, scratch[q].x);
    refine_dirs(tr, scratch[q].refines[j], side, side * side, dirs);
  };
  trace_tasks(
      tr, w, n, 4, count, [&](std::size_t q, std::size_t j, glm::vec3* org, glm::vec3* dirs) { make(2, q, j, org, dirs); },
      [&](std::size_t q, std::size_t j, const glm::vec3*, const detail::Hit* hits) {
        RefineTask& task = scratch[q].refines[j];
        int open = 0;
        for (int c = 0; c < 4; ++c) open += !hits[c].hit();
        if (open == 4) set_bit(tr, scratch[q], task.face, task.fu, task.fv);
        task.mixed = open > 0 && open < 4;
      });
  for_each_parallel(n, 1, [&](std::size_t q) {
    std::vector<RefineTask>& v = scratch[q].refines;
    v.erase(std::remove_if(v.begin(), v.end(), [](const RefineTask& t) { return !t.mixed; }), v.end());
  });
  trace_tasks(
      tr, w, n, 16, count, [&](std::size_t q, std::size_t j, glm::vec3* org, glm::vec3* dirs) { make(4, q, j, org, dirs); },
      [&](std::size_t q, std::size_t j, const glm::vec3*, const detail::Hit* hits) {
        const RefineTask& task = scratch[q].refines[j];
        std::uint16_t mask = 0;
        for (int c = 0; c < 16; ++c)
          if (!hits[c].hit()) mask = std::uint16_t(mask | (1u << c));
        if (mask == 0xffff) {
          set_bit(tr, scratch[q], task.face, task.fu, task.fv);
        } else if (mask != 0) {
          records[p0 + q].partial_nodes.push_back(probe_node_id(tr.r, task.face, 0, task.fu, task.fv));
          records[p0 + q].partial_mask.push_back(mask);
        }
      });
  w.occlusion = false;
}

// ---- a block of probes ---------------------------------------------------------------

// The probe's state and, stored, its visibility nodes, depth moments and
// bounce matrices.
void finish_record(const ProbeTracing& tr, const ProbeScratch& sc, ProbeRecord& rec) {
  const int N = tr.N;
  if (2 * sc.back > sc.total) {
    rec.state = ProbeState::Invalid;
  } else if (sc.hit_count == 0) {
    rec.state = ProbeState::Sky;
  } else {
    rec.state = ProbeState::Stored;
    bool complement = false;
    rec.nodes = probe_visibility_nodes(sc.bits, tr.r, complement);
    rec.complement = complement;
    rec.depth.resize(2 * std::size_t(N) * N);
    const double cap = tr.t.depth_cap;
    for (std::size_t i2 = 0; i2 < std::size_t(N) * N; ++i2) {
      const double mean = sc.count[i2] > 0 ? sc.m1[i2] / sc.count[i2] : cap,
                   mean2 = sc.count[i2] > 0 ? sc.m2[i2] / sc.count[i2] : cap * cap;
      rec.depth[2 * i2] = std::uint16_t(std::lround(std::clamp(mean / cap, 0.0, 1.0) * 65535.0));
      rec.depth[2 * i2 + 1] = std::uint16_t(std::lround(std::clamp(mean2 / (cap * cap), 0.0, 1.0) * 65535.0));
    }
    rec.bounce.assign(sc.bounce.begin(), sc.bounce.end());
  }
}

// Probe p of the grid placed (moved off surfaces) and its sums cleared.
void start_probe(const ProbeTracing& tr, ProbeScratch& sc, std::size_t p, ProbeRecord& rec) {
  const ProbeGrid& grid = tr.t.grid;
  const int i = int(p % std::size_t(grid.dims[0]));
  const int j = int((p / std::size_t(grid.dims[0])) % std::size_t(grid.dims[1]));
  const int k = int(p / (std::size_t(grid.dims[0]) * std::size_t(grid.dims[1])));
  sc.x = detail::lift_off_surfaces(tr.rays, tr.scene.mesh, tr.lift, glm::vec3(grid.position(i, j, k)));
  rec.position = sc.x;
  std::fill(sc.bits.begin(), sc.bits.end(), 0u);
  std::fill(sc.m1.begin(), sc.m1.end(), 0.0);
  std::fill(sc.m2.begin(), sc.m2.end(), 0.0);
  std::fill(sc.count.begin(), sc.count.end(), 0.0);
  std::fill(sc.bounce.begin(), sc.bounce.end(), 0.0);
  sc.back = sc.hit_count = sc.total = 0;
  sc.paths.clear();
  sc.refines.clear();
}

// Probes [p0, p0 + n) traced into records, a wavefront at a time: their
// base rays, each bounce of their paths, each stage of their refinement.
void trace_block(const ProbeTracing& tr, std::size_t p0, std::size_t n, std::vector<ProbeScratch>& scratch,
                 std::vector<ProbeRecord>& records, Wave& w) {
  for_each_parallel(n, 1, [&](std::size_t q) { start_probe(tr, scratch[q], p0 + q, records[p0 + q]); });
  trace_base_cubes(tr, p0, n, scratch, w);
  trace_bounces(tr, scratch, n, w);
  for_each_parallel(n, 1, [&](std::size_t q) { plan_refinement(tr, scratch[q], p0 + q); });
  refine_texels(tr, p0, n, scratch, records, w);
  for_each_parallel(n, 1, [&](std::size_t q) { finish_record(tr, scratch[q], records[p0 + q]); });
}

// Probes a block traces together: kBlockRays base rays at most, 1 to kProbeBlock.
std::size_t probe_block(const ProbeTracing& tr) {
  const std::size_t rays = std::size_t(6) * tr.base * tr.base * tr.kk * tr.kk;
  return std::clamp<std::size_t>(kBlockRays / rays, 1, kProbeBlock);
}

// The probes' records packed into t, in grid order.
void pack_records(ProbeTransfer& t, const std::vector<ProbeRecord>& records) {
  const std::size_t P = records.size();
  t.state.resize(P);
  t.positions.resize(P);
  t.vis_offsets.assign(1, 0);
  t.partial_offsets.assign(1, 0);
  for (std::size_t p = 0; p < P; ++p) {
    const ProbeRecord& rec = records[p];
    t.state[p] = rec.state;
    t.positions[p] = rec.position;
    if (rec.state != ProbeState::Stored) continue;
    t.vis_nodes.insert(t.vis_nodes.end(), rec.nodes.begin(), rec.nodes.end());
    t.vis_offsets.push_back(t.vis_nodes.size());
    t.vis_complement.push_back(rec.complement ? 1 : 0);
    t.partial_nodes.insert(t.partial_nodes.end(), rec.partial_nodes.begin(), rec.partial_nodes.end());
    t.partial_mask.insert(t.partial_mask.end(), rec.partial_mask.begin(), rec.partial_mask.end());
    t.partial_offsets.push_back(t.partial_nodes.size());
    t.depth.insert(t.depth.end(), rec.depth.begin(), rec.depth.end());
    t.bounce.insert(t.bounce.end(), rec.bounce.begin(), rec.bounce.end());
  }
}

}  // namespace

ProbeTransfer compute_probe_transfer(const Scene& scene, const ProbeGrid& grid, const ProbeOptions& o,
                                     const Progress& progress) {
  check_probe_options(o);
  // Before anything is allocated per probe (a hand-made grid has not been through probe_grid).
  if (const std::string p = probe_dims_problem(grid.dims); !p.empty()) throw Error("probe grid: " + p);
  const Mesh& mesh = scene.mesh;
  detail::check_ray_offset(o.offset, mesh, "--offset");
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);
  const detail::RayScene rays(mesh, /*robust=*/true);
  const float offset = float(o.offset > 0 ? o.offset : detail::default_ray_offset(mesh));
  double smallest = 0.0;
  ProbeTransfer t = probe_header(scene, grid, o, smallest);
  (void)smallest;  // the lift below is a twentieth of it (detail::probe_lift)

  const int r = o.cube_res, base = std::max(1, r / 4);
  const ProbeTracing tr{scene,
                        rays,
                        o,
                        t,
                        offset,
                        r,
                        int(std::lround(std::sqrt(double(o.rays_per_texel)))),
                        o.depth_res,
                        sh::num_coeffs(o.bands),
                        o.mode == TransferMode::Interreflected ? sh::num_coeffs(o.bounce_bands) : 0,
                        base,
                        r / base,
                        (std::size_t(6) * r * r + 31) / 32,
                        detail::probe_lift(grid)};
  const std::size_t P = grid.count();
  std::vector<ProbeRecord> records(P);
  const std::size_t block = std::min(probe_block(tr), P);
  std::vector<ProbeScratch> scratch(block, ProbeScratch(tr));
  Wave wave;
  detail::ProgressTicker ticker(progress, P, "probes");
  ticker.start();
  for (std::size_t p0 = 0; p0 < P && !ticker.cancelled(); p0 += block) {
    const std::size_t n = std::min(block, P - p0);
    trace_block(tr, p0, n, scratch, records, wave);
    ticker.tick(n);
  }
  ticker.finish();
  pack_records(t, records);
  if (const std::string problem = probe_transfer_problem(t); !problem.empty())
    throw Error("computed probe volume is inconsistent (a bug): " + problem);
  return t;
}
ProbeOcclusion::ProbeOcclusion(const Mesh& mesh, const ProbeGrid& grid)
    : rays_(std::make_unique<detail::RayScene>(mesh, /*robust=*/true)), offset_(detail::default_ray_offset(mesh)) {
  const glm::dvec3 sp = grid.spacing();
  double smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (sp[a] > 0) smallest = std::min(smallest, sp[a]);
  spread_ = std::isfinite(smallest) ? 0.1 * smallest : 0.0;
}

ProbeOcclusion::~ProbeOcclusion() = default;

double ProbeOcclusion::operator()(const glm::dvec3& probe, const glm::dvec3& p) const {
  check_ray_origin(p, 0, "probe visibility");  // the query point: a caller's, not the grid's
  detail::enable_ftz_daz();
  const glm::dvec3 axis = probe - p;
  const double len = glm::length(axis);
  if (!(len > 0)) return 1.0;
  glm::dvec3 t, b;
  detail::basis(axis / len, t, b);
  const glm::dvec3 ends[5] = {probe, probe + t * spread_, probe - t * spread_, probe + b * spread_, probe - b * spread_};
  int open = 0;
  for (const glm::dvec3& e : ends) {
    const glm::dvec3 d = e - p;
    const double dl = glm::length(d);
    open += dl <= 0 || !rays_->occluded1(glm::vec3(p), glm::vec3(d / dl), float(offset_), float(dl));
  }
  return open / 5.0;
}

namespace detail {

double probe_lift(const ProbeGrid& grid) {
  const glm::dvec3 sp = grid.spacing();
  const double largest = std::max({sp.x, sp.y, sp.z});
  double smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (sp[a] > 0) smallest = std::min(smallest, sp[a]);
  if (!std::isfinite(smallest)) smallest = largest > 0 ? largest : 1.0;
  return 0.05 * smallest;
}

glm::vec3 lift_off_surfaces(const RayScene& rays, const Mesh& mesh, double lift, glm::vec3 x) {
  for (int move = 0; move < 4; ++move) {
    glm::dvec3 at;
    const std::uint32_t f = rays.closest_point(x, float(lift), at);
    if (f == ~0u) break;
    const glm::uvec3& tri = mesh.triangles[f];
    const glm::dvec3 a(mesh.positions[tri[0]]), b(mesh.positions[tri[1]]), c(mesh.positions[tri[2]]);
    glm::dvec3 n = glm::cross(b - a, c - a);
    if (!(glm::length(n) > 0)) break;
    n = glm::normalize(n);
    const double side = glm::dot(glm::dvec3(x) - at, n);
    const double sign = side < -1e-3 * lift ? -1.0 : 1.0;
    x = glm::vec3(glm::dvec3(x) + n * (sign * 2.0 * lift - side));
  }
  return x;
}

}  // namespace detail

}  // namespace prt
